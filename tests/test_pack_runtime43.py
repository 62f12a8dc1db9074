"""Packed 4.3 projects in the official Spine 4.3 runtime (spine-core 4.3, ``tests/runtime43``).

The render harness has no 4.3 runtime, so the proof is the runtime's own numbers: the 4.3
corpus projects, upgraded and packed (``upgrade --pack``), load, every attachment keeps its
world vertices, and every mesh samples the same texels: at its vertices and at points inside
its triangles, the UVs the runtime computes on the packed pages read (bilinearly) what the
UVs it computes on the unpacked pages read.

Both 4.3 projects come on full power-of-two pages that no packing can halve, so each is first
given pages with a transparent margin (a size no longer a power of two, every region where it
was): packing must then at least take the margin away, and the meshes are checked on pages
packed anew.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from spinemesh.atlas import read_atlas
from spinemesh.files.atomic import atomic_write_png, atomic_write_text
from spinemesh.images.decode import load_rgba
from spinemesh.images.sources import AtlasImages
from spinemesh.upgrade import Options, upgrade_project

from test_pack import bilinear
from test_skeleton_binary_v43 import PROJECTS43, _corpus_json, _node, runtime43  # noqa: F401  (fixture)


def _samples(uvs: np.ndarray, triangles: np.ndarray, page: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Bilinear samples of ``page`` at the vertices and at fixed barycentric points of every triangle."""
    h, w = page.shape[:2]
    points = np.concatenate([uvs, np.einsum("kj,tjd->tkd", weights, uvs[triangles]).reshape(-1, 2)])
    return bilinear(page, points * (w, h))


#: Transparent texels added right of and below every page.
MARGIN = 96


def _with_margin(project, dest):
    """A copy of ``project`` whose pages have a transparent margin (regions stay where they were)."""
    dest.mkdir()
    for f in project.iterdir():
        if f.is_file() and not f.name.endswith((".atlas", ".png")):
            (dest / f.name).write_bytes(f.read_bytes())
    for path in project.glob("*.atlas"):
        atlas = read_atlas(path)
        for page in atlas.pages:
            rgba = np.pad(load_rgba(project / page.name), ((0, MARGIN), (0, MARGIN), (0, 0)))
            atomic_write_png(dest / page.name, rgba)
            for e in page.entries:
                if e.key == "size":
                    e.values = [str(rgba.shape[1]), str(rgba.shape[0])]
        atomic_write_text(dest / path.name, atlas.dumps())
    return dest


@pytest.mark.parametrize("name", PROJECTS43)
def test_packed_43_project_samples_alike(name, runtime43, tmp_path):  # noqa: F811
    project = _with_margin(_corpus_json(name).parent, tmp_path / "project")
    plain, packed = tmp_path / "plain", tmp_path / "packed"
    upgrade_project(project, plain, Options(repack=True), mesh_cache={})
    result = upgrade_project(project, packed, Options(repack=True, pack=True), mesh_cache={})
    assert not result.partial, result.errors
    skeleton = _corpus_json(name).name
    assert (packed / skeleton).read_bytes() == (plain / skeleton).read_bytes()
    rng = np.random.default_rng(5)
    weights = rng.dirichlet(np.ones(3), 12)
    proved = 0
    for row in result.atlases:
        if row.status != "packed":
            continue
        worlds = {}
        for side in (plain, packed):
            out = tmp_path / f"{side.name}-{row.atlas.replace('/', '~')}.json"
            _node(runtime43, "world.mjs", side / row.atlas, side / skeleton, out)
            worlds[side] = json.loads(out.read_text())
        assert worlds[plain].keys() == worlds[packed].keys()
        pages = {side: [load_rgba(AtlasImages.page_path(a, p.name, side)) for p in a.pages]
                 for side in (plain, packed) for a in [read_atlas(side / row.atlas)]}
        for key, before in worlds[plain].items():
            after = worlds[packed][key]
            np.testing.assert_allclose(after["world"], before["world"], atol=1e-4, err_msg=key)
            if before["type"] != "mesh" or len(pages[plain]) != 1 or len(pages[packed]) != 1:
                continue
            tris = np.reshape(before["triangles"], (-1, 3))
            a = _samples(np.reshape(before["uvs"], (-1, 2)), tris, pages[plain][0], weights)
            b = _samples(np.reshape(after["uvs"], (-1, 2)), tris, pages[packed][0], weights)
            np.testing.assert_allclose(b, a, atol=0.5, err_msg=key)
            proved += 1
    assert proved, f"no mesh of {name} was checked on a packed atlas: {[(a.atlas, a.reason) for a in result.atlases]}"
