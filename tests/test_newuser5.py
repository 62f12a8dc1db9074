"""A new user walks the guides a fifth time, on real projects of every Spine version (3.5 to 4.3):
what they met that the program said badly, each test failing on the code before its fix.

Everything runs on the demo project drawn by our own code (no outside data needed).
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

from typer.testing import CliRunner

from spinemesh.cli import app

REPO = Path(__file__).resolve().parents[1]
DEMO = REPO / "examples" / "demo"


def _pack_table(rows: list, columns: int) -> str:
    from spinemesh.cli import pack as pack_cli

    console = pack_cli.console
    width = console.width
    try:
        console.width = columns
        with console.capture() as got:
            pack_cli.print_pack_table(rows)
        return got.get()
    finally:
        console.width = width


def _atlas_row(name: str, texels: tuple[int, int], size: tuple[int, int]) -> SimpleNamespace:
    return SimpleNamespace(atlas=name, pages_before=1, pages_after=1, texels_before=texels[0], texels_after=texels[1],
                           bytes_before=size[0], bytes_after=size[1], by_outline=25, by_rectangle=5, reason="",
                           page_files=())


def test_the_pack_table_names_each_atlas_at_80_columns():
    """At 80 columns (a CI log, a pipe) the table cut every atlas's name to a few letters
    (``HalloweenC…``, ``Waiter_417Down.at…``: the corpus's halloween-creature and cafe-waiter),
    so the log did not say which atlas was packed; the figures wrap instead, none cut."""
    for row in (_atlas_row("HalloweenCreature.atlas", (192_604, 162_782), (95_490, 81_902)),
                _atlas_row("Waiter_417Down.atlas", (6_714_663, 5_138_813), (4_296_671, 2_725_174))):
        text = _pack_table([row], 80)
        assert f"│ {row.atlas} " in text, text
        for figure in (row.texels_before, row.texels_after, row.bytes_before, row.bytes_after):
            assert f"{figure:,}" in text, text
        assert "1 -> 1" in text, text  # a short cell is not wrapped to make room
        assert all(len(line) <= 80 for line in text.splitlines()), text
    # a name longer than the room left keeps its end (which file) and stays told apart
    long = [_atlas_row(f"studio-export-december/characters/{n}/people_Max_pal.atlas.txt", (4096, 2048), (900, 800))
            for n in ("max", "mia")]
    text = _pack_table(long, 80)
    names = [line.split("│")[1].strip() for line in text.splitlines() if line.startswith("│")
             and line.split("│")[1].strip() not in ("", "total")]
    assert len(names) == 2 and len(set(names)) == 2 and all(n.endswith(".atlas.txt") for n in names), text
    assert all(len(line) <= 80 for line in text.splitlines()), text


def test_weights_on_a_project_without_meshes_says_so(tmp_path):
    """``spinemesh weights project/`` on an export whose art is all regions (the demo) printed an
    empty table and the time, exit 0: no skeleton named, no word that there was nothing to
    weight. Every skeleton is a row, and a warning says why nothing was weighted and what does."""
    project = tmp_path / "demo"
    shutil.copytree(DEMO, project)
    res = CliRunner().invoke(app, ["weights", str(project), "--out", str(tmp_path / "w")], env={"COLUMNS": "100"})
    assert res.exit_code == 0, res.output
    rows = [line.split("│")[1].strip() for line in res.output.splitlines() if line.startswith("│")]
    assert rows == ["demo-binary.skel", "demo.json"], res.output
    assert "warning: nothing to weight: no skeleton holds a mesh attachment" in res.output, res.output
    assert "upgrade --weights auto" in res.output, res.output


def test_weights_lists_a_skeleton_without_meshes_beside_the_others(tmp_path):
    """A project of two skeletons, one without a mesh (the corpus's zse-cabin, 3.7): the table
    listed the other alone, as if the first had not been read; no warning, as something was weighted."""
    meshed = tmp_path / "meshed"
    assert CliRunner().invoke(app, ["upgrade", str(DEMO / "demo.json"), "--out", str(meshed)]).exit_code == 0
    shutil.copy(DEMO / "demo-binary.skel", meshed / "demo-binary.skel")  # its regions: no mesh
    res = CliRunner().invoke(app, ["weights", str(meshed), "--out", str(tmp_path / "w")], env={"COLUMNS": "100"})
    assert res.exit_code == 0, res.output
    rows = {line.split("│")[1].strip(): line for line in res.output.splitlines() if line.startswith("│")}
    assert sorted(rows) == ["demo-binary.skel", "demo.json"], res.output
    assert rows["demo-binary.skel"].split("│")[2].strip() == "0", res.output
    assert "nothing to weight" not in res.output, res.output


def _one_game_data_set(tmp_path: Path) -> Path:
    shutil.copytree(DEMO, tmp_path / "projects" / "demo")  # one game, on the training side of the split
    res = CliRunner().invoke(app, ["dataset", str(tmp_path / "projects"), "--out", str(tmp_path / "DS")])
    assert res.exit_code == 0, res.output
    return tmp_path / "DS"


def test_segment_eval_on_a_data_set_without_held_out_games_says_what_to_do(tmp_path):
    """The segmentation guide's ``segment-eval`` on a data set of the studio's one or two games said
    ``error: no held-out sprites in DS`` and no more: why (the split is by game, fixed by a hash of
    its name) and what to do (more games, another data set) are said in that line."""
    data = _one_game_data_set(tmp_path)
    res = CliRunner().invoke(app, ["segment-eval", "--data", str(data)], env={"COLUMNS": "300"})
    assert res.exit_code == 2, res.output
    (line,) = [line for line in res.output.splitlines() if line.startswith("error:")]
    assert line.startswith(f"error: no held-out sprites in {data}: none of its games falls on the val side"), line
    assert "more games" in line and "--data" in line, line


def test_train_on_a_data_set_without_held_out_games_is_one_line_and_writes_nothing(tmp_path):
    """``train`` on such a data set wrote its sprite pack into OUT, then stopped on a traceback
    (exit 1); it is refused in the one line above, exit 2, OUT not made."""
    import pytest

    pytest.importorskip("torch")
    data = _one_game_data_set(tmp_path)
    out = tmp_path / "runs"
    res = CliRunner().invoke(app, ["train", "--data", str(data), "--out", str(out), "--time-limit", "1"],
                             env={"COLUMNS": "300"})
    assert res.exit_code == 2, res.output
    assert [line for line in res.output.splitlines() if line.startswith("error:")] == [
        line for line in res.output.splitlines() if line.startswith(f"error: no held-out sprites in {data}: ")], res.output
    assert "more games" in res.output and not out.exists(), res.output


def test_the_diff_page_counts_the_failures_the_markdown_counts():
    """The diff guide's page said ``122`` meshes for the paper's preset where ``report.md`` said
    ``122 (16 failed)`` (the corpus's zse-cabin, faint art under the paper's threshold): a reader
    of the page took the means for every attachment."""
    import numpy as np

    from spinemesh.diff.report import aggregate, aggregate_markdown, to_html
    from spinemesh.diff.run import DiffResult, DiffRow
    from spinemesh.mesher import mesh_image

    rgba = np.zeros((64, 96, 4), np.uint8)
    rgba[16:48, 16:80] = (200, 60, 40, 255)
    mesh = mesh_image(rgba)
    measured = {"coverage": 1.0, "waste": 0.1, "vertices": mesh.vertex_count, "triangles": mesh.triangle_count}
    row = DiffRow("hero", "hero.json", "default", "body", "body", "body", 96, 64, rgba,
                  meshes={"artist": mesh, "default": mesh},
                  metrics={"artist": measured, "default": measured, "paper": {"error": "no foreground component"}})
    result = DiffResult([row], ("default", "paper"), [])
    agg = aggregate(result)
    assert "| 0 (1 failed) |" in aggregate_markdown(agg)
    page = to_html(result, agg)
    assert "<td>0 (1 failed)</td>" in page and "report.md lists them all" in page, page[:3000]


def test_the_pack_total_of_atlases_all_kept_counts_no_region():
    """Two atlases kept in their layout (the corpus's dm-background: lossy WebP pages) show ``-``
    under by outline and by rectangle, their regions where they were; the total row said 0 and 0."""
    rows = [SimpleNamespace(**{**vars(_atlas_row(name, (4096, 4096), (900, 900))), "by_outline": None,
                               "by_rectangle": None, "reason": "its pages are lossy WebP"})
            for name in ("background.atlas", "freespinBG_anim.atlas")]
    text = _pack_table(rows, 120)
    (total,) = [line for line in text.splitlines() if line.startswith("│ total")]
    assert [cell.strip() for cell in total.split("│")[5:7]] == ["-", "-"], text


def test_meshes_left_unweighted_for_one_kind_of_reason_are_one_line():
    """``upgrade --weights auto`` on a 3.5 skeleton with IK legs and head (the corpus's
    sws-crawler) said ``bones: 1 meshes not weighted (... bone 'r_heel' ... 'R_HEEL_IK' ...)``
    twelve times, once per bone named; reasons that differ only in the names they quote are one
    line, and one mesh is said in the singular."""
    from spinemesh.cli._summary import weights_lines

    def unweighted(bone: str, constraint: str) -> SimpleNamespace:
        why = (f"setup position depends on bone '{bone}', moved in the setup pose by the IK constraint "
               f"'{constraint}' (constraints are solved for 3.8-4.3 skeletons; this one is 3.5.46)")
        return SimpleNamespace(status="meshed", weights={"status": "skipped", "reason": why})

    targets = [unweighted("r_heel", "R_HEEL_IK"), unweighted("l_heel", "L_HEEL_IK"), unweighted("r_heel", "R_HEEL_IK"),
               unweighted("neck", "HEAD_IK"),
               SimpleNamespace(status="meshed", weights={"status": "skipped", "reason": "keyed by a deform timeline"}),
               SimpleNamespace(status="meshed", weights={"status": "weighted", "bones": {"root": 1}})]
    lines = [line for line in weights_lines(targets) if "not weighted" in line]
    assert len(lines) == 2, lines
    assert lines[0].startswith("bones: 4 meshes not weighted (setup position depends on bone 'r_heel'"), lines
    assert lines[0].endswith("; 2 of them with other names)"), lines
    assert lines[1] == "bones: 1 mesh not weighted (keyed by a deform timeline)", lines


def test_weights_refuses_its_pictures_inside_the_output_folder(tmp_path):
    """``weights --preview OUT/pics`` wrote its debugging pictures into the folder a game loads
    (``upgrade`` and ``pack`` refuse a preview there); refused in one line, nothing written."""
    meshed = tmp_path / "meshed"
    assert CliRunner().invoke(app, ["upgrade", str(DEMO / "demo.json"), "--out", str(meshed)]).exit_code == 0
    out = tmp_path / "w"
    r = subprocess.run([sys.executable, "-m", "spinemesh", "weights", str(meshed), "--out", str(out), "--preview",
                        str(out / "pics")], check=False, capture_output=True, text=True, env={**os.environ, "PYTHONPATH": str(REPO)})
    assert r.returncode == 2, r.stdout + r.stderr
    assert r.stderr.startswith("error: ") and "overlaps the output folder" in r.stderr, r.stderr
    assert "Traceback" not in r.stderr and not out.exists(), r.stderr


def test_a_reason_with_other_figures_is_counted_among_its_kind():
    """``kept as region: 4 (... 4% fewer pixels ...; 1 more like it with other figures)`` counted
    the other wordings, not attachments, and read as a fifth attachment (the corpus's
    xasdfb-char, 3.6): it says how many of them have other figures."""
    from spinemesh.cli import _summary
    from spinemesh.runs import reason_groups

    share = "not worth meshing: a mesh would draw only {}% fewer pixels than the region"
    reasons = [share.format(4)] * 3 + [share.format(2)] + [share.format(3)] * 2
    assert reason_groups(reasons) == [(share.format(4), 6, 3)]
    rows = [SimpleNamespace(status="kept", reason=r, skeleton="s.json") for r in reasons]
    with _summary.console.capture() as got:
        _summary.print_left_alone(rows, [], "kept", "kept as region", "left a region")
    assert got.get().strip() == f"kept as region: 6 ({share.format(4)}; 3 of them with other figures)", got.get()
