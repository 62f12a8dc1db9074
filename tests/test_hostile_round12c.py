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
    skeleton"). Folders that hold only atlases and only skeletons are one project, the nearest
    folder above them all."""
    from spinemesh.project import find_projects

    project = _split(meshed, tmp_path / "game")
    assert find_projects(project) == [project]
    r = _cli("pack", project, "--out", tmp_path / "o", "--report", tmp_path / "r.json", "-j", "1", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    (row,) = _rows(tmp_path / "r.json").values()
    assert row["status"] == "packed" and row["by_outline"] == 8 and row["by_rectangle"] == 0, row
    # halves in a folder of their own are joined there; beside a whole project they stay projects
    # of their own (which skeletons draw which atlas is not known there)
    _split(meshed, tmp_path / "lib" / "a")
    shutil.copytree(meshed, tmp_path / "lib" / "b")
    assert find_projects(tmp_path / "lib") == [tmp_path / "lib" / "a", tmp_path / "lib" / "b"]
    for half in ("art", "spine"):
        (tmp_path / "lib" / "a" / half).rename(tmp_path / "lib" / half)
    assert find_projects(tmp_path / "lib") == [tmp_path / "lib" / "art", tmp_path / "lib" / "b",
                                               tmp_path / "lib" / "spine"]
    # atlases a folder deeper than the skeletons (art/characters/, art/ui/): one project all the same
    deeper = tmp_path / "deeper"
    _split(meshed, deeper)
    (deeper / "art").rename(deeper / "characters")
    (deeper / "art").mkdir()
    (deeper / "characters").rename(deeper / "art" / "characters")
    shutil.copytree(deeper / "art" / "characters", deeper / "art" / "ui")
    assert find_projects(deeper) == [deeper]


def test_an_atlas_beside_another_games_skeletons_is_not_joined_to_them(meshed, tmp_path):
    """A library whose root held one game's atlases (``alpha-art/``) and another game's skeletons
    (``beta-spine/``) was taken for one project by the folders' kinds alone, and ``pack`` packed
    the atlas's ``demo-head`` by the other game's mesh of that name (exit 0): the halves are one
    project only where the skeletons draw from the atlases."""
    import json

    from spinemesh.project import find_projects

    lib = tmp_path / "lib"
    for name in ("demo.atlas", "demo.png"):
        (lib / "alpha-art").mkdir(parents=True, exist_ok=True)
        shutil.copy(meshed / name, lib / "alpha-art" / name)
    doc = json.loads((meshed / "demo.json").read_text())
    for skin in doc["skins"]:
        for slot in skin["attachments"].values():
            for key, att in slot.items():
                if (att.get("path") or key) != "demo-head":  # the one name the two games share
                    att["path"] = "beta-" + (att.get("path") or key)
    (lib / "beta-spine").mkdir()
    (lib / "beta-spine" / "beta.json").write_text(json.dumps(doc))
    assert find_projects(lib) == [lib / "alpha-art", lib / "beta-spine"]
    r = _cli("pack", lib, "--out", tmp_path / "o", "--report", tmp_path / "r.json", "-j", "1", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    (row,) = _rows(tmp_path / "r.json").values()
    assert row["by_outline"] in (0, None), row
    # the same game's halves are still one project
    shutil.copy(meshed / "demo.json", lib / "beta-spine" / "beta.json")
    assert find_projects(lib) == [lib]


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

    from spinemesh.pack.checks import is_lossy_webp

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


def test_an_atlas_kept_before_its_pages_are_read_reads_each_header_once(meshed, tmp_path, monkeypatch):
    """Pages shared by two atlases keep both before a page is decoded: their rows' texels came
    from each page's header read again (after the read that checks them against their ``size:``
    lines and the one that sized the bar), three opens of each page for its header. Now once."""
    from PIL import Image

    from spinemesh.pack.run import PackOptions, pack_project

    project = tmp_path / "p"
    shutil.copytree(meshed, project)
    (project / "twin.atlas").write_text((project / "demo.atlas").read_text())
    page = (project / "demo.png").resolve()
    opened: list[Path] = []
    real_open = Image.open

    def counted(fp, *args, **kwargs):
        if isinstance(fp, (str, Path)) and Path(fp).resolve() == page:
            opened.append(Path(fp))
        return real_open(fp, *args, **kwargs)

    monkeypatch.setattr(Image, "open", counted)
    rows = pack_project(project, tmp_path / "o", PackOptions(jobs=1)).atlases
    assert [r.status for r in rows] == ["kept", "kept"] and all("shared" in r.reason for r in rows), rows
    with real_open(page) as im:
        assert all(r.texels_before == r.texels_after == im.width * im.height for r in rows), rows
    assert len(opened) == 2, opened  # each atlas's page header once, when the atlas is read


def _bar_line(bars) -> str:
    import io

    from rich.console import Console

    shown = Console(width=120, file=io.StringIO(), color_system=None)
    shown.print(bars.make_tasks_table(bars.tasks))
    return shown.file.getvalue().splitlines()[0]


def test_a_bar_is_seen_working_through_one_long_step(monkeypatch):
    """One large page through oxipng is one step of many seconds with nothing to count: the bar
    stood still (its percent, its bar) and looked hung. Every command's bar (one ``progress_bar``)
    turns a spinner while its task is under way; none before its first step nor once done."""
    from spinemesh.cli._app import err_console, progress_bar
    from spinemesh.cli.pack import atlas_bars

    monkeypatch.setattr(err_console.real, "width", 120)
    for phases in (False, True):
        clock = [0.0]
        bars = progress_bar("pack", phases=phases)
        bars.get_time = lambda: clock[0]  # the time the bars' tasks read (a task takes it when made)
        if phases:
            task = bars.add_task("write", total=100, project="hero")
        else:
            atlas_bars(bars).atlas("hero.atlas", 100)
            task = bars.tasks[0].id
        waiting = _bar_line(bars)
        bars.update(task, completed=40)  # under way: writing its one large page
        lines = []
        for tick in range(8):
            clock[0] = 1.0 + tick * 0.1
            lines.append(_bar_line(bars))
        # the same percent, times and words; the spinner before them turning
        assert len({line[:2] for line in lines}) > 2 and len({line[2:] for line in lines}) == 1, lines
        bars.update(task, completed=100)
        done = []
        for tick in range(4):
            clock[0] = 2.0 + tick * 0.1
            done.append(_bar_line(bars))
        assert waiting[:2] == "  " and {line[:2] for line in done} == {"  "}, (waiting, done)
    # a console in ASCII (or a code page) turns a spinner of its own characters: each braille dot
    # was escaped there, six characters wide
    monkeypatch.setattr(type(err_console.real), "encoding", property(lambda self: "ascii"))
    bars = progress_bar("pack")
    bars.add_task("writing pages", total=100, completed=40)
    assert _bar_line(bars)[0] in "-\\|/", _bar_line(bars)


def test_an_atlas_packed_without_any_skeleton_says_why_each_region_keeps_its_rectangle(meshed, tmp_path):
    """``pack art/`` (the atlas's folder, its skeletons in ``spine/`` beside it) packs every region by
    its rectangle: the report said "not drawn by any skeleton" of each, as of regions a game looks
    up in code. It says that the project holds no skeleton, and what to give instead."""
    project = _split(meshed, tmp_path / "game")
    r = _cli("pack", project / "art", "--out", tmp_path / "o", "--report", tmp_path / "r.json", "-j", "1",
             cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    (row,) = _rows(tmp_path / "r.json").values()
    assert row["by_outline"] == 0 and row["by_rectangle"] == 8, row
    assert all("holds no skeleton" in region["reason"] and "pack the folder that also holds the skeletons" in
               region["reason"] for region in row["regions_by_rectangle"]), row["regions_by_rectangle"]
