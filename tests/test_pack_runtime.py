"""Proof with the official Spine runtime: packed projects render like the unpacked ones.

A representative share, to keep CI short: one project per harness runtime (3.8, 4.0, 4.1)
from the corpus, packed as they are (artists' meshes), and our own demo upgraded and then
packed (4.2, stripped whitespace, a rotated region, a sequence). Each skeleton renders its
setup pose and two frames of its first animation with the original and the packed atlas;
every pixel must agree within 2/255 (but a share of 1e-5, see ``prove_pack.MAX_OFF_SHARE``).
``scripts/prove_pack.py`` proves every example and corpus project the same way.
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

from conftest import REPO
from spinemesh.demo import make_demo_project

sys.path.insert(0, str(REPO / "scripts"))

#: One corpus project per runtime of the harness, each with an atlas that packing shrinks (PNG pages:
#: an atlas of lossy WebP pages, as most 4.1 corpus projects have, is kept as it was).
SHARE = {"isk-cactus": "3.8", "bom-tiger": "4.0", "jt-mia": "4.1"}


def _prove(tool: Path, project: Path, work: Path, upgrade: bool = False):
    from prove_pack import prove_project

    rows = prove_project(tool, project, work, animations=1, upgrade=upgrade)
    proved = [r for r in rows if r.packed and r.status != "not rendered"]
    assert proved, f"no skeleton of {project.name} was rendered on a packed atlas: {rows}"
    for r in rows:
        assert r.status != "FAIL", f"{r.project}/{r.skeleton}: {r.cause} {r.details}"
    return proved


@pytest.mark.parametrize("name", sorted(SHARE))
def test_packed_corpus_project_renders_alike(name, corpus, spine_runtime, tmp_path):
    proved = _prove(spine_runtime, corpus / name, tmp_path)
    assert all(r.version.startswith(SHARE[name]) for r in proved)


def test_upgraded_and_packed_demo_renders_alike(spine_runtime, tmp_path):
    demo = make_demo_project(tmp_path / "demo", with_images_folder=False)
    _prove(spine_runtime, demo, tmp_path / "work", upgrade=True)
