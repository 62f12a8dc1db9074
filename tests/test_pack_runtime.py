"""Proof with the official Spine runtime: packed projects render like the unpacked ones.

A representative share, to keep CI short (``scripts/prove_pack.py`` proves every example and
corpus project the same way):

- one official example per runtime of the harness (3.8, 4.0, 4.1, 4.2), packed as exported or
  upgraded then packed as ``upgrade --pack`` does;
- corpus projects: a 3.8 atlas with regions stored turned by 90 degrees (and packed turned),
  a 4.0 project, and a 4.1 project whose pages are given a ``MipMap`` filter first, so that
  packing pads for mipmaps and no region reads another's texels at the first mipmap level
  (the harness itself draws without mipmaps);
- our own demo upgraded and then packed (4.2, stripped whitespace, a rotated region, a sequence).

Each skeleton renders its setup pose and two frames of its first animation with the original and
the packed atlas; every pixel must agree within 2/255 (but a share of 1e-5, see
``prove_pack.MAX_OFF_SHARE``).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from conftest import REPO
from spinemesh.atlas import read_atlas
from spinemesh.demo import make_demo_project

sys.path.insert(0, str(REPO / "scripts"))

#: Corpus projects, each with an atlas of PNG pages that packing shrinks (an atlas of lossy WebP
#: pages, as most 4.1 corpus projects have, is kept as it was): name -> (version, MipMap pages).
SHARE = {"bom-tiger": ("4.0", False), "jt-mia": ("4.1", True)}

#: Official examples, one per harness runtime: (version, project, upgraded first, skeleton file).
#: Packed as exported, most examples keep their tight atlases; these are packed.
EXAMPLES = [
    ("3.8", "stretchyman", False, "stretchyman-pro.skel"),
    ("4.0", "alien", True, "alien-pro.skel"),
    ("4.1", "dragon", False, "dragon-ess.skel"),
    ("4.2", "chibi-stickers", False, "chibi-stickers.skel"),
]

#: A 3.8 corpus project whose atlas stores regions turned by 90 degrees.
ROTATED = ("vonder-robin", "Robin.atlas")


def _prove(tool: Path, project: Path, work: Path, **kw):
    from prove_pack import prove_project

    rows = prove_project(tool, project, work, animations=1, **kw)
    proved = [r for r in rows if r.packed and r.status != "not rendered"]
    assert proved, f"no skeleton of {project.name} was rendered on a packed atlas: {rows}"
    for r in rows:
        assert r.status != "FAIL", f"{r.project}/{r.skeleton}: {r.cause} {r.details}"
    return proved


@pytest.mark.parametrize("version,name,upgrade,skeleton", EXAMPLES, ids=[f"{v}-{n}" for v, n, _, _ in EXAMPLES])
def test_packed_example_renders_alike(version, name, upgrade, skeleton, examples, spine_runtime, tmp_path):
    proved = _prove(spine_runtime, examples / version / name, tmp_path, upgrade=upgrade, skeletons=skeleton)
    assert [r.skeleton for r in proved] == [skeleton]
    assert all(r.version.startswith(version) and r.renders >= 3 for r in proved)


@pytest.mark.parametrize("name", sorted(SHARE))
def test_packed_corpus_project_renders_alike(name, corpus, spine_runtime, tmp_path):
    version, mipmaps = SHARE[name]
    proved = _prove(spine_runtime, corpus / name, tmp_path, mipmaps=mipmaps)
    assert all(r.version.startswith(version) for r in proved)
    if mipmaps:
        from prove_pack import MIP_REQUIRED

        assert all(r.mip_after is not None and r.mip_after >= MIP_REQUIRED for r in proved), proved
        # the first level's texels under every region are the original's (blocks falling alike):
        # jt-mia's hands hold art their meshes do not draw, which that level averages in
        for r in proved:
            level1 = next(t for t in r.mip_texels if t[0] == 1)
            assert level1[1] <= 2 and level1[2] == 0 and level1[3] >= 30, r.mip_texels


def _turned(atlas: Path) -> int:
    parsed = read_atlas(atlas)
    return sum(1 for r in parsed.regions if r.geometry(str(atlas)).degrees)


def test_packed_rotated_regions_render_alike(corpus, spine_runtime, tmp_path):
    name, atlas = ROTATED
    assert _turned(corpus / name / atlas) > 0
    proved = _prove(spine_runtime, corpus / name, tmp_path)
    assert all(r.version.startswith("3.8") for r in proved)
    assert _turned(tmp_path / "out" / atlas) > 0


def test_upgraded_and_packed_demo_renders_alike(spine_runtime, tmp_path):
    demo = make_demo_project(tmp_path / "demo", with_images_folder=False)
    _prove(spine_runtime, demo, tmp_path / "work", upgrade=True)


def test_mip_texel_check_sees_art_beyond_what_is_drawn_and_not_where_blocks_fall():
    """The proof's texel check of a mipmap level: a region moved by one texel reads the same
    level-1 texels as before once its blocks fall alike (0), but not when the page it is moved to
    lacks art of the region beyond what is drawn (the level averages it in), nor at level 2 when
    a neighbour of the original lies within that level's reach and counts only when its own."""
    from prove_pack import mip_texel_difference

    original = np.zeros((64, 64, 4), np.uint8)
    original[16:32, 16:32] = 200         # the region's stored rectangle, all art
    drawn = np.zeros((16, 16), bool)
    drawn[1:12, 1:15] = True             # its mesh draws rows 17-27 only: rows 28-31 are art not drawn
    packed = np.zeros_like(original)
    packed[22:38, 25:41] = original[16:32, 16:32]   # moved by (6, 9): its columns' blocks fall otherwise
    own = (16, 16, 32, 32)
    assert mip_texel_difference(original, packed, (16, 16), (22, 25), drawn, 1, True, own=own) == 0
    cut = packed.copy()
    # the art beyond the drawn rows and their ring left out (last drawn row 33, ring 34): the
    # last drawn row lies in the second half of its block, whose level texel reads rows 34-35
    cut[22 + 13:38] = 0
    assert mip_texel_difference(original, cut, (16, 16), (22, 25), drawn, 1, True, own=own) > 2
    neighbour = original.copy()
    neighbour[16:32, 33:35] = 255         # another region 1 texel right of the rectangle
    assert mip_texel_difference(neighbour, packed, (16, 16), (22, 25), drawn, 2, True, own=own) == 0
    assert mip_texel_difference(neighbour, packed, (16, 16), (22, 25), drawn, 2, True) > 2


@pytest.mark.parametrize("column,level", [(33, 0), (34, 1), (35, 1), (36, 2), (39, 2), (40, 3), (48, 4)])
def test_mipmap_check_sees_a_neighbour_by_its_distance(column, level):
    """The proof's mipmap check: a region drawn over texels 16-31 (both axes) and a neighbour's
    opaque column; a level-``L`` texel averages a block of ``2**L``, and bilinear sampling from the
    last drawn texel (in the second half of its block) reads the next block too."""
    from prove_pack import mip_clean_level

    alpha = np.zeros((64, 64), np.uint8)
    alpha[16:32, 16:32] = 255
    alpha[:, column] = 255
    core = np.zeros_like(alpha, bool)
    core[15:33, 15:33] = True  # what it draws grown by the texel bilinear sampling reads
    assert mip_clean_level(alpha, core, core) == level
