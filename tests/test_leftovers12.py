"""Small leftovers of the sixth stop, each proven here: ``convert`` refuses a JSON naming two
slots (constraints, skins) alike before writing a ``.skel`` its own reader refuses, ..."""

from __future__ import annotations

import json

import pytest
from test_hostile import check_run, run_cli, snapshot
from test_skel_names_twice import NAME, _doc_3x, _doc_4x

from spinemesh.dataset.format import encode_mesh

# --- convert: a JSON naming two items alike -----------------------------------------------------

def _named_twice(version: str, kind: str) -> tuple[dict, str]:
    """A document of ``version`` whose ``kind`` list holds two items named ``NAME``; the list's key."""
    doc = _doc_3x(version) if version.startswith("3.") else _doc_4x(version)
    if kind == "slots":
        doc["slots"] += [{"name": NAME, "bone": "arm"}, {"name": NAME, "bone": "head"}]
    elif kind == "ik":
        doc["ik"] = [{"name": NAME, "bones": ["arm"], "target": "head"} for _ in range(2)]
    elif kind == "constraints":  # 4.3: one list of every type, the names once per type
        doc["constraints"] = [{"type": "ik", "name": NAME, "bones": ["arm"], "target": "head"} for _ in range(2)]
    elif kind == "skins":
        doc["skins"] += [{"name": NAME, "attachments": {}} for _ in range(2)]
    return doc, kind


def _convert_refused(tmp_path, doc: dict) -> str:
    """``convert x.json x.skel`` of ``doc`` in ``tmp_path``, refused: exit 2, nothing written, and
    the one line it says (returned)."""
    (tmp_path / "x.json").write_text(json.dumps(doc))
    before = snapshot(tmp_path)
    r = run_cli("convert", "x.json", "x.skel", cwd=tmp_path)
    check_run(r, before, tmp_path, ["x.skel"], codes=(0, 2))
    assert r.returncode == 2 and not (tmp_path / "x.skel").exists(), r.stderr
    line = r.stderr.strip()
    assert "\n" not in line, line
    return line


CONVERT_CASES = [("4.2.40", "slots"), ("4.2.40", "ik"), ("4.2.40", "skins"), ("4.3.39", "constraints"),
                 ("4.3.39", "slots"), ("3.8.99", "slots"), ("3.8.99", "skins"), ("3.7.94", "ik")]


@pytest.mark.parametrize("version,kind", CONVERT_CASES, ids=[f"{v}-{k}" for v, k in CONVERT_CASES])
def test_convert_refuses_a_json_naming_two_items_alike(tmp_path, version, kind):
    """The ``.skel`` written from such a JSON was one our own reader refuses (exit 0): now one line
    naming the file and the name in the reader's words, exit 2, nothing written."""
    doc, key = _named_twice(version, kind)
    line = _convert_refused(tmp_path, doc)
    assert line.startswith("error: x.json: cannot be written as a binary skeleton: expected "), line
    assert f"named once each, found {NAME!r} naming two ({key}[" in line, line


def test_a_4_3_constraint_list_may_name_two_of_other_types_alike(tmp_path):
    """4.3's one list is named once per type, as the reader checks it: an IK constraint and a
    transform constraint of one name convert, and read back."""
    from spinemesh.skeleton_binary import encode_skel, read_skel

    doc = _doc_4x("4.3.39")
    doc["constraints"] = [{"type": "ik", "name": NAME, "bones": ["arm"], "target": "head"},
                          {"type": "transform", "name": NAME, "bones": ["arm"], "source": "head"}]
    back = read_skel(encode_skel(doc))
    assert [c["name"] for c in back["constraints"]] == [NAME, NAME]


# --- convert: a number the binary cannot store as it is --------------------------------------------

def _event_doc(value) -> dict:
    doc = _doc_4x("4.2.40")
    doc["events"] = {"hit": {"int": value}}
    doc["animations"]["t"] = {"events": [{"time": 0, "name": "hit"}]}
    return doc


@pytest.mark.parametrize("where", ["event", "key"])
def test_convert_refuses_a_fraction_where_the_binary_stores_an_integer(tmp_path, where):
    """An event's ``int`` of 2.5 was written 2 without a word (exit 0; spine-ts plays the JSON's
    2.5): ``convert`` does one thing whole or refuses, so one line names the field and the value,
    exit 2, nothing written."""
    doc = _event_doc(2.5 if where == "event" else 1)
    if where == "key":
        doc["animations"]["t"]["events"][0]["int"] = 2.5
    line = _convert_refused(tmp_path, doc)
    field = "the event's int" if where == "event" else "an event key's int"
    assert line.startswith("error: x.json: cannot be written as a binary skeleton: ") \
        and f"a whole number for {field}" in line and "got 2.5" in line, line


def test_a_whole_float_where_the_binary_stores_an_integer_converts(tmp_path):
    """``4.0`` (as some tools write a whole number) is that number: converted, read back 4."""
    from spinemesh.skeleton_binary import encode_skel, read_skel

    assert read_skel(encode_skel(_event_doc(4.0)))["events"]["hit"]["int"] == 4


@pytest.mark.parametrize("count", [-1, 1 << 23, 2.5])
def test_a_recorded_timeline_count_no_reader_takes_is_refused(count):
    """``--keep-binary-info``'s ``_skel`` timeline count, edited by hand, was written as given: the
    runtimes only reserve that much (libGDX, spine-csharp) or skip it, so a count read back is
    kept, but a negative one (their load stops) or one past what a ``.skel`` is read with (our
    own reader refused the file) is refused in one line naming the animation."""
    from spinemesh.errors import SkelFormatError
    from spinemesh.skeleton_binary import encode_skel, read_skel

    doc = _event_doc(1)
    doc["_skel"] = {"timelines": {"t": 7}}
    back = read_skel(encode_skel(doc))
    assert back["_skel"]["timelines"] == {"t": 7}  # within the range: kept for the byte-exact round trip
    doc["_skel"] = {"timelines": {"t": count}}
    with pytest.raises(SkelFormatError, match=r"animation 't''s timeline count .*got " + str(count)):
        encode_skel(doc)


# --- one function for every printed name: control characters never raw ----------------------------

#: A name holding ESC (a terminal colour sequence), BEL and a carriage return, and markup.
HOSTILE_NAME = "hero\x1b[31m\x07[b]\rred"


def _drawn(bars) -> str:
    """What the bars print on a terminal (their text, control codes kept as they are)."""
    import io

    from rich.console import Console

    shown = Console(width=200, file=io.StringIO(), force_terminal=True, color_system=None)
    shown.print(bars.make_tasks_table(bars.tasks))
    return shown.file.getvalue()


def test_phase_bars_escape_the_control_characters_of_a_project_name(monkeypatch):
    """``upgrade``'s and ``weights``' bars escaped a project's name for rich's markup only: an ESC
    in it reached the terminal raw (it coloured the rest of the line), a carriage return went back
    to the line's start. Now as every printed name (``console_text``): written as ``\\x1b``."""
    from spinemesh.cli._app import err_console, phase_progress, progress_bar

    monkeypatch.setattr(err_console.real, "width", 200)  # the words' room: the whole name
    bars = progress_bar("upgrade", phases=True)
    progress = phase_progress(bars)
    progress.project(HOSTILE_NAME)
    progress.add("mesh", 10)
    progress.step("mesh", "meshing", HOSTILE_NAME + "/x.png")
    progress.add("read", 10, project=HOSTILE_NAME)
    drawn = _drawn(bars)
    assert "\x1b[31m" not in drawn and "\x07" not in drawn and "\r" not in drawn, repr(drawn)
    assert "hero\\x1b" in drawn and "[b]" in drawn, repr(drawn)


def test_pack_bars_escape_the_control_characters_of_an_atlas_name(monkeypatch):
    from spinemesh.cli._app import err_console, progress_bar
    from spinemesh.cli.pack import atlas_bars

    monkeypatch.setattr(err_console.real, "width", 200)
    bars = progress_bar("pack")
    progress = atlas_bars(bars)
    progress.atlas(HOSTILE_NAME + ".atlas", 10)
    progress.step(HOSTILE_NAME + ".atlas", "placing regions")
    drawn = _drawn(bars)
    assert "\x1b[31m" not in drawn and "\x07" not in drawn and "\r" not in drawn, repr(drawn)
    assert "hero\\x1b" in drawn, repr(drawn)


def test_info_escapes_the_control_characters_of_a_skeleton_name(tmp_path):
    """``info``'s standard output escaped a skeleton's and an atlas's file name for markup only."""
    from spinemesh.demo import make_demo_project

    project = make_demo_project(tmp_path / "p", with_images_folder=False)
    (project / "demo.json").rename(project / "de\x1b[31mmo.json")
    (project / "demo.atlas").rename(project / "at\x1b[31mlas.atlas")
    r = run_cli("info", "p", cwd=tmp_path)
    assert "\x1b" not in r.stdout + r.stderr, repr(r.stdout + r.stderr)
    assert "de\\x1b[31mmo.json" in r.stdout and "at\\x1b[31mlas.atlas" in r.stdout, r.stdout


# --- a data set's members checked as its rows are ------------------------------------------------

@pytest.fixture(scope="module")
def small_dataset(tmp_path_factory):
    """A data set of the demo project upgraded (its meshes stand for an artist's), made by
    ``spinemesh dataset``."""
    from spinemesh.demo import make_demo_project

    tmp = tmp_path_factory.mktemp("ds")
    make_demo_project(tmp / "p")
    r = run_cli("upgrade", "p", "--out", "games/hero", "--jobs", "1", cwd=tmp)
    assert r.returncode == 0, r.stdout + r.stderr
    (tmp / "games" / "hero" / "demo-binary.skel").unlink()
    if not (tmp / "games" / "hero" / "images").is_dir():
        import shutil

        shutil.copytree(tmp / "p" / "images", tmp / "games" / "hero" / "images")
    r = run_cli("dataset", "games", "--out", "ds", "--jobs", "1", cwd=tmp)
    assert r.returncode == 0, r.stdout + r.stderr
    return tmp / "ds"


def _member_replaced(src, tmp, member: str, data: bytes):
    """A copy of the data set ``src`` whose first sample of a ``member`` has ``data`` there
    instead (the index's span made its size); the data set and that row."""
    import shutil

    from spinemesh.dataset import open_dataset

    shutil.copytree(src, tmp / "ds")
    index = tmp / "ds" / "index.jsonl"
    rows = [json.loads(line) for line in index.read_text().splitlines()]
    i = next(i for i, row in enumerate(rows) if row.get(member))
    shard = tmp / "ds" / rows[i]["shard"]
    with open(shard, "ab") as f:
        offset = f.tell()
        f.write(data)
    rows[i][member] = [offset, len(data)]
    index.write_text("".join(json.dumps(row) + "\n" for row in rows))
    ds = open_dataset(tmp / "ds")
    return ds, next(row for row in ds.rows() if row["id"] == rows[i]["id"])


def _mesh(**change) -> dict:
    import numpy as np

    mesh = {"vertices": np.zeros((4, 2), np.float32), "triangles": np.array([[0, 1, 2], [0, 2, 3]], np.int32),
            "hull": np.arange(4, dtype=np.int32), "edges": np.zeros((0, 2), np.int32)}
    mesh.update(change)
    return {k: v for k, v in mesh.items() if v is not None}


def _bomb() -> bytes:
    """A 1-bit PNG of 20000x20000 pixels (over the pixel limit) in a few kilobytes."""
    import io

    from PIL import Image

    buf = io.BytesIO()
    Image.new("1", (20000, 20000)).save(buf, "PNG")
    return buf.getvalue()


@pytest.mark.parametrize("member,data,said", [
    ("mask", b"junk" * 10, "its mask: cannot decode image"),
    ("mask", "bomb", "its mask: image 20000x20000 exceeds the limit of 16384 pixels a side and 89,478,485 pixels"),
    ("mesh", b"junk" * 10, "its mesh is of another form: not a numpy .npz archive"),
    ("mesh", encode_mesh(_mesh(hull=None)), "its mesh is of another form: no hull array"),
    ("mesh", encode_mesh(_mesh(triangles=__import__("numpy").array([[0, 1, 9]], "int32"))),
     "its mesh is of another form: triangles index 9 is not one of its 4 vertices"),
    ("mesh", encode_mesh(_mesh(vertices=__import__("numpy").full((4, 2), float("nan"), "float32"))),
     "its mesh is of another form: a vertex is not a finite number"),
    ("mesh", encode_mesh(_mesh(vertices=__import__("numpy").zeros((4, 3), "float32"))),
     "its mesh is of another form: vertices is an array of float32 (4, 3)"),
], ids=["mask junk", "mask bomb", "mesh junk", "mesh no hull", "mesh index", "mesh NaN", "mesh columns"])
def test_a_data_set_member_is_checked_as_its_row_is(tmp_path, small_dataset, member, data, said):
    """``Dataset.load_mask`` and ``load_mesh`` (the library's) read a member as it was: junk
    bytes were a Pillow or numpy traceback, a mask past the pixel limit was decoded whole, a
    mesh of another form (an array missing, of other columns, NaN, an index past its vertices)
    was handed on. Each is one line naming the shard and the sample now."""
    from spinemesh.errors import SpineMeshError

    ds, row = _member_replaced(small_dataset, tmp_path, member, _bomb() if data == "bomb" else data)
    with pytest.raises(SpineMeshError) as e:
        (ds.load_mask if member == "mask" else ds.load_mesh)(row)
    line = str(e.value)
    assert "\n" not in line and "shards/" in line and f"sample {row['id']}: {said}" in line, line


def test_a_data_set_member_of_the_right_form_still_loads(small_dataset):
    from spinemesh.dataset import open_dataset

    ds = open_dataset(small_dataset)
    rows = list(ds.rows())
    meshes = [ds.load_mesh(row) for row in rows if row["mesh"]]
    assert meshes and all(len(m["vertices"]) and m["triangles"].shape[1] == 3 for m in meshes)
    for row in rows:
        assert (ds.load_mask(row) == (ds.load_image(row)[..., 3] > 128)).all()


# --- a decompression bomb's size said ---------------------------------------------------------------

@pytest.mark.parametrize("size", [(20000, 20000), (10000, 10000), (16000, 8000)])
def test_an_image_past_the_pixel_limit_is_said_with_its_size(tmp_path, size):
    """Pillow refuses an image of too many pixels before it says its size, and the line said
    "image exceeds the limit of 89,478,485 pixels", whatever it claimed. Its header's size is
    said now, in the words of every other size refused (``limits.check_image_size``)."""
    from PIL import Image

    Image.new("1", size).save(tmp_path / "big.png")
    before = snapshot(tmp_path)
    r = run_cli("mesh", "big.png", "--out", "m.json", cwd=tmp_path)
    check_run(r, before, tmp_path, [], codes=(2,))
    w, h = size
    assert r.stderr.strip() == (f"error: big.png: image {w}x{h} exceeds the limit of 16384 pixels a side and "
                                "89,478,485 pixels"), r.stderr


# --- mesh FOLDER names each image as found ----------------------------------------------------------

def test_mesh_folder_names_each_image_from_the_folder(tmp_path):
    """``mesh FOLDER``'s ``info.image`` said ``x.png`` for ``sprites/x.png`` and
    ``sprites/sub/x.png`` alike; each is named from the folder's name now, as reports name a
    project's files, and the same bytes from another folder."""
    import numpy as np
    from PIL import Image

    a = np.zeros((24, 24, 4), np.uint8)
    a[4:20, 4:20] = 255
    (tmp_path / "sprites" / "sub").mkdir(parents=True)
    Image.fromarray(a).save(tmp_path / "sprites" / "x.png")
    Image.fromarray(a).save(tmp_path / "sprites" / "sub" / "x.png")
    r = run_cli("mesh", "sprites", "--out", "m", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    named = {rel: json.loads((tmp_path / "m" / rel).read_text())["info"]["image"] for rel in ("x.json", "sub/x.json")}
    assert named == {"x.json": "sprites/x.png", "sub/x.json": "sprites/sub/x.png"}, named
    (tmp_path / "elsewhere").mkdir()
    r = run_cli("mesh", str(tmp_path / "sprites"), "--out", "m2", cwd=tmp_path / "elsewhere")
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "elsewhere" / "m2" / "sub" / "x.json").read_bytes() == (tmp_path / "m" / "sub" / "x.json").read_bytes()


# --- the weights pictures: a colour per bone ----------------------------------------------------------

def test_every_bone_of_a_mesh_has_a_colour_of_its_own():
    """The weights pictures' palette had 10 colours, repeated from the 11th bone (the corpus has
    meshes of 20 and more bones): each bone's colour is its own now, the first 32 far apart, and
    the legend, the caption and the player draw the same colours."""
    import itertools
    import math

    from spinemesh.player.frames import bone_colours as vertex_colours
    from spinemesh.rig.preview import bone_colour, caption

    colours = [bone_colour(i) for i in range(256)]
    assert len(set(colours)) == 256
    assert min(math.dist(a, b) for a, b in itertools.combinations(colours[:32], 2)) > 25
    names = [f"b{i}" for i in range(30)]
    said = caption(names, "default", "s", "a", "a.png")["bones"]
    assert [b["colour"] for b in said] == ["#{:02x}{:02x}{:02x}".format(*bone_colour(i)) for i in range(30)]
    # the player: a region on the 25th bone is that bone's colour, not the 5th's
    assert tuple(vertex_colours(None, 4, 30, 24)[0]) == bone_colour(24) != bone_colour(4)
    # and a vertex weighted whole on the 25th bone
    mesh = {"type": "mesh", "uvs": [0, 0, 1, 0, 1, 1], "triangles": [0, 1, 2], "hull": 3,
            "vertices": [1, 24, 0, 0, 1, 1, 24, 1, 0, 1, 1, 3, 1, 1, 1]}
    assert [tuple(c) for c in vertex_colours(mesh, 3, 30, 0)] == [bone_colour(24), bone_colour(24), bone_colour(3)]


# --- train refuses a side the export refuses ----------------------------------------------------------

@pytest.mark.parametrize("size", ["100", "4096"])
def test_train_refuses_a_side_its_checkpoint_could_not_be_exported_at(tmp_path, size):
    """``segment-export`` refuses a checkpoint whose ``image_size`` is not a multiple of 32 from 32
    to 2048; ``train --size 100`` trained such a network for as long as asked. Refused first now,
    in one line, as any bad option (exit 2, nothing read or written)."""
    before = snapshot(tmp_path)
    r = run_cli("train", "--data", "nowhere", "--out", "o", "--size", size, cwd=tmp_path)
    check_run(r, before, tmp_path, [], codes=(2,))
    assert r.stderr.startswith(f"error: train: Invalid value for '--size': {size} is not a multiple of 32 from 32 "
                               "to 2048"), r.stderr


def test_a_weights_picture_reads_its_mesh_once(tmp_path, monkeypatch):
    """``write_previews`` read each mesh's vertices twice (the picture, then its caption's names)."""
    import spinemesh.rig.preview as preview
    from spinemesh.demo import make_demo_project
    from spinemesh.rig.document import WeightOptions
    from spinemesh.rig.run import weight_project

    make_demo_project(tmp_path / "p", with_images_folder=False)
    r = run_cli("upgrade", "p", "--out", "u", "--jobs", "1", "--weights", "auto", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    calls = []
    real = preview.parse_vertices
    monkeypatch.setattr(preview, "parse_vertices", lambda *a, **k: calls.append(1) or real(*a, **k))
    result = weight_project(tmp_path / "u", tmp_path / "w", WeightOptions(replace=True), preview=tmp_path / "pics")
    pictures = sorted((tmp_path / "pics").glob("*.png"))
    assert pictures and len(calls) == len(pictures), (len(calls), len(pictures), result.errors)


# --- a library's packing total known before it packs ---------------------------------------------------

def test_a_library_upgrade_tells_its_whole_packing_work_before_packing(tmp_path):
    """``upgrade LIBRARY --pack`` told each project's packing work as it began packing it: the
    ``pack`` bar's total grew once per project and its time left jumped each time. The whole
    library's work is told at the first packing now, each project then telling only how far its
    own differs (nothing here: its copies' pages are the project's), and the work done meets it."""
    from spinemesh.demo import make_demo_project
    from spinemesh.upgrade import Options
    from spinemesh.upgrade.library import upgrade_library
    from spinemesh.upgrade.progress import Progress

    class Recorded(Progress):
        def __init__(self):
            self.told, self.done = [], 0

        def add(self, phase, steps, project=None):
            if phase == "pack":
                self.told.append((steps, self.done))

        def advance(self, phase, steps=1):
            if phase == "pack":
                self.done += steps

    for name in ("hero", "villain", "zombie"):
        make_demo_project(tmp_path / "lib" / name, with_images_folder=False)
    progress = Recorded()
    result = upgrade_library(tmp_path / "lib", tmp_path / "out", Options(pack=True, jobs=1), progress)
    assert result.atlases, result.errors
    (first, before), *later = progress.told
    assert before == 0 and first > 0, progress.told
    assert all(steps <= 0 for steps, _ in later), progress.told  # never grown after the first tell
    assert sum(steps for steps, _ in progress.told) == progress.done, (progress.told, progress.done)


def test_packing_told_ahead_for_a_project_not_packed_is_taken_back():
    """A project whose packing did not happen (unreadable, failed first) takes its share of the
    work told ahead back, so the work done still meets the total."""
    from spinemesh.upgrade.pack import PackAhead, PhaseProgress
    from spinemesh.upgrade.progress import Progress

    class Recorded(Progress):
        def __init__(self):
            self.total = 0

        def add(self, phase, steps, project=None):
            self.total += steps

    progress, ahead = Recorded(), PackAhead({"a": 10, "b": 20, "c": 5})
    ahead.settle(progress, "c")  # before any packing: left out of the whole
    PhaseProgress(progress, lambda: ahead.tell(progress, "a")).work(12)  # a's pages grew by 2
    assert progress.total == 32
    ahead.settle(progress, "a")  # packed: nothing to take back
    ahead.settle(progress, "b")  # not packed
    assert progress.total == 12



def test_pose_says_its_output_with_control_characters_escaped(tmp_path):
    """``pose --out`` said the file it wrote as given: an ESC in its name reached the terminal raw
    (as every line a command prints, the name is escaped now)."""
    from spinemesh.demo import make_demo_project

    make_demo_project(tmp_path / "p", with_images_folder=False)
    r = run_cli("pose", "p/demo.json", "--out", "po\x1b[31mses.json", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert "\x1b" not in r.stderr and "po\\x1b[31mses.json: 1 pose" in r.stderr, repr(r.stderr)
