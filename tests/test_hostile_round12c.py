"""Hostile round twelve, third part: ``pack`` and its pages.

The rule: a packed atlas draws exactly like the original in the official runtimes and never
grows in bytes; where that cannot be proved the atlas is kept, with one line saying why. Each case
is the demo project upgraded to meshes (``meshed``, made by our own code), laid out or given pages
as a studio's export may have them.
"""

from __future__ import annotations

import shutil
from pathlib import Path

from test_hostile_round11c import _cli, _rows


def _split(meshed: Path, project: Path) -> Path:
    """``meshed`` laid out as many games keep it: atlases and pages in ``art/``, skeletons in ``spine/``."""
    for name, folder in (("demo.atlas", "art"), ("demo.png", "art"), ("demo.json", "spine"),
                         ("demo-binary.skel", "spine")):
        (project / folder).mkdir(parents=True, exist_ok=True)
        shutil.copy(meshed / name, project / folder / name)
    return project


def test_an_atlas_beside_its_skeletons_folder_is_packed_by_their_outlines(meshed, tmp_path):
    """``art/`` and ``spine/`` were taken for two projects of a folder of projects: the atlas was
    packed without a skeleton drawing it, every region by its rectangle ("not drawn by any
    skeleton"). Sibling folders that hold only atlases and only skeletons are one project."""
    from spinemesh.project import find_projects

    project = _split(meshed, tmp_path / "game")
    assert find_projects(project) == [project]
    r = _cli("pack", project, "--out", tmp_path / "o", "--report", tmp_path / "r.json", "-j", "1", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    (row,) = _rows(tmp_path / "r.json").values()
    assert row["status"] == "packed" and row["by_outline"] == 8 and row["by_rectangle"] == 0, row
    # halves beside a whole project stay projects of their own: which skeletons draw what is unknown
    _split(meshed, tmp_path / "lib" / "a")
    shutil.copytree(meshed, tmp_path / "lib" / "b")
    assert find_projects(tmp_path / "lib") == [tmp_path / "lib" / "a", tmp_path / "lib" / "b"]
