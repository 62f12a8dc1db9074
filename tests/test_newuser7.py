"""A new user walks the guides a seventh time, from an installed wheel and a folder outside the
checkout (``weights``, ``pose``, ``diff``, a library, the report JSON): what they met that the
program or the guides said badly, each test failing on the code before its fix.

Everything runs on the demo project drawn by our own code (no outside data needed).
"""

from __future__ import annotations

import json
import shutil

from rig_project import make_worm_project
from test_newuser6 import DEMO, REPO, _run
from test_pipeline import spinemesh


def test_pose_times_without_an_animation_are_refused_naming_the_animations(tmp_path):
    """``pose hero.json --times 0.5,1 --out p.json`` (the animation forgotten) wrote the setup pose
    alone, exit 0, and said ``p.json: 1 poses``: the times were dropped in silence. It is refused
    before anything is written, naming the skeleton's animations; the setup pose alone (no
    ``--times``, or ``--times 0``) is written as before, said as one pose."""
    r = _run("pose", DEMO / "demo.json", "--times", "0.5,1", "--out", "p.json", cwd=tmp_path)
    assert r.returncode == 2, r.stderr
    assert r.stderr.count("\n") == 1 and "--times 0.5,1 samples an animation: add --animation NAME" in r.stderr
    assert "(the skeleton has: wave)" in r.stderr, r.stderr
    assert not (tmp_path / "p.json").exists()
    for times in ((), ("--times", "0")):
        r = _run("pose", DEMO / "demo.json", *times, "--out", "s.json", cwd=tmp_path)
        assert r.returncode == 0 and r.stderr == "s.json: 1 pose\n", r.stderr
        assert [p["label"] for p in json.loads((tmp_path / "s.json").read_text())["poses"]] == ["setup"]
    r = _run("pose", DEMO / "demo.json", "-a", "wave", "--times", "0.5,1", "--out", "w.json", cwd=tmp_path)
    assert r.returncode == 0 and r.stderr == "w.json: 3 poses\n", r.stderr


def test_diff_of_a_project_without_meshes_names_it_and_says_why(tmp_path):
    """``diff project/`` on an export of regions (the guide's own ``project/`` before ``upgrade``)
    said ``error: no artist mesh attachment found`` and no more, naming no project; a folder
    without a skeleton said the same. Each line names what was given and what is missing."""
    shutil.copytree(DEMO, tmp_path / "project")
    (tmp_path / "empty").mkdir()
    r = _run("diff", "project", "--out", "d", cwd=tmp_path)
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
    assert r.stderr.startswith("error: project: no artist mesh attachment found: diff compares each mesh attachment "
                               "your artists drew with ours, and the skeletons there hold none"), r.stderr
    assert "'spinemesh upgrade' meshes them" in r.stderr
    r = _run("diff", "empty", "--out", "d", cwd=tmp_path)
    assert r.returncode == 2 and r.stderr.startswith("error: empty: no Spine skeleton found (a .skel file"), r.stderr
    assert not (tmp_path / "d").exists()


def test_weights_says_how_many_meshes_bend(tmp_path, meshed):
    """``weights`` on a corpus effects rig (49 meshes) printed ``weighted 49``, ``median bones 1``:
    read as 49 meshes that now bend, where each followed its one bone as before. It says, as
    ``upgrade --weights auto`` does, how many bend over how many bones and how many follow one."""
    r = _run("weights", meshed, "--out", "w", "--replace", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert "bones: 12 meshes weighted, each to one bone (no other bone is likely to bend their art)\n" in r.stdout
    r = _run("weights", meshed, "--out", "k", "--replace", "--bones", "keep", cwd=tmp_path)
    assert "bones: 12 meshes weighted, each to one bone (--bones keep: the bone each was bound to)\n" in r.stdout
    make_worm_project(tmp_path / "worm")
    assert _run("upgrade", "worm", "--out", "wu", cwd=tmp_path).returncode == 0
    r = _run("weights", "wu", "--out", "ww", "--bones", "rule", cwd=tmp_path)
    assert r.returncode == 0 and "bones: 1 mesh weighted: 1 bend over 3 bones (median 3), 0 follow one bone\n" in r.stdout


def test_help_says_the_default_of_the_vertex_budget_and_of_diffs_limit(tmp_path):
    """``--max-vertices`` (``mesh``, ``upgrade``) said ``Hard vertex budget per mesh. Default preset
    only.`` (a user read "Default" as its default, and found none), and ``diff --limit`` said
    nothing of what it takes without it. Each help names its default."""
    for command, words in (("mesh", "Hard vertex budget per image (default: none, as many as the art's outline and "
                                    "--density ask)"),
                           ("upgrade", "Hard vertex budget per mesh (default: none, as many as the art's outline and "
                                       "--density ask)"),
                           ("diff", "Compare at most this many attachments, the first found (default: every one)")):
        r = spinemesh(command, "--help", cwd=tmp_path)
        assert r.returncode == 0 and words in " ".join(r.stdout.split()), (command, r.stdout)


def _report_section() -> str:
    """The upgrade guide's section on ``--report``, to its next heading."""
    text = (REPO / "docs" / "guide" / "upgrade.md").read_text()
    start = text.index("\n## The report\n")
    return text[start:text.index("\n## ", start + 1)]


def test_the_upgrade_guide_names_every_field_of_the_report(tmp_path):
    """A user reading ``report.json`` found no page saying what its fields are (``paths`` a list,
    ``coverage`` a share or a percent, ``counts`` without ``failed`` when none failed, what a
    ``weights`` object holds): the guide said only that the report holds "per attachment, its
    vertices, triangles, coverage, transparent area and time". Its section names every field a
    report of ``--pack --weights auto`` holds, at every level."""
    r = _run("upgrade", DEMO, "--out", "o", "--pack", "--weights", "auto", "--report", "r.json", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    report = json.loads((tmp_path / "r.json").read_text())
    fields = set(report) | set(report["seconds"]) | set(report["counts"])
    for row in report["attachments"]:
        fields |= set(row) | set(row.get("weights") or {})
    assert any(row.get("weights") for row in report["attachments"]) and "atlases" in report
    section = _report_section()
    assert not [f for f in sorted(fields) if f"`{f}`" not in section], section


def test_upgrade_says_where_its_editor_images_went(tmp_path):
    """``upgrade project/ --out meshed/ --images meshed-images/`` (getting started's way to bring
    the meshes into the editor) wrote the images without a word: the table and the last lines
    speak of OUT only, as ``pack --preview`` and ``weights --preview`` did of their pictures. The
    run says where they are and how many, as the previews' lines do; a dry run writes none and
    says nothing of them."""
    r = _run("upgrade", DEMO, "--out", "meshed", "--images", "meshed-images", cwd=tmp_path)
    written = sorted((tmp_path / "meshed-images").rglob("*.png"))
    assert r.returncode == 0 and written, r.stderr
    assert (f"images: meshed-images ({len(written)} images at their original size, for the editor's images folder)\n"
            in r.stdout), r.stdout
    r = _run("upgrade", DEMO, "--out", "dry", "--images", "dry-images", "--dry-run", cwd=tmp_path)
    assert r.returncode == 0 and "images:" not in r.stdout, r.stdout


def test_every_option_has_a_help_and_train_says_what_0_minutes_is(tmp_path):
    """``train --help`` showed ``--seed <int> [default: 0]`` with no word of what it seeds, and
    ``--time-limit`` as ``Minutes; the cosine schedule then ends with the budget. [default: 0]``:
    0 minutes read as no training at all, where it is no limit. Every option of every command
    has a help; the limit's says what 0 is."""
    import typer

    from spinemesh.cli import app

    bare = [(name, param.opts) for name, command in typer.main.get_command(app).commands.items()
            for param in command.params if param.param_type_name == "option" and not (param.help or "").strip()]
    assert not bare, bare
    r = spinemesh("train", "--help", cwd=tmp_path)
    assert r.returncode == 0 and "Minutes of training (0: no limit, --epochs alone)" in " ".join(r.stdout.split())


def test_convert_writes_json_under_the_names_unity_and_godot_load(tmp_path):
    """Every command reads ``hero.json.txt`` (Unity) and ``hero.spine-json`` (spine-godot, which
    reads a ``.json`` as binary), but ``convert hero.skel hero.spine-json`` was refused (``target
    must end in .skel, .skel.bytes or .json``). Both are written as JSON, the bytes a ``.json``
    gets; another name is refused listing every name taken."""
    source = DEMO / "demo-binary.skel"
    assert _run("convert", source, "hero.json", cwd=tmp_path).returncode == 0
    for name in ("hero.json.txt", "hero.spine-json"):
        r = _run("convert", source, name, cwd=tmp_path)
        assert r.returncode == 0 and r.stdout.startswith(f"wrote {name} (JSON, Spine "), r.stderr
        assert (tmp_path / name).read_bytes() == (tmp_path / "hero.json").read_bytes()
    r = _run("convert", source, "hero.txt", cwd=tmp_path)
    assert r.returncode == 2 and r.stderr == ("error: hero.txt: target must end in .skel, .skel.bytes (binary) or "
                                              ".json, .json.txt, .spine-json (JSON)\n"), r.stderr


def test_the_diff_report_names_images_from_the_project_not_this_machine(tmp_path, meshed):
    """``report.json`` and ``index.html`` of ``diff`` gave each image's ``source`` as an absolute
    path of the machine (``/home/me/work/meshed/images/demo-body.png``), and a project given as
    ``.`` had ``"project": ""``: a report differed from one folder or machine to the next and
    showed the user's folders to whoever it was sent to. They name them from the project's
    folder (``meshed/images/demo-body.png``), the same bytes from inside the project as from
    beside it, as ``upgrade``'s report does."""
    shutil.copytree(meshed, tmp_path / "meshed")
    assert _run("diff", "meshed", "--out", "beside", "--methods", "hull", cwd=tmp_path).returncode == 0
    assert _run("diff", ".", "--out", "../inside", "--methods", "hull", cwd=tmp_path / "meshed").returncode == 0
    for name in ("report.json", "index.html", "report.md"):
        beside = (tmp_path / "beside" / name).read_bytes()
        assert beside == (tmp_path / "inside" / name).read_bytes(), name
        assert str(tmp_path).encode() not in beside, name
    rows = json.loads((tmp_path / "beside" / "report.json").read_text())["rows"]
    assert rows and all(row["source"].startswith("meshed/") and row["project"] == "meshed" for row in rows), rows
