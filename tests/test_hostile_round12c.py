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


def _draws_alike(tool: Path, before: Path, after: Path, scratch: Path, atlas: str = "demo.atlas") -> int:
    """Renders of ``demo.json`` in the official 4.2 runtime with ``before``'s atlas and with
    ``after``'s, the setup pose: each pixel alike (within the harness's tolerance); how many renders."""
    from runtime_tool import render, render_difference

    a = render(tool, before / atlas, before / "demo.json", None, "0", scratch / "a")
    b = render(tool, after / atlas, after / "demo.json", None, "0", scratch / "b",
               frame_from=scratch / "a.frame.json")
    assert a and len(a) == len(b)
    for x, y in zip(a, b):
        diff = render_difference(x, y)
        assert diff["off"] == 0 and diff["lost"] == 0, diff
    return len(a)


def test_larger_files_packs_lossy_webp_pages_and_they_draw_alike(meshed, tmp_path, spine_runtime):
    """``--larger-files`` promises a packed atlas "even where its files take more bytes": an atlas
    of lossy WebP pages was kept all the same. Its pages written losslessly hold the texels the
    lossy ones decode to: packed, it draws what it drew."""
    from test_pack import _webp_project

    from spinemesh.pack.run import is_lossy_webp

    project = _webp_project(meshed, tmp_path / "p", lossless=False)
    assert is_lossy_webp(project / "demo.webp")
    r = _cli("pack", project, "--out", tmp_path / "o", "--report", tmp_path / "r.json", "-j", "1",
             "--larger-files", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    (row,) = _rows(tmp_path / "r.json").values()
    assert row["status"] == "packed" and row["texels_after"] < row["texels_before"], row
    assert not is_lossy_webp(tmp_path / "o" / "demo.webp")
    assert _draws_alike(spine_runtime, project, tmp_path / "o", tmp_path / "r")
    r = _cli("pack", project, "--out", tmp_path / "o2", "--report", tmp_path / "r2.json", "-j", "1", cwd=tmp_path)
    (row,) = _rows(tmp_path / "r2.json").values()  # without it: kept, and the reason names the option
    assert row["status"] == "kept" and "lossy WebP" in row["reason"] and "--larger-files" in row["reason"], row
