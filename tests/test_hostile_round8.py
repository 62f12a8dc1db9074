"""Hostile input, eighth round: names as other platforms write and read them (case, Unicode form,
backslashes, trailing dots), and the commands earlier rounds barely touched (mesh, segment,
dataset, diff, info, upgrade's selection options).

As in the earlier rounds (tests/test_hostile*.py), every project is made here by our own code;
each case checks what docs/safety.md promises: one clear line naming the file, never a
traceback, never two outputs silently landing on one file, inputs unchanged.
"""

from __future__ import annotations

import os
import unicodedata
from pathlib import Path

import numpy as np
import pytest
from test_hostile import check_run, run_cli, snapshot

NFD_CAFE = unicodedata.normalize("NFD", "café")
NFC_CAFE = unicodedata.normalize("NFC", "café")


def _png(path: Path, width: int, height: int) -> None:
    import cv2

    rgba = np.zeros((height, width, 4), np.uint8)
    rgba[4:-4, 4:-4] = (40, 90, 200, 255)
    path.parent.mkdir(parents=True, exist_ok=True)
    assert cv2.imwrite(str(path), rgba, [cv2.IMWRITE_WEBP_QUALITY, 101] if path.suffix == ".webp" else [])


def _renamed_demo(folder: Path, names: dict[str, str]) -> Path:
    """The demo project (JSON skeleton only) with regions renamed in its atlas and skeleton alike."""
    from spinemesh.demo import make_demo_project

    project = make_demo_project(folder, with_images_folder=False)
    (project / "demo-binary.skel").unlink()
    for name in ("demo.atlas", "demo.json"):
        text = (project / name).read_text("utf-8")
        for old, new in names.items():
            # JSON spells a backslash twice, the atlas once
            text = text.replace(old, new.replace("\\", "\\\\") if name.endswith(".json") else new)
        (project / name).write_text(text, "utf-8")
    return project


# --- two outputs that are one file on another disk --------------------------------------------

def test_mesh_of_a_folder_never_writes_two_images_onto_one_mesh_file(tmp_path):
    """``hero.png`` and ``hero.webp`` both mesh to ``hero.json``; ``Hero.png`` does too on a
    macOS or Windows disk. The second and third were written over the first without a word
    (3 meshes said written, one file left): now each later one is one line, exit 3."""
    art = tmp_path / "art"
    _png(art / "Hero.png", 40, 40)
    _png(art / "hero.png", 60, 40)
    _png(art / "hero.webp", 50, 30)
    _png(art / "other.png", 30, 30)
    before = snapshot(tmp_path)
    r = run_cli("mesh", "art", "--out", "meshes", "--preview", "previews", cwd=tmp_path)
    check_run(r, before, tmp_path, ["meshes/", "previews/"], codes=(3,))
    assert "2 meshes written" in r.stdout, r.stdout
    skipped = [line for line in r.stderr.splitlines() if line.startswith("skipped:")]
    assert len(skipped) == 2, r.stderr
    assert all("'Hero.json'" in line and "Hero.png" in line for line in skipped), r.stderr
    assert sorted(p.name for p in (tmp_path / "meshes").iterdir()) == [".spinemesh-written", "Hero.json", "other.json"]


@pytest.mark.parametrize("first, second", [
    ("Hero", "hero"),                 # one file on a disk that ignores case
    (NFD_CAFE, NFC_CAFE),             # macOS writes NFD, Linux sees two names
    ("arm\\left", "arm/left"),        # a Windows export's backslash: one file everywhere
    ("arm./left", "arm/left"),        # Windows drops a folder name's trailing dots
], ids=["case", "unicode-form", "backslash", "trailing-dot"])
def test_editor_images_of_two_regions_never_land_on_one_file(tmp_path, first, second):
    """``upgrade --images`` writes ``<region>.png``: two regions naming one file on some disk
    wrote both (one lost there, or on every disk for a backslash); now the second region stays a
    region with one line naming both, and every editor image written is its own region's."""
    project = _renamed_demo(tmp_path / "p", {"demo-head": first, "demo-body": second})
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", "out", "--images", "editor", "--jobs", "1", "--min-saving", "0",
                cwd=tmp_path)
    check_run(r, before, tmp_path, ["out/", "editor/"], codes=(3,))
    lines = [line for line in r.stderr.splitlines() if "editor image not written" in line]
    assert len(lines) == 1, r.stdout + r.stderr
    assert "would be the same file as" in lines[0] or "was written for" in lines[0], lines[0]
    written = [p.relative_to(tmp_path / "editor").as_posix() for p in (tmp_path / "editor").rglob("*.png")]
    from spinemesh.files.names import portable_name

    assert len({portable_name(p) for p in written}) == len(written), written
    assert len(written) == 8 - 1, written  # the demo's eight region images (three spark frames) but one
    assert (project / "demo.png").exists()


# --- an editor's images folder written on macOS or Windows, read on Linux ---------------------

def test_from_images_finds_an_image_as_the_editors_disk_did(tmp_path):
    """A skeleton exported on macOS or Windows names ``demo-head`` for ``Demo-Head.png``,
    ``demo-arm`` for ``demo-arm.PNG`` and ``démo-ring`` (NFC) for a file macOS wrote in NFD: the
    editor found each, Linux found none (three regions left as "no image"). The one image that is
    the file there is read; two such images are one line saying which."""
    import os

    from spinemesh.demo import make_demo_project

    project = make_demo_project(tmp_path / "p", with_images_folder=True)
    (project / "demo-binary.skel").unlink()
    images = project / "images"
    os.rename(images / "demo-head.png", images / "Demo-Head.png")
    os.rename(images / "demo-arm.png", images / "demo-arm.PNG")
    os.rename(images / "demo-ring.png", images / f"{unicodedata.normalize('NFD', 'démo-ring')}.png")
    skeleton = project / "demo.json"
    skeleton.write_text(skeleton.read_text("utf-8").replace("demo-ring", unicodedata.normalize("NFC", "démo-ring")), "utf-8")
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p/demo.json", "--out", "out", "--from-images", "p/images", "--jobs", "1",
                "--min-saving", "0", cwd=tmp_path)
    check_run(r, before, tmp_path, ["out/"], codes=(0,))
    assert "left a region" not in r.stdout + r.stderr

    (images / "DEMO-head.png").write_bytes((images / "Demo-Head.png").read_bytes())
    r = run_cli("upgrade", "p/demo.json", "--out", "out2", "--from-images", "p/images", "--jobs", "1",
                "--min-saving", "0", cwd=tmp_path)
    assert r.returncode == 3 and "Traceback" not in r.stderr, r.stdout + r.stderr
    lines = [line for line in r.stderr.splitlines() if "left a region" in line]
    assert len(lines) == 1 and "DEMO-head.png, Demo-Head.png" in lines[0], r.stderr


# --- segment: a model that is not ours -------------------------------------------------------

@pytest.mark.parametrize("change, said", [
    (lambda c: c.update(input_size=100), "does not take the 1x3x100x100 image"),   # another model's card
    (lambda c: c.update(input_size=10**9), "input_size is 1000000000"),            # was "not enough memory"
    (lambda c: c.update(threshold="x"), "threshold is 'x'"),
    (lambda c: c.update(threshold=float("nan")), "threshold is nan"),
    (lambda c: c.update(inference={"flips": "yes"}), "inference is not an object"),
    (lambda c: [c], "card is a JSON list"),                                          # was a traceback
], ids=["other-size", "huge-size", "text-threshold", "nan-threshold", "text-flips", "list"])
def test_segment_with_a_model_whose_card_is_not_ours_is_one_line(tmp_path, change, said):
    """``segment --model`` reads the card beside the model: a card from another model, or one
    edited by hand, ended in a traceback (onnxruntime's, a KeyError, an AttributeError), or in
    "not enough memory" for a side of a billion; now one line naming the model or its card."""
    import json
    import shutil

    from spinemesh.segment import DEFAULT_MODEL

    shutil.copyfile(DEFAULT_MODEL, tmp_path / "other.onnx")
    card = json.loads(DEFAULT_MODEL.with_suffix(".json").read_text("utf-8"))
    card = change(card) or card
    (tmp_path / "other.json").write_text(json.dumps(card), "utf-8")
    _png(tmp_path / "art.png", 48, 40)
    before = snapshot(tmp_path)
    r = run_cli("segment", "art.png", "--out", "mask.png", "--mask", "model", "--model", "other.onnx", cwd=tmp_path)
    check_run(r, before, tmp_path, [], codes=(2,))
    errors = [line for line in r.stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1 and said in errors[0] and "other." in errors[0], r.stderr


# --- diff ---------------------------------------------------------------------------------------

def test_diff_says_every_artist_mesh_it_cannot_compare(tmp_path):
    """An artist mesh of broken numbers (a vertex of 1e308, uvs cut short), in any skin, was
    neither compared nor listed as skipped: it vanished from the report. Each is now a skipped
    row with the field that is wrong; a skin sharing a name with the default skin is its own row."""
    import copy
    import json

    from spinemesh.demo import make_demo_project
    from spinemesh.upgrade import Options, upgrade_project

    demo = make_demo_project(tmp_path / "demo", with_images_folder=False)
    (demo / "demo-binary.skel").unlink()
    upgrade_project(demo, tmp_path / "p", Options(min_saving=None, jobs=1))
    skeleton = tmp_path / "p" / "demo.json"
    doc = json.loads(skeleton.read_text("utf-8"))
    meshes = doc["skins"][0]["attachments"]
    meshes["body"]["demo-body"]["vertices"][1] = 1e308
    meshes["ring"]["demo-ring"]["uvs"] = meshes["ring"]["demo-ring"]["uvs"][:-2]
    doc["skins"].append({"name": "other", "attachments": {"head": {
        "demo-head": copy.deepcopy(meshes["body"]["demo-body"]) | {"path": "demo-head"}}}})
    skeleton.write_text(json.dumps(doc), "utf-8")
    before = snapshot(tmp_path)
    r = run_cli("diff", "p", "--out", "d", "--methods", "default", cwd=tmp_path)
    check_run(r, before, tmp_path, ["d/"], codes=(0,))
    report = json.loads((tmp_path / "d" / "report.json").read_text("utf-8"))
    compared = {(row["slot"], row["attachment"]) for row in report["rows"]}
    said = [(s["slot"], s["attachment"], s["reason"]) for s in report["skipped"]]
    assert ("body", "demo-body") not in compared and ("ring", "demo-ring") not in compared
    assert any(s[:2] == ("body", "demo-body") and "skins[0]" in s[2] for s in said), said
    assert any(s[:2] == ("ring", "demo-ring") for s in said), said
    assert any(s[:2] == ("head", "demo-head") and "skins[1]" in s[2] for s in said), said
    assert ("head", "demo-head") in compared  # the default skin's head is compared still
    assert f"{len(report['rows'])} attachments compared, {len(said)} skipped" in r.stdout


# --- names near the 255-byte limit ------------------------------------------------------------

@pytest.mark.parametrize("stem", ["k" * 250, "é" * 122], ids=["ascii-250", "two-byte-letters"])
def test_a_skeleton_named_near_the_limit_is_written_like_any_other(tmp_path, stem):
    """A skeleton whose name is within the 255-byte limit (250 bytes and ``.json``) could not be
    written: the temporary file beside it, ``.<name>.<token>.tmp``, was 14 bytes longer, and the
    run ended on "File name too long" with the atlas copied and no skeleton. The temporary name
    is cut to the limit (inside a two-byte letter too)."""
    import os

    from spinemesh.demo import make_demo_project

    project = make_demo_project(tmp_path / "p", with_images_folder=False)
    (project / "demo-binary.skel").unlink()
    name = f"{stem}.json"
    assert 245 <= len(os.fsencode(name)) <= 255
    os.rename(project / "demo.json", project / name)
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", "out", "--preview", "preview", "--report", "report.json", "--jobs", "1",
                cwd=tmp_path)
    check_run(r, before, tmp_path, ["out/", "preview/", "report.json"], codes=(0,))
    assert (tmp_path / "out" / name).is_file() and (tmp_path / "preview" / "index.html").is_file()


# --- upgrade --from-images: images of other sizes and colour modes --------------------------

def test_from_images_of_other_proportions_than_the_region_stay_regions(tmp_path):
    """``--from-images`` meshes the folder's image and scales the mesh to the attachment's
    width and height, over the region the runtime draws. An image cropped to half its height
    was meshed without a word: its outline, stretched, lay beside the art. It now stays a region
    with one line giving both sizes; an image at twice the size (another export scale), a
    palette, grey-and-alpha, 16-bit, 1-bit or CMYK JPEG image is meshed as before."""
    import json

    from PIL import Image

    from spinemesh.demo import make_demo_project

    project = make_demo_project(tmp_path / "p", with_images_folder=True)
    (project / "demo-binary.skel").unlink()
    images = project / "images"
    with Image.open(images / "demo-head.png") as im:
        im.crop((0, 0, im.width, im.height // 2)).save(images / "demo-head.png")
    with Image.open(images / "demo-body.png") as im:
        im.resize((im.width * 2, im.height * 2)).convert("P").save(images / "demo-body.png")
    for name, mode in (("demo-arm", "LA"), ("demo-ring", "I;16"), ("demo-blobs", "1")):
        with Image.open(images / f"{name}.png") as im:
            im.convert(mode).save(images / f"{name}.png")
    with Image.open(images / "demo-spark" / "frame1.png") as im:
        im.convert("CMYK").save(images / "demo-spark" / "frame1.jpg")
    (images / "demo-spark" / "frame1.png").unlink()
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", "out", "--from-images", "p/images", "--jobs", "1", "--min-saving", "0",
                "--report", "report.json", cwd=tmp_path)
    check_run(r, before, tmp_path, ["out/", "report.json"], codes=(3,))
    lines = [line for line in r.stderr.splitlines() if "left a region" in line]
    assert len(lines) == 1 and "'demo-head'" in lines[0] and "90x45" in lines[0] and "90x90" in lines[0], r.stderr
    kinds = {name: att.get("type", "region")
             for slot in json.loads((tmp_path / "out" / "demo.json").read_text("utf-8"))["skins"][0]["attachments"].values()
             for name, att in slot.items()}
    assert kinds == {"demo-arm": "mesh", "demo-body": "mesh", "demo-head": "region", "demo-ring": "mesh",
                     "demo-blobs": "mesh", "spark": "mesh"}, kinds


# --- passed as they were, kept as tests ----------------------------------------------------------

@pytest.mark.parametrize("options, code, said", [
    (["--only", "zzz*"], 2, "not matched by --only"),
    (["--only", "[demo"], 2, "not matched by --only"),          # regex-like text is a glob, matching nothing
    (["--exclude", "*"], 2, "matched by --exclude"),
    (["--only", "*", "--exclude", "demo-head"], 0, "matched by --exclude"),
    (["--min-size", "1e308"], 0, "smaller than --min-size"),
    (["--min-size", "inf"], 2, "must be a finite number"),
    (["--min-size", "nan"], 2, "must be a finite number"),
], ids=["only-nothing", "only-bracket", "exclude-all", "only-all-exclude-most", "min-size-huge", "min-size-inf",
        "min-size-nan"])
def test_selection_options_at_their_extremes(tmp_path, options, code, said):
    """``--only``/``--exclude``/``--min-size`` matching nothing or everything, regex-like text, a
    size of 1e308, inf or NaN: the exit status the help promises and the reason said."""
    from spinemesh.demo import make_demo_project

    make_demo_project(tmp_path / "p", with_images_folder=False)
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", "out", "--jobs", "1", *options, cwd=tmp_path)
    text = r.stdout + r.stderr
    assert r.returncode == code and said in text and "Traceback" not in text, text
    assert {k: v for k, v in snapshot(tmp_path).items() if not k.startswith("out/")} == before


@pytest.mark.parametrize("command", [
    ["diff", "p", "--out", "p/d"], ["dataset", "p", "--out", "p/ds"], ["mesh", "p", "--out", "p/m"],
    ["info", "p/demo.atlas"], ["info", "p/demo.png"],
], ids=["diff-inside", "dataset-inside", "mesh-inside", "info-atlas", "info-image"])
def test_other_commands_refuse_in_one_line(tmp_path, command):
    """Outputs inside their input, ``info`` of a file that is no skeleton: one line, nothing written."""
    from spinemesh.demo import make_demo_project

    make_demo_project(tmp_path / "p", with_images_folder=False)
    before = snapshot(tmp_path)
    r = run_cli(*command, cwd=tmp_path)
    check_run(r, before, tmp_path, [], codes=(2,))
    assert len([line for line in r.stderr.splitlines() if line.startswith("error:")]) == 1, r.stderr


# --- info ----------------------------------------------------------------------------------------

def test_info_counts_and_says_the_attachments_it_cannot_use(tmp_path):
    """``info`` counted only the attachments it could use: regions whose width is text, whose x
    is "1e999", and 30 in another skin whose height is text vanished from the count, exit 0 and
    "every attachment image was found". They are counted and each is a problem line naming its
    field (exit 3, as for an unreadable skeleton); past 20, one line counts the rest."""
    import copy
    import json

    from spinemesh.demo import make_demo_project

    project = make_demo_project(tmp_path / "p", with_images_folder=False)
    (project / "demo-binary.skel").unlink()
    skeleton = project / "demo.json"
    doc = json.loads(skeleton.read_text("utf-8"))
    regions = doc["skins"][0]["attachments"]
    regions["body"]["demo-body"]["width"] = "wide"
    regions["head"]["demo-head"]["x"] = "1e999"
    doc["skins"].append({"name": "crowd", "attachments": {
        f"slot{i}": {"demo-ring": copy.deepcopy(regions["ring"]["demo-ring"]) | {"height": "tall"}} for i in range(30)}})
    skeleton.write_text(json.dumps(doc), "utf-8")
    before = snapshot(tmp_path)
    r = run_cli("info", "p", cwd=tmp_path)
    check_run(r, before, tmp_path, [], codes=(3,))
    problems = [line for line in r.stderr.splitlines() if line.startswith("problem:")]
    assert any("skins[0].attachments.body.demo-body.width" in line for line in problems), r.stderr
    assert any("skins[0].attachments.head.demo-head.x" in line for line in problems), r.stderr
    assert len(problems) == 20 + 1 and "12 more attachments that cannot be used" in problems[-1], r.stderr
    assert "total           │    36" in r.stdout.replace("┃", "│"), r.stdout


# --- dataset -------------------------------------------------------------------------------------

def test_dataset_counts_the_attachments_it_cannot_use(tmp_path):
    """A data set left an attachment of broken fields (a mesh vertex of 1e308, a region width of
    text) out without a word, in neither ``samples`` nor ``skipped``: the project's row counts them
    now, and its other images are extracted."""
    import json

    from spinemesh.demo import make_demo_project
    from spinemesh.upgrade import Options, upgrade_project

    demo = make_demo_project(tmp_path / "demo", with_images_folder=False)
    (demo / "demo-binary.skel").unlink()
    upgrade_project(demo, tmp_path / "corpus" / "p", Options(min_saving=None, jobs=1))
    skeleton = tmp_path / "corpus" / "p" / "demo.json"
    doc = json.loads(skeleton.read_text("utf-8"))
    doc["skins"][0]["attachments"]["body"]["demo-body"]["vertices"][1] = 1e308
    doc["skins"][0]["attachments"]["ring"]["demo-ring"] = {"width": "wide", "height": 10}
    skeleton.write_text(json.dumps(doc), "utf-8")
    before = snapshot(tmp_path)
    r = run_cli("dataset", "corpus", "--out", "ds", "--jobs", "1", cwd=tmp_path)
    check_run(r, before, tmp_path, ["ds/"], codes=(0, 3))
    row = json.loads((tmp_path / "ds" / "projects.jsonl").read_text("utf-8").splitlines()[-1])
    assert row["skipped"].get("attachment of unusable fields") == 2, row
    assert row["samples_found"] >= 4, row


def test_preview_pages_of_skeletons_named_apart_by_case_only_are_two_files_everywhere(tmp_path):
    """``Hero.json`` and ``hero.json`` in one project got ``s/Hero.html`` and ``s/hero.html`` and
    two data folders of those names: one page and one folder, the other's files mixed in, once
    the preview is copied to a macOS or Windows disk. Each page and folder is its own there."""
    import os
    import shutil

    from spinemesh.demo import make_demo_project
    from spinemesh.files.names import portable_name

    project = make_demo_project(tmp_path / "p", with_images_folder=False)
    (project / "demo-binary.skel").unlink()
    shutil.copyfile(project / "demo.json", project / "Hero.json")
    os.rename(project / "demo.json", project / "hero.json")
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", "out", "--preview", "preview", "--jobs", "1", cwd=tmp_path)
    check_run(r, before, tmp_path, ["out/", "preview/"], codes=(0,))
    for folder in ("s", "data"):
        names = [p.name for p in (tmp_path / "preview" / folder).iterdir()]
        assert len(names) == 2 and len({portable_name(n) for n in names}) == 2, names
    index = (tmp_path / "preview" / "index.html").read_text("utf-8")
    for page in (tmp_path / "preview" / "s").iterdir():
        assert f'href="s/{page.name}"' in index


def test_a_new_page_is_never_named_as_a_page_of_another_case():
    """An atlas of pages ``hero.png`` and ``Hero-2.png`` whose first page packs onto two pages
    named the new one ``hero-2.png``: beside ``Hero-2.png``, one file on a macOS or Windows disk,
    one page's texels lost there. The new page takes the next name free on every disk."""
    from spinemesh.atlas import parse_atlas
    from spinemesh.pack.atlas_pack import _page_name

    page = "{}\nsize: 64,64\nformat: RGBA8888\nfilter: Linear,Linear\nrepeat: none\n{}\n  bounds: 0,0,8,8\n"
    atlas = parse_atlas(page.format("hero.png", "a") + "\n" + page.format("Hero-2.png", "b"))
    assert [p.name for p in atlas.pages] == ["hero.png", "Hero-2.png"]
    assert _page_name(atlas, [0], 0, set()) == "hero.png"
    assert _page_name(atlas, [0], 1, set()) == "hero-3.png"
    assert _page_name(atlas, [0], 1, {"HERO-3.png"}) == "hero-4.png"


def test_diff_of_one_project_given_twice_compares_it_once(tmp_path):
    """``diff p p/demo.json ./p/`` compared every artist mesh three times and said so (three
    times the attachments, each row thrice in the report): each skeleton is compared once."""
    import json

    from spinemesh.demo import make_demo_project
    from spinemesh.upgrade import Options, upgrade_project

    demo = make_demo_project(tmp_path / "demo", with_images_folder=False)
    (demo / "demo-binary.skel").unlink()
    upgrade_project(demo, tmp_path / "p", Options(min_saving=None, jobs=1))
    r = run_cli("diff", "p", "--out", "once", "--methods", "default", cwd=tmp_path)
    assert r.returncode == 0, r.stdout + r.stderr
    before = snapshot(tmp_path)
    r = run_cli("diff", "p", "p/demo.json", "./p/", "--out", "thrice", "--methods", "default", cwd=tmp_path)
    check_run(r, before, tmp_path, ["thrice/"], codes=(0,))
    rows = [json.loads((tmp_path / d / "report.json").read_text("utf-8"))["rows"] for d in ("once", "thrice")]
    assert len(rows[1]) == len(rows[0]) == 6, [len(r) for r in rows]


@pytest.mark.parametrize("command", [["pack", "p", "--out", "out"],
                                     ["upgrade", "p", "--out", "out", "--pack", "--jobs", "1"]], ids=["pack", "upgrade-pack"])
def test_a_page_named_with_a_backslash_is_written_where_it_was_read(tmp_path, command):
    """An atlas exported on Windows names its page ``pages\\demo.png``: read from
    ``pages/demo.png``, its packed page was written to a file named ``pages\\demo.png`` at the top
    of the output (a name Windows cannot hold), ``pages/`` left without it. It is written to
    ``pages/demo.png``, under the name the atlas says, as it was read."""
    import os

    from spinemesh.demo import make_demo_project

    project = make_demo_project(tmp_path / "p", with_images_folder=False)
    (project / "demo-binary.skel").unlink()
    (project / "pages").mkdir()
    os.rename(project / "demo.png", project / "pages" / "demo.png")
    atlas = project / "demo.atlas"
    atlas.write_text(atlas.read_text("utf-8").replace("demo.png", "pages\\demo.png"), "utf-8")
    before = snapshot(tmp_path)
    r = run_cli(*command, cwd=tmp_path)
    check_run(r, before, tmp_path, ["out/"], codes=(0,))
    written = [p.relative_to(tmp_path / "out").as_posix() for p in (tmp_path / "out").rglob("*") if p.is_file()]
    assert "pages/demo.png" in written and not any("\\" in name for name in written), written
    assert (tmp_path / "out" / "demo.atlas").read_text("utf-8").startswith("pages\\demo.png"), written


@pytest.mark.parametrize("command", [["pack", "p", "--out", "out"], ["upgrade", "p", "--out", "out", "--jobs", "1"]],
                         ids=["pack", "upgrade"])
def test_a_page_file_whose_own_name_holds_a_backslash_is_refused_in_one_line_naming_its_folder(tmp_path, command):
    """On a Linux or macOS disk ``pages\\demo.png`` can be one file. libGDX and spine-c there load
    it by that name; Windows and browsers (spine-ts) read the page as ``pages/demo.png``, so the
    project loads on some runtimes only. It is refused in one line saying so and where to move
    it; the line said ``page image 'pages\\\\demo.png' not found`` of a file that was there."""
    from spinemesh.demo import make_demo_project

    project = make_demo_project(tmp_path / "p", with_images_folder=False)
    (project / "demo-binary.skel").unlink()
    os.rename(project / "demo.png", project / "pages\\demo.png")
    atlas = project / "demo.atlas"
    atlas.write_text(atlas.read_text("utf-8").replace("demo.png", "pages\\demo.png"), "utf-8")
    before = snapshot(tmp_path)
    r = run_cli(*command, cwd=tmp_path)
    said = [line for line in r.stderr.splitlines() if "backslash" in line]
    assert len(said) == 1 and "move it to 'pages/demo.png'" in said[0] and "libGDX" in said[0], r.stderr
    assert "not found" not in said[0] and "Traceback" not in r.stderr
    check_run(r, before, tmp_path, ["out/"], codes=(2, 3))


@pytest.mark.parametrize("folder, options", [
    (False, ["--out", "m.json", "--preview", "a.png", "--steps", "a.png"]),
    (False, ["--out", "m.json", "--preview", "b.png", "--steps", "B.png"]),
    (False, ["--out", "m.json", "--preview", "m.json"]),
    (True, ["--out", "meshes", "--preview", "pictures", "--steps", "Pictures"]),
], ids=["same-file", "same-file-but-case", "preview-over-mesh", "same-folder-but-case"])
def test_mesh_never_writes_two_of_its_outputs_to_one_file(tmp_path, folder, options):
    """``mesh hero.png --preview a.png --steps a.png`` said "wrote m.json, a.png, a.png" and left
    the steps alone; ``b.png`` and ``B.png`` do the same on a macOS or Windows disk, as two
    folders whose names differ by case: one line naming both, nothing written."""
    _png(tmp_path / "art" / "hero.png", 40, 40)
    before = snapshot(tmp_path)
    r = run_cli("mesh", "art" if folder else "art/hero.png", *options, cwd=tmp_path)
    check_run(r, before, tmp_path, [], codes=(2,))
    assert "are the same path" in r.stderr, r.stderr


def test_a_region_named_apart_by_case_or_unicode_form_only_is_said_so(tmp_path):
    """A skeleton names ``démo-head`` (NFC) where its atlas, saved on macOS, says it in NFD, and
    ``demo-body`` where the atlas says ``Demo-Body``: runtimes match names exactly and find
    neither, so both stay regions, but the line said only "no atlas region named": it names the
    region that differs in case or Unicode form only."""
    project = _renamed_demo(tmp_path / "p", {})
    atlas, skeleton = project / "demo.atlas", project / "demo.json"
    atlas.write_text(atlas.read_text("utf-8").replace("demo-head", unicodedata.normalize("NFD", "démo-head"))
                     .replace("demo-body", "Demo-Body"), "utf-8")
    skeleton.write_text(skeleton.read_text("utf-8").replace("demo-head", unicodedata.normalize("NFC", "démo-head")),
                        "utf-8")
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", "out", "--jobs", "1", cwd=tmp_path)
    check_run(r, before, tmp_path, ["out/"], codes=(3,))
    lines = [line for line in r.stderr.splitlines() if "left a region" in line]
    assert len(lines) == 2 and all("other in case or Unicode form only" in line for line in lines), r.stderr
    assert any("'Demo-Body'" in line for line in lines), r.stderr


@pytest.mark.parametrize("pattern", [unicodedata.normalize("NFC", "café*"), "arms/*"],
                         ids=["nfc-pattern", "slash-pattern"])
def test_only_matches_names_from_another_platform(tmp_path, pattern):
    """``--only 'café*'`` typed on Linux (NFC) matched no region a macOS export names in NFD, and
    ``--only 'arms/*'`` no image path a Windows export writes ``arms\\left``: every region was
    kept, exit 2. The pattern matches the same letters in either form, and backslashes as the
    folders they are."""
    import json

    _renamed_demo(tmp_path / "p", {"demo-head": unicodedata.normalize("NFD", "café-head"),
                                   "demo-body": "arms\\left"})
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", "out", "--jobs", "1", "--min-saving", "0", "--only", pattern, cwd=tmp_path)
    check_run(r, before, tmp_path, ["out/"], codes=(0,))
    meshed = {name for slot in json.loads((tmp_path / "out" / "demo.json").read_text("utf-8"))["skins"][0]
              ["attachments"].values() for name, att in slot.items() if att.get("type") == "mesh"}
    assert len(meshed) == 1, meshed
