"""What ``spinemesh upgrade`` tells while and after it runs, and what its preview page says.

On projects our own code draws (the demo, the worm, the bar of ``test_upgrade_weights``):
the ``--weights auto`` summary, rows that stay distinct at 80 columns in a library, a bar per
phase, a skeleton that cannot be read listed with its reason, reasons grouped by wording, and
the preview's headline, bones, bent poses and sequence note.
"""

from __future__ import annotations

import json
import re
import shutil
from pathlib import Path

from typer.testing import CliRunner

from spinemesh.cli import app
from spinemesh.runs import reason_groups, short_names
from spinemesh.upgrade import Options, upgrade_library, upgrade_project
from spinemesh.upgrade.progress import Progress
from test_upgrade_weights import make_bar_project

DEMO = Path(__file__).resolve().parents[1] / "examples" / "demo"


def run(*args: str, columns: int = 80):
    return CliRunner().invoke(app, ["upgrade", *args], env={"COLUMNS": str(columns)})


# --------------------------------------------------------------------------- names and reasons
def test_short_names_stay_distinct_and_fit():
    names = [f"raeleus-dec2021/spine/characters/hero{i}/export-{v}/hero.json" for i in range(12) for v in "ab"]
    names += ["raeleus-dec2021/spine/x.json", "a/b.json"]
    for width in (33, 20):
        shown = short_names(names, width)
        assert len(set(shown.values())) == len(names), width
        assert max(map(len, shown.values())) <= width
    shown = short_names(names, 33)
    assert shown["a/b.json"] == "a/b.json"
    assert shown[names[0]] == "…/hero0/export-a/hero.json"  # the parts that tell them apart


def test_reasons_worded_differently_are_never_folded():
    reasons = ["not worth meshing: the art fills 99% of the region (--min-saving 5%)"] * 3 + [
        "not worth meshing: the art fills 97% of the region (--min-saving 5%)",
        "not worth meshing: a mesh would draw only 3% fewer pixels than the region (--min-saving 5%)",
        "--only matched nothing"]
    groups = reason_groups(reasons)
    assert groups[0] == ("not worth meshing: the art fills 99% of the region (--min-saving 5%)", 4, 1)
    assert len(groups) == 3 and sum(n for _, n, _ in groups) == len(reasons)


# --------------------------------------------------------------------------- the console
def test_weights_auto_summary_counts_weighted_bending_and_meshed_only_to_bend(tmp_path):
    make_bar_project(tmp_path / "bar")
    res = run(str(tmp_path / "bar"), "--out", str(tmp_path / "out"), "--weights", "auto")
    assert res.exit_code == 0, res.output
    assert "bones: 1 of 1 new meshes weighted: 1 bend over 2 bones (median 2), 0 follow one bone; " \
           "1 of those that bend meshed only to bend (without --weights auto they would stay regions" \
           in res.output.replace("\n", " ")
    assert re.search(r"weights \d+\.\d s", res.output)
    plain = run(str(tmp_path / "bar"), "--out", str(tmp_path / "plain"))
    assert "bones:" not in plain.output and "weights" not in plain.output.split("median vertices")[1]


def test_weights_auto_summary_on_meshes_that_follow_one_bone(tmp_path):
    res = run(str(DEMO), "--out", str(tmp_path / "out"), "--weights", "auto")
    assert res.exit_code == 0, res.output
    assert "bones: 10 of 10 new meshes weighted, each to one bone" in res.output


def test_library_rows_are_told_apart_at_80_columns(tmp_path):
    library = tmp_path / "lib"
    for hero in ("hero1", "hero2"):
        for export in ("export-a", "export-b"):
            shutil.copytree(DEMO, library / "studio-december-2021" / "spine" / "characters" / hero / export)
    res = run(str(library), "--out", str(tmp_path / "out"))
    assert res.exit_code == 0, res.output
    rows = [line for line in res.output.splitlines() if line.startswith("│")]
    names = [row.split("│")[1].strip() for row in rows]
    assert len(rows) == 8 and len(set(names)) == 8, names
    assert [line for line in res.output.splitlines() if line[:1] in "┏┃┡│└" and len(line) > 80] == []
    assert "…/hero1/export-a/demo.json" in names


def test_a_skeleton_that_cannot_be_read_is_listed_while_the_others_are_upgraded(tmp_path):
    project = tmp_path / "p"
    shutil.copytree(DEMO, project)
    (project / "demo-binary.skel").write_bytes(b"\x00" * 40)  # no Spine version in its header
    res = run(str(project), "--out", str(tmp_path / "out"), "--report", str(tmp_path / "r.json"))
    assert res.exit_code == 3
    assert re.search(r"not read: \S*demo-binary\.skel", res.output)
    assert re.search(r"│ demo\.json +│ +5 │", res.output)
    report = json.loads((tmp_path / "r.json").read_text())
    assert list(report["skeletons_not_read"]) == ["demo-binary.skel"]
    assert (tmp_path / "out" / "demo.json").is_file()


class Recorder(Progress):
    def __init__(self):
        self.added, self.done, self.projects, self.ahead = {}, {}, [], []

    def add(self, phase, steps, project=None):
        self.added[phase] = self.added.get(phase, 0) + steps
        if project is not None:
            self.ahead.append((phase, project))

    def advance(self, phase, steps=1):
        self.done[phase] = self.done.get(phase, 0) + steps

    def project(self, name):
        self.projects.append(name)


def test_every_phase_reports_its_work_and_finishes_it(tmp_path):
    seen = Recorder()
    result = upgrade_project(DEMO, tmp_path / "out", Options(weights="auto", jobs=1), seen)
    # every mesh made is bound, those made only to bend and then put back as regions included
    bound = sum(t.weights is not None for t in result.targets)
    assert bound >= sum(t.status == "meshed" for t in result.targets) > 0
    assert seen.added == seen.done
    assert seen.added["read"] == 2 and seen.added["write"] == 2 and seen.added["weights"] == bound
    assert seen.added["mesh"] >= 5
    lib = tmp_path / "lib"
    shutil.copytree(DEMO, lib / "a")
    shutil.copytree(DEMO, lib / "b")
    seen = Recorder()
    upgrade_library(lib, tmp_path / "lib-out", Options(jobs=1), seen)
    assert seen.projects == ["a", "b"] and seen.added == seen.done and seen.added["read"] == 4
    assert "weights" not in seen.added
    # on workers, with weights: each project's meshing is added under its own name (it runs
    # ahead of the project written), and every step is told by the end
    seen = Recorder()
    upgrade_library(lib, tmp_path / "lib-weights", Options(jobs=2, weights="auto"), seen)
    assert seen.projects == ["a", "b"] and seen.added == seen.done and seen.added["weights"] > 0
    assert [p for phase, p in seen.ahead if phase == "mesh"] == ["a", "b"], seen.ahead


def test_meshes_are_told_as_their_workers_end_them_not_when_collected():
    """A library run meshes projects ahead while this process weights and writes an earlier one:
    the meshing's progress is told as each mesh arrives, before anything collects it, and
    collecting it later tells nothing again."""
    import concurrent.futures
    import time

    from spinemesh.cluster import open_workers
    from spinemesh.project import find_project
    from spinemesh.upgrade.meshing import finish_meshing, start_meshing
    from spinemesh.upgrade.plan import plan_project
    from spinemesh.upgrade.report import Result

    tasks = plan_project(find_project(DEMO), Options(jobs=2), Result()).tasks
    told = []
    with open_workers(2, None) as workers:
        meshing = start_meshing(tasks, workers, progress=told.append)
        assert len(meshing.futures) == len(tasks) > 1
        concurrent.futures.wait(meshing.futures)
        # a future's waiters wake just before its callbacks run
        deadline = time.monotonic() + 10
        while sum(told) < len(tasks) and time.monotonic() < deadline:
            time.sleep(0.01)
        assert sum(told) == len(tasks), told
        meshes = finish_meshing(meshing, tasks, workers, progress=told.append)
    assert sum(told) == len(tasks) and set(meshes) == set(tasks)


def test_a_projects_weights_go_ahead_of_the_meshing_queued_for_later_projects(tmp_path):
    """The weighting jobs are sent first (ahead of the tasks waiting): else, in a library run,
    a project's weights waited for the meshing of every project planned after it, its bar still."""
    from spinemesh.cluster import Workers

    class Recording(Workers):
        kind, slots = "recording", 2  # not this process's own Workers: the weights go to the workers

        def __init__(self):
            self.sent = []

        def submit(self, fn, arg, first=False):
            self.sent.append((fn.__name__, first))
            return super().submit(fn, arg, first)

    workers = Recording()
    upgrade_project(make_bar_project(tmp_path / "bar"), tmp_path / "out", Options(weights="auto", jobs=2),
                    workers=workers)
    weights = [first for name, first in workers.sent if name == "weight_apart"]
    assert weights and all(weights), workers.sent


# --------------------------------------------------------------------------- the preview
def page_text(page: Path) -> str:
    """The index and every skeleton page of a preview, as one text."""
    return "".join(p.read_text(encoding="utf-8") for p in [page, *sorted(page.parent.glob("s/*.html"))])


def test_preview_states_what_failed_instead_of_an_empty_headline(tmp_path):
    meshed = tmp_path / "meshed"
    upgrade_project(DEMO, meshed, Options(min_saving=0, jobs=1))  # every region already a mesh now
    project = tmp_path / "p"
    shutil.copytree(meshed, project, ignore=shutil.ignore_patterns(".spinemesh*"))
    (project / "demo-binary.skel").write_bytes(b"\x00" * 40)
    res = run(str(project), "--out", str(tmp_path / "out"), "--preview", str(tmp_path / "prev"))
    assert res.exit_code == 3, res.output
    text = page_text(tmp_path / "prev" / "index.html")
    assert "Nothing meshed: 1 skeleton could not be read" in text
    assert "not read:</b>" in text and "demo-binary.skel" in text
    assert "−-" not in text and "- fewer" not in text


def _vertex_colours(prev: Path) -> set[str]:
    """The colours by bone of the upgraded side's vertices, over every skeleton's player."""
    import json

    out = set()
    for model in prev.glob("data/*/model.js"):
        data = json.loads(model.read_text(encoding="utf-8").split(",", 1)[1].rsplit(");", 1)[0])
        out |= {row["c"][i:i + 6] for row in data["sides"]["after"] for i in range(0, len(row["c"]), 6)}
    return out


def test_preview_colours_vertices_by_bone_and_draws_each_bending_mesh_bent(tmp_path):
    make_bar_project(tmp_path / "bar")
    res = run(str(tmp_path / "bar"), "--out", str(tmp_path / "out"), "--weights", "auto",
              "--preview", str(tmp_path / "prev"))
    assert res.exit_code == 0, res.output
    text = page_text(tmp_path / "prev" / "index.html")
    assert text.count('alt="bent pose"') == 1  # the bar bends; nothing else was meshed
    # its art fills its region: it was meshed to bend, which its card says instead of a saving
    assert text.count("<b>Made to bend</b> over its bones") == 1 and "transparent area no longer drawn" not in text
    # the bar's vertices mix the colours of its two bones: more than the two pure colours
    assert len(_vertex_colours(tmp_path / "prev")) > 3
    plain = run(str(tmp_path / "bar"), "--out", str(tmp_path / "o2"), "--preview", str(tmp_path / "p2"),
                "--min-saving", "0")
    assert plain.exit_code == 0, plain.output
    assert len(_vertex_colours(tmp_path / "p2")) <= 2  # each mesh on its slot's bone: one colour each


def test_preview_says_why_a_sequence_mesh_is_larger_than_its_frame(tmp_path):
    res = run(str(DEMO), "--out", str(tmp_path / "out"), "--preview", str(tmp_path / "prev"))
    assert res.exit_code == 0, res.output
    text = page_text(tmp_path / "prev" / "index.html")
    assert "One mesh for the 3 frames of this sequence" in text
    assert text.count("One mesh for the") == 1  # the spark, once: demo.json and demo-binary.skel are twins


def test_preview_reasons_table_keeps_different_reasons_apart(tmp_path):
    from spinemesh.upgrade.preview import _reasons_table
    from spinemesh.upgrade.report import Result, Target

    result = Result()
    for i, reason in enumerate(["not worth meshing: the art fills 99% of the region",
                                "not worth meshing: the art fills 97% of the region",
                                "not worth meshing: 40 separate islands of art need 120+ outline vertices",
                                "excluded by --exclude"]):
        result.targets.append(Target("s.json", "default", "slot", f"a{i}", ["a"], status="kept", reason=reason))
    table = _reasons_table(result)
    assert table.count("<tr>") == 4  # the header and three groups
    assert "1 of them with other figures" in table and "similar" not in table


def test_phase_bars_keep_their_counts_and_times_at_80_columns():
    from rich.console import Console

    from spinemesh.cli._app import phase_progress, progress_bar

    bars = progress_bar("upgrade", phases=True)
    progress = phase_progress(bars)
    progress.project("studio-december-2021/spine/characters/hero3/export-b")
    for phase, total in (("read", 120), ("mesh", 3456), ("weights", 2345), ("write", 120)):
        progress.add(phase, total)
        progress.advance(phase, total // 3)
    console = Console(width=80, record=True, force_terminal=False)
    console.print(bars.make_tasks_table(bars.tasks))
    lines = console.export_text().splitlines()
    # each line: the spinner (every phase is under way), then the phase
    assert [line.split()[1] for line in lines] == ["read", "mesh", "weights", "write"]
    assert "1152/3456" in lines[1] and "ETA" in lines[1] and "…/hero3/export-b" in lines[1]
    assert all(len(line) <= 80 and "…/…" not in line for line in lines)


def test_a_bar_cuts_its_words_short_never_its_counts_and_times(monkeypatch):
    """At 80 columns a bar whose words are long (a step, an atlas deep in a library) ends them with
    an ellipsis: its label, count, elapsed time and time left stay whole."""
    import io

    from rich.console import Console

    from spinemesh.cli._app import err_console, progress_bar

    monkeypatch.setattr(err_console.real, "width", 80)
    for phases, fields in ((True, {"project": "placing regions, trying page sizes: " + "deep/" * 20}),
                           (False, {})):
        bars = progress_bar("pack", phases=phases)
        bars.add_task("pack" if phases else "placing regions: " + "deep/" * 20, total=1000, completed=999,
                      **fields)
        shown = Console(width=80, file=io.StringIO(), record=True, color_system=None)
        shown.print(bars.make_tasks_table(bars.tasks))
        (line,) = shown.export_text().strip().splitlines()
        assert len(line) <= 80 and line.rstrip().endswith("…"), line
        assert "999/1000 0:00:00 ETA " in line and "placing regions" in line, line
