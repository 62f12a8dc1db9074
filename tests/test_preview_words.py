"""What a user reads from ``upgrade --preview``, ``pose``, ``weights`` and ``upgrade``'s console: the
player says why its canvases are blank, its frames few or a skin missing, the bars count the work
they wait on, the index's tables are headed, a bad ``--times`` names the option, and a broken page
fails its attachments in one line. Runs on the demo project drawn by our own code."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

from spinemesh.demo import make_demo_project
from spinemesh.player.frames import FPS, plan_sampling, sample_animations
from spinemesh.upgrade import Options, upgrade_project
from spinemesh.upgrade.preview import write_preview

REPO = Path(__file__).resolve().parents[1]


def _demo_doc(tmp_path: Path) -> dict:
    return json.loads((make_demo_project(tmp_path / "demo") / "demo.json").read_text())


def _notes(doc: dict) -> dict[str, str]:
    setup, sampling, sides = plan_sampling(doc, doc)
    return {"setup pose": setup.note} | {name: got.note for name, got in
                                         sample_animations(sides, sampling, list(sampling.durations))}


def test_the_player_says_why_its_canvases_are_blank_or_its_frames_few(tmp_path):
    doc = _demo_doc(tmp_path)
    slots = [s["name"] for s in doc["slots"]]
    doc["animations"] |= {
        "hidden": {"slots": {s: {"attachment": [{"name": None}]} for s in slots}},  # every slot emptied
        "faded": {"slots": {s: {"rgba": [{"color": "ffffff00"}]} for s in slots}},  # every slot transparent
        "long": {"bones": {"arm": {"rotate": [{"value": 0}, {"time": 40, "value": 90}]}}},  # 300 frames at most
    }
    notes = _notes(doc)
    for name in ("hidden", "faded"):
        assert notes[name].startswith("Nothing to see: played alone, as here, this animation shows no attachment"), \
            notes[name]
    assert notes["long"].startswith("Shown at 7.5 frames a second, not 30,"), notes["long"]
    assert notes["wave"] == notes["setup pose"] == ""  # a drawn animation at full rate: no words
    # a skeleton whose setup pose shows nothing (its slots are given attachments by animations)
    for slot in doc["slots"]:
        slot.pop("attachment", None)
    assert _notes(doc)["setup pose"].startswith("Nothing to see in the setup pose: no slot shows an attachment")
    assert FPS == 30


def test_the_preview_bar_counts_animations_and_pages_and_the_reasons_have_a_heading(tmp_path):
    demo = make_demo_project(tmp_path / "demo")
    doc = json.loads((demo / "demo.json").read_text())
    doc["animations"] |= {"wave2": doc["animations"]["wave"], "still": {}}
    (demo / "demo.json").write_text(json.dumps(doc))
    (demo / "demo-binary.skel").unlink()  # no longer its twin
    result = upgrade_project(demo, tmp_path / "out", Options(jobs=1))
    calls: list[tuple[int, int]] = []
    index = write_preview(result, demo, tmp_path / "out", tmp_path / "preview",
                                  on_progress=lambda done, total: calls.append((done, total)))
    # one skeleton and its three animations
    assert calls[0] == (0, 4) and calls[-1] == (4, 4)
    assert [d for d, _ in calls] == sorted(d for d, _ in calls) and {t for _, t in calls} == {4}
    assert len(calls) == 1 + 3 + 1  # the start, each animation as it is sampled, the page
    text = index.read_text(encoding="utf-8")
    heading = text.index("<h2>Why regions were left as they are</h2>")
    assert text.index("<h2>Skeletons</h2>") < heading < text.index("<th>left a region</th>")


def test_a_time_that_is_not_one_names_the_option(tmp_path):
    skeleton = make_demo_project(tmp_path / "demo") / "demo.json"
    for times, why in (("0.2,abc", "'abc' is not a number of seconds"),
                       ("-1", "'-1': times must be finite and not negative")):
        r = subprocess.run([sys.executable, "-m", "spinemesh", "pose", str(skeleton), "-a", "wave", f"--times={times}"],
                           check=False, capture_output=True, text=True, cwd=REPO)
        assert r.returncode == 2 and f"Invalid value for --times: {why}" in r.stderr, r.stderr
        assert "Traceback" not in r.stderr


def test_weights_tells_each_mesh_weighted_and_each_picture_drawn(tmp_path):
    """``spinemesh weights`` has a bar per phase: every mesh attachment gone through (weighted,
    skipped or failed) and every picture of ``--preview``, each step told once."""
    from collections import Counter

    from spinemesh.rig.document import WeightOptions
    from spinemesh.rig.run import weight_project

    demo = make_demo_project(tmp_path / "demo")
    upgrade_project(demo / "demo.json", tmp_path / "up", Options(min_saving=0, jobs=1))
    added, done = Counter(), Counter()

    class Told:
        def add(self, phase, steps, project=None):
            added[phase] += steps

        def advance(self, phase, steps=1):
            done[phase] += steps
            assert done[phase] <= added[phase], phase  # never past what was announced

    result = weight_project(tmp_path / "up", tmp_path / "w", WeightOptions(bones="keep", only=["demo-b*"]),
                            preview=tmp_path / "prev", progress=Told())
    weighted = sum(o.status == "weighted" for o in result.outcomes)
    assert 0 < weighted < len(result.outcomes)  # --only skips some: they are steps too
    assert added == done == Counter(weights=len(result.outcomes), preview=weighted)
    assert len(list((tmp_path / "prev").glob("*.png"))) == weighted


def test_the_skins_the_player_does_not_offer_are_named_on_the_page(tmp_path):
    from spinemesh.player.frames import MAX_SKINS

    doc = _demo_doc(tmp_path)
    arm = doc["skins"][0]["attachments"]["arm"]
    doc["skins"] += [{"name": f"outfit{i}", "attachments": {"arm": arm}} for i in range(1, 7)]
    problems: list[str] = []
    plan_sampling(doc, doc, problems=problems)
    assert MAX_SKINS == 4 and problems == [("skins outfit5, outfit6 not offered alone: the player offers at most 4 "
                                            "skins, those that dress the setup pose first")]
    doc["skins"] = doc["skins"][:4]  # the default skin and three more: all offered
    problems.clear()
    plan_sampling(doc, doc, problems=problems)
    assert problems == []


def test_a_broken_page_fails_its_attachments_in_one_line(tmp_path):
    """Every attachment a truncated page holds fails for one reason: one line says it, naming
    the first attachment, how many more, and the file (it was one line per attachment)."""
    demo = make_demo_project(tmp_path / "demo")
    page = demo / "demo.png"
    page.write_bytes(page.read_bytes()[:300])
    r = subprocess.run([sys.executable, "-m", "spinemesh", "upgrade", str(demo), "--out", str(tmp_path / "out"),
                        "--jobs", "1"], check=False, capture_output=True, text=True, cwd=REPO,
                       env={**os.environ, "COLUMNS": "400"})
    lines = [line for line in r.stderr.splitlines() if line.startswith("left a region:")]
    assert r.returncode == 3 and len(lines) == 1, r.stderr
    assert "attachment 'demo-arm' and 11 more: " in lines[0] and f"{page}: cannot decode image" in lines[0], lines[0]


def test_an_output_beside_the_skeleton_run_from_its_folder_says_which_folder_and_what_to_do(tmp_path):
    """``spinemesh pose hero.skel --out pose.json`` run in the skeleton's folder writes into the
    project, which is refused: the line names the folder (it said "the input .") and the way out."""
    project = make_demo_project(tmp_path / "demo")
    r = subprocess.run([sys.executable, "-m", "spinemesh", "pose", "demo-binary.skel", "-a", "wave", "--out", "pose.json"],
                       check=False, capture_output=True, text=True, cwd=project,
                       env={**os.environ, "PYTHONPATH": str(REPO), "COLUMNS": "400"})
    assert r.returncode == 2 and not (project / "pose.json").exists()
    assert r.stderr.strip() == (f"error: pose.json: output file lies inside the input folder {project.resolve()}; "
                                "nothing is written there: give a path outside it"), r.stderr
    r = subprocess.run([sys.executable, "-m", "spinemesh", "pose", "demo-binary.skel", "-a", "wave", "--out", "../pose.json"],
                       check=False, capture_output=True, text=True, cwd=project, env={**os.environ, "PYTHONPATH": str(REPO)})
    assert r.returncode == 0 and (tmp_path / "pose.json").exists(), r.stderr


def test_a_kept_atlas_note_is_a_line_of_its_own_in_a_narrow_terminal():
    """``pack``'s note of 20 words took a line a word in its column at 80 columns: there it is a
    line under the table; a wide terminal keeps it in the table."""
    from types import SimpleNamespace

    from spinemesh.cli import pack as pack_cli

    reason = ("its regions need 19% of the page texels; the next smaller power-of-two page holds 50%, and no fill "
              "tried placed them on it")
    row = SimpleNamespace(atlas="hero.atlas", pages_before=1, pages_after=1, texels_before=4096, texels_after=4096,
                          bytes_before=900, bytes_after=800, by_outline=None, by_rectangle=None, reason=reason)
    console = pack_cli.console
    width = console.width
    try:
        for columns in (80, 200):
            console.width = columns
            with console.capture() as got:
                pack_cli.print_pack_table([row])
            text = got.get()
            assert (f"note: hero.atlas: {reason}" in text) == (columns < pack_cli.NOTES_IN_TABLE_FROM), text
            assert ("┃ note" in text) == (columns >= pack_cli.NOTES_IN_TABLE_FROM), text
    finally:
        console.width = width


def test_the_preview_indexes_count_in_words(tmp_path):
    """One of a thing is said in the singular on both indexes: "1 kept as a region", "1 atlas"."""
    from spinemesh.pack.preview import write_preview as write_pack_preview
    from spinemesh.pack.run import pack_project
    from spinemesh.words import counted

    demo = make_demo_project(tmp_path / "demo")  # one skeleton (and its twin), one atlas, one region kept
    result = upgrade_project(demo, tmp_path / "out", Options(jobs=1))
    text = write_preview(result, demo, tmp_path / "out", tmp_path / "preview").read_text(encoding="utf-8")
    assert "<p>1 skeleton (1 more file the same skeleton" in text and ", 1 kept as a region, " in text, text[-2000:]
    packed = pack_project(tmp_path / "out", tmp_path / "packed", keep_previews=True)
    text = write_pack_preview(packed, tmp_path / "pack-preview").read_text(encoding="utf-8")
    assert "<p>1 atlas; page texels" in text, text[-2000:]
    assert [counted(n, "atlas", "atlases") for n in (0, 1, 2, 1234)] == ["0 atlases", "1 atlas", "2 atlases",
                                                                          "1,234 atlases"]
