"""Hostile input, tenth round, second half: the inputs of the commands the earlier rounds barely
attacked (``mesh``, ``segment``, ``segment-export``, ``convert``).

As in the earlier rounds (tests/test_hostile*.py), every input is made here by our own code;
each case checks what docs/safety.md promises: one clear line naming the file, never a
traceback, never a wrong output written silently, inputs unchanged.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from test_hostile import check_run, json_demo, run_cli, snapshot

# --- convert: integers the binary format cannot hold ----------------------------------------------

@pytest.mark.parametrize("where", ["event", "key"])
@pytest.mark.parametrize("value", [2 ** 40, 2 ** 31, -(2 ** 31) - 1])
def test_an_integer_past_32_bits_is_not_written_cut(tmp_path, value, where):
    """An event's ``int`` (or a key's) is a varint of 32 bits in a ``.skel``. One of 2**40 was
    written cut to its low bits and read back 256 (2**31 read back -1), exit 0: the game got
    another number than the JSON held. Now the skeleton is refused in one line naming the field,
    and nothing is written."""
    skeleton = json_demo(tmp_path) / "demo.json"
    doc = json.loads(skeleton.read_text())
    doc["events"] = {"hit": {"int": value if where == "event" else 0}}
    key = {"time": 0, "name": "hit", **({"int": value} if where == "key" else {})}
    next(iter(doc["animations"].values()))["events"] = [key]
    skeleton.write_text(json.dumps(doc))
    before = snapshot(tmp_path)
    r = run_cli("convert", "p/demo.json", "out.skel", cwd=tmp_path)
    check_run(r, before, tmp_path, [], codes=(2,))
    assert "demo.json: cannot be written as a binary skeleton" in r.stderr, r.stderr
    assert f"int (the binary format's range), got {value}" in r.stderr, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1, r.stderr


def test_the_ends_of_the_32_bit_range_go_through(tmp_path):
    """The largest and smallest 32-bit ints are written and read back exactly."""
    skeleton = json_demo(tmp_path) / "demo.json"
    doc = json.loads(skeleton.read_text())
    doc["events"] = {"low": {"int": -(2 ** 31)}, "high": {"int": 2 ** 31 - 1}}
    skeleton.write_text(json.dumps(doc))
    for args in (("p/demo.json", "out.skel"), ("out.skel", "back.json")):
        r = run_cli("convert", *args, cwd=tmp_path)
        assert r.returncode == 0, r.stdout + r.stderr
    back = json.loads((tmp_path / "back.json").read_text())["events"]
    assert back == {"low": {"int": -(2 ** 31)}, "high": {"int": 2 ** 31 - 1}}


# --- checkpoints and models that are not ours, or broken ------------------------------------------

_SMALL = {"encoder": "efficientnet-lite0", "image_size": 64, "decoder_channels": [16, 8, 8, 4]}


def _weights(config: dict = _SMALL) -> dict:
    from spinemesh.train.model import build_model

    return build_model(config).state_dict()


def _nan(weights: dict) -> dict:
    import torch

    key = "decoder.blocks.0.reduce.weight"
    return {**weights, key: torch.full_like(weights[key], float("nan"))}


@pytest.mark.parametrize("case, said", [
    ("size 100", "the checkpoint's image_size is 100, not a multiple of 32 from 32 to 2048"),
    ("NaN weights", "1 weight(s) of NaN or infinity, the first 'decoder.blocks.0.reduce.weight': the training diverged"),
])
def test_segment_export_of_a_checkpoint_it_cannot_make_is_one_line(tmp_path, case, said):
    """A checkpoint whose ``image_size`` is not a multiple of 32 ended ``segment-export`` in a
    ValueError traceback, after every data set was read; one of NaN weights was exported (its
    parity of NaN was read as 0 by ``max``) as a model that masks nothing, exit 0. Both are one
    line naming the checkpoint now, before the data sets are read (here an empty folder: its
    own refusal would come later), and nothing is written."""
    import torch

    weights = _weights()
    config = dict(_SMALL, image_size=100) if case == "size 100" else _SMALL
    torch.save({"config": config, "model": _nan(weights) if case == "NaN weights" else weights,
                "metrics": {}}, tmp_path / "best.pt")
    (tmp_path / "ds").mkdir()
    before = snapshot(tmp_path)
    r = run_cli("segment-export", "best.pt", "--data", "ds", "--out", "m.onnx", "--fp32", cwd=tmp_path)
    check_run(r, before, tmp_path, [], codes=(2,))
    assert f"best.pt: {said}" in r.stderr, r.stderr


def test_a_checkpoint_of_another_network_is_one_line():
    """Another encoder, another decoder, weights missing or extra or not tensors, a config that
    is not one: each was a KeyError, RuntimeError, TypeError or AttributeError traceback from
    deep in torch (a decoder of 100000 channels asked for 360 GB first); each is now one line
    naming the checkpoint and what differs."""
    from spinemesh.errors import SpineMeshError
    from spinemesh.train.export import model_of

    weights = _weights()
    first = next(iter(weights))
    cases = {
        "no encoder": ({"image_size": 64}, weights, "its config makes none (KeyError: 'encoder')"),
        "other encoder": (dict(_SMALL, encoder="resnet50"), weights, "unknown encoder 'resnet50'"),
        "b0's weights": (dict(_SMALL, encoder="efficientnet-b0"), weights, "64 weight(s) missing, the first "),
        "half the weights": (_SMALL, dict(list(weights.items())[::2]), "weight(s) missing, the first "),
        "an extra weight": (_SMALL, {**weights, "head.extra": weights[first]},
                            "1 weight(s) not in the network, the first 'head.extra'"),
        "other decoder": (dict(_SMALL, decoder_channels=[32, 16, 8, 4]), weights, "of another shape"),
        "not a tensor": (_SMALL, {**weights, first: 3}, f"1 weight(s) not tensors, the first '{first}'"),
        "size as text": (dict(_SMALL, image_size="64"), weights, "image_size is '64', not a multiple of 32"),
        "size 0": (dict(_SMALL, image_size=0), weights, "image_size is 0, not a multiple of 32"),
        "100000 channels": (dict(_SMALL, decoder_channels=[100000, 8, 8, 4]), weights,
                            "decoder_channels are [100000, 8, 8, 4], not 1 to 8 counts from 1 to 2048"),
        "-1 channels": (dict(_SMALL, decoder_channels=[-1, 8, 8, 4]), weights, "decoder_channels are [-1, 8, 8, 4]"),
    }
    for name, (config, held, said) in cases.items():
        with pytest.raises(SpineMeshError) as e:
            model_of({"config": config, "model": held}, "best.pt")
        assert str(e.value).startswith("best.pt: ") and said in str(e.value), (name, str(e.value))
        assert "\n" not in str(e.value), name
    assert model_of({"config": _SMALL, "model": weights}, "best.pt").config["image_size"] == 64


def _nan_model(folder: Path, side: int = 32) -> Path:
    """An ONNX model of spinemesh's input and output whose logits are all NaN, with its card."""
    import onnx
    from onnx import TensorProto, helper

    graph = helper.make_graph(
        [helper.make_node("Mul", ["image", "nan"], ["scaled"]),
         helper.make_node("ReduceMean", ["scaled"], ["logits"], axes=[1], keepdims=1)],
        "nan", [helper.make_tensor_value_info("image", TensorProto.FLOAT, [1, 3, side, side])],
        [helper.make_tensor_value_info("logits", TensorProto.FLOAT, [1, 1, side, side])],
        [helper.make_tensor("nan", TensorProto.FLOAT, [1], [float("nan")])])
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 13)])
    model.ir_version = 8
    path = folder / "nan.onnx"
    onnx.save(model, str(path))
    card = json.loads((Path(__file__).parents[1] / "spinemesh" / "models" / "segment.json").read_text())
    (folder / "nan.json").write_text(json.dumps(dict(card, input_size=side, inference={})))
    return path


def test_a_model_of_nan_logits_writes_no_mask(tmp_path):
    """A model whose logits are NaN (a training run that diverged) gave ``segment`` an empty
    mask, written with a warning that the art looked empty, exit 0. Now it is one line naming
    the model, and no mask is written."""
    from PIL import Image

    _nan_model(tmp_path)
    rgb = np.zeros((40, 50, 3), np.uint8)
    rgb[10:30, 10:40] = (200, 40, 40)
    Image.fromarray(rgb).save(tmp_path / "art.png")
    before = snapshot(tmp_path)
    r = run_cli("segment", "art.png", "--model", "nan.onnx", "--mask", "model", "--out", "mask.png", cwd=tmp_path)
    check_run(r, before, tmp_path, [], codes=(2,))
    assert "nan.onnx: the model gives logits of NaN or infinity" in r.stderr, r.stderr


# --- names a progress bar shows ---------------------------------------------------------------------

def _sprite(path: Path, size=(20, 30)) -> None:
    from PIL import Image

    a = np.zeros((*size, 4), np.uint8)
    a[4:-4, 5:-5] = 255
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(a).save(path)


def test_a_file_named_as_markup_is_meshed(tmp_path):
    """``mesh FOLDER`` names each image in its progress bar, which reads its words as rich markup:
    an image at ``a[/]b.png`` (a folder ``a[`` holding ``]b.png``) ended the run in a MarkupError
    traceback, exit 1, a mesh half written. Every image is meshed now, its name shown as it is."""
    art = tmp_path / "art"
    _sprite(art / "a[" / "]b.png")
    _sprite(art / "[bold red]c.png")
    before = snapshot(tmp_path)
    r = run_cli("mesh", "art", "--out", "meshes", cwd=tmp_path)
    check_run(r, before, tmp_path, ["meshes/"], codes=(0,))
    assert (tmp_path / "meshes" / "a[" / "]b.json").is_file() and (tmp_path / "meshes" / "[bold red]c.json").is_file()
    (tmp_path / "o[").mkdir()
    before = snapshot(tmp_path)
    r = run_cli("mesh", "art/[bold red]c.png", "--out", "o[/]m.json", cwd=tmp_path)  # its line names it too
    check_run(r, before, tmp_path, ["o[/]m.json"], codes=(0,))
    assert "wrote o[/]m.json" in r.stdout, r.stdout


def test_an_animation_named_as_markup_is_posed(tmp_path):
    """``pose -a 'a[/]b'`` named its progress bar after the animation: a MarkupError traceback."""
    skeleton = json_demo(tmp_path) / "demo.json"
    doc = json.loads(skeleton.read_text())
    animations = doc["animations"]
    animations["a[/]b"] = animations.pop(next(iter(animations)))
    skeleton.write_text(json.dumps(doc))
    before = snapshot(tmp_path)
    r = run_cli("pose", "p/demo.json", "-a", "a[/]b", "--times", "0.1", "--out", "pose.json", cwd=tmp_path)
    check_run(r, before, tmp_path, ["pose.json"], codes=(0,))
    assert len(json.loads((tmp_path / "pose.json").read_text())["poses"]) == 2


@pytest.mark.parametrize("folder", [False, True], ids=["file", "folder"])
def test_an_image_named_in_bytes_not_utf8_is_meshed(tmp_path, folder):
    """An image whose name holds bytes that are not UTF-8 (``bad\\xff.png``, from an old archive)
    was refused ("not written: text holds an invalid character"): the mesh names its image, and
    that name could not be written as JSON. The mesh is written now, naming the image with U+FFFD
    for each such byte, under the image's own name."""
    import os

    name = os.fsdecode(b"bad\xff.png")
    _sprite(tmp_path / "art" / name)
    before = snapshot(tmp_path)
    if folder:
        r = run_cli("mesh", "art", "--out", "meshes", cwd=tmp_path)
        written = tmp_path / "meshes" / os.fsdecode(b"bad\xff.json")
    else:
        r = run_cli("mesh", f"art/{name}", "--out", "m.json", cwd=tmp_path)
        written = tmp_path / "m.json"
    check_run(r, before, tmp_path, ["meshes/" if folder else "m.json"], codes=(0,))
    # a folder run names it from the folder's name (as reports name a project's files)
    assert json.loads(written.read_text())["info"]["image"] == ("art/" if folder else "") + "bad\ufffd.png"


# --- diff: artist meshes of odd fields ------------------------------------------------------------

@pytest.fixture(scope="module")
def artist_project(tmp_path_factory) -> Path:
    """The demo project upgraded: its meshes stand for an artist's (JSON skeleton, images folder)."""
    import shutil

    from spinemesh.demo import make_demo_project

    tmp = tmp_path_factory.mktemp("artist")
    make_demo_project(tmp / "p")
    r = run_cli("upgrade", "p", "--out", "o", "--jobs", "1", cwd=tmp)
    assert r.returncode == 0, r.stdout + r.stderr
    (tmp / "o" / "demo-binary.skel").unlink()
    if not (tmp / "o" / "images").is_dir():
        shutil.copytree(tmp / "p" / "images", tmp / "o" / "images")
    return tmp / "o"


def _artist_variant(artist_project: Path, tmp: Path, change) -> None:
    import shutil

    shutil.copytree(artist_project, tmp / "a")
    doc = json.loads((tmp / "a" / "demo.json").read_text())
    change(doc["skins"][0]["attachments"])
    (tmp / "a" / "demo.json").write_text(json.dumps(doc))


@pytest.mark.parametrize("field, value, reason", [
    ("hull", 1000, "mesh attachment hull 1000 is not a count of its {n} vertices"),
    ("hull", -3, "mesh attachment hull -3 is not a count of its {n} vertices"),
    ("edges", [0, 2, 4], "mesh attachment edges are not pairs of its {n} vertices (each index times 2)"),
    ("triangles", [], "mesh attachment has no triangles"),
])
def test_diff_skips_an_artist_mesh_whose_hull_or_edges_are_no_counts(tmp_path, artist_project, field, value,
                                                                    reason):
    """An artist mesh whose ``hull`` is more than its vertices (or below 0) was measured and
    reported with -980 interior vertices (or more than it has), exit 0; one of an odd count of
    ``edges`` was skipped with numpy's words ("cannot reshape array of size 3"), one of no
    triangles as one whose "triangles do not index its uvs". Each is a
    skipped row now, its reason naming the field; the other meshes are compared as before."""
    _artist_variant(artist_project, tmp_path, lambda atts: atts["body"]["demo-body"].update({field: value}))
    before = snapshot(tmp_path)
    r = run_cli("diff", "a", "--out", "r", "--methods", "default", cwd=tmp_path)
    check_run(r, before, tmp_path, ["r/"], codes=(0,))
    report = json.loads((tmp_path / "r" / "report.json").read_text())
    n = len(json.loads((artist_project / "demo.json").read_text())["skins"][0]["attachments"]["body"]["demo-body"]
            ["uvs"]) // 2
    assert [(s["attachment"], s["reason"]) for s in report["skipped"]] == [("demo-body", reason.format(n=n))]
    assert len(report["rows"]) == 4
    for row in report["rows"]:
        artist = row["metrics"]["artist"]
        assert 0 <= artist["interior"] <= artist["vertices"], row


def test_diff_measures_weighted_meshes_uvs_past_the_image_and_a_hull_of_0(tmp_path, artist_project):
    """Passed as it was: a weighted artist mesh is measured by its uvs as the unweighted one;
    uvs outside 0..1 (the runtime samples past the region) and a hull of 0 are measured, not
    refused."""
    def change(atts):
        body, head, ring = atts["body"]["demo-body"], atts["head"]["demo-head"], atts["ring"]["demo-ring"]
        v = body["vertices"]
        body["vertices"] = [x for i in range(0, len(v), 2) for x in (1, 0, v[i], v[i + 1], 1)]
        head["uvs"] = [u * 3 - 1 for u in head["uvs"]]
        ring["hull"] = 0

    _artist_variant(artist_project, tmp_path, change)
    r = run_cli("diff", "a", "--out", "r", "--methods", "default", cwd=tmp_path)
    assert r.returncode == 0, r.stdout + r.stderr
    report = json.loads((tmp_path / "r" / "report.json").read_text())
    assert report["skipped"] == [] and len(report["rows"]) == 5
    rows = {row["attachment"]: row["metrics"]["artist"] for row in report["rows"]}
    assert rows["demo-body"]["vertices"] > 3 and rows["demo-ring"]["interior"] == rows["demo-ring"]["vertices"]


# --- mesh: images of odd kinds (passed as they were) ------------------------------------------------

def test_an_exif_turned_jpeg_is_meshed_as_stored(tmp_path):
    """A JPEG whose EXIF orientation is 6 (turn 90 degrees to show it) is meshed as its pixels are
    stored, 60x40 here: the editor's image loader (libGDX's, stb_image) and the runtimes' read it so
    and place the attachment by that size; only browsers and photo viewers turn it."""
    from PIL import Image

    rgb = np.full((40, 60, 3), 30, np.uint8)
    rgb[5:35, 10:30] = 200
    exif = Image.Exif()
    exif[0x0112] = 6
    Image.fromarray(rgb).save(tmp_path / "turned.jpg", exif=exif.tobytes())
    r = run_cli("mesh", "turned.jpg", "--out", "m.json", cwd=tmp_path)
    assert r.returncode == 0, r.stdout + r.stderr
    doc = json.loads((tmp_path / "m.json").read_text())
    assert (doc["width"], doc["height"]) == (60, 40)


def test_an_animated_png_is_meshed_by_its_first_frame(tmp_path):
    """An APNG is meshed by its default image (the first frame), which every PNG reader that
    knows no animation (the editor's, the runtimes') shows."""
    from PIL import Image

    first = np.zeros((40, 60, 4), np.uint8)
    first[5:35, 10:30] = 255
    Image.fromarray(first).save(tmp_path / "anim.png", save_all=True, duration=100,
                                append_images=[Image.fromarray(np.full((40, 60, 4), 255, np.uint8))])
    r = run_cli("mesh", "anim.png", "--out", "m.json", cwd=tmp_path)
    assert r.returncode == 0, r.stdout + r.stderr
    xs, ys = np.array(json.loads((tmp_path / "m.json").read_text())["vertices"]).T
    assert xs.min() >= 9 and xs.max() <= 31 and ys.min() >= 4 and ys.max() <= 36  # the first frame's square


def _odd_images(tmp: Path) -> dict[str, str]:
    """Images ``mesh`` refuses, each with what its one line says."""
    import os
    import struct
    import zlib

    from PIL import Image

    a = np.zeros((8, 8, 4), np.uint8)
    Image.fromarray(a).save(tmp / "anim.gif", save_all=True, append_images=[Image.fromarray(a)])
    Image.fromarray(a).save(tmp / "pages.tiff", save_all=True, append_images=[Image.fromarray(a)])
    Image.fromarray(np.zeros((8, 8), np.float32)).save(tmp / "float.tiff")
    (tmp / "empty.png").write_bytes(b"")
    Image.fromarray(np.full((65535, 1, 4), 255, np.uint8)).save(tmp / "tall.png")

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))

    (tmp / "bomb.png").write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", 100000, 100000, 8, 6, 0, 0, 0))
                                   + chunk(b"IDAT", zlib.compress(b"\0" * 1000)) + chunk(b"IEND", b""))
    os.symlink("/dev/zero", tmp / "zero.png")
    os.mkfifo(tmp / "fifo.png")
    decode = "cannot decode image: not a PNG, WebP, AVIF or JPEG file"
    return {"anim.gif": decode, "pages.tiff": decode, "float.tiff": decode, "empty.png": decode,
            "tall.png": "image 1x65535 exceeds the limit of 16384 pixels a side",
            "bomb.png": "image 100000x100000 exceeds the limit of 16384 pixels a side and 89,478,485 pixels",
            "zero.png": "image is a device, not a regular file", "fifo.png": "image is a FIFO, not a regular file"}


def test_images_mesh_cannot_read_are_one_line_each(tmp_path):
    """A GIF or TIFF (animated, of pages, of floats: formats the editor's exports do not use), a
    file of 0 bytes, an image of 1x65535, a PNG whose header claims 100000x100000 (a
    decompression bomb: refused before a texel is decoded), a link to /dev/zero and a FIFO: one
    line each, exit 2, nothing written; a 1x1 image is meshed."""
    from PIL import Image

    said = _odd_images(tmp_path)
    Image.fromarray(np.full((1, 1, 4), 255, np.uint8)).save(tmp_path / "dot.png")
    before = snapshot(tmp_path)
    for name, line in said.items():
        r = run_cli("mesh", name, "--out", "m.json", cwd=tmp_path, timeout=30)
        check_run(r, before, tmp_path, [], codes=(2,))
        assert f"error: {name}: {line}" in r.stderr and len(r.stderr.strip().splitlines()) == 1, (name, r.stderr)
    r = run_cli("mesh", "dot.png", "--out", "m.json", cwd=tmp_path)
    assert r.returncode == 0 and json.loads((tmp_path / "m.json").read_text())["width"] == 1, r.stderr


def test_convert_keeps_u0000_and_refuses_a_lone_surrogate(tmp_path):
    """Passed as they were: names and event strings holding U+0000 are written to a ``.skel``
    and read back the same; a JSON ``"\\ud800"`` (no UTF-8 file can hold it) is one line."""
    skeleton = json_demo(tmp_path) / "demo.json"
    doc = json.loads(skeleton.read_text())
    doc["events"] = {"h\u0000it": {"string": "a\u0000b"}}
    skeleton.write_text(json.dumps(doc))
    for args in (("p/demo.json", "out.skel"), ("out.skel", "back.json")):
        r = run_cli("convert", *args, cwd=tmp_path)
        assert r.returncode == 0, r.stdout + r.stderr
    assert json.loads((tmp_path / "back.json").read_text())["events"] == {"h\u0000it": {"string": "a\u0000b"}}
    skeleton.write_text(skeleton.read_text().replace('"a\\u0000b"', '"a\\ud800b"'))
    before = snapshot(tmp_path)
    r = run_cli("convert", "p/demo.json", "lone.skel", cwd=tmp_path)
    check_run(r, before, tmp_path, [], codes=(2,))
    assert "demo.json: JSON holds an escaped lone UTF-16 surrogate" in r.stderr, r.stderr


@pytest.mark.parametrize("data", [b"\x80\x02.", b"\x80\xb3.", b"\x80\x02)R."], ids=["empty stack", "protocol 179",
                                                                                   "call of nothing"])
def test_a_checkpoint_of_no_pickle_is_one_line(tmp_path, data):
    """Bytes torch's weights-only reader stops on in its own stack (a file of another kind, a
    pickle cut or corrupted) ended ``segment-export`` in an IndexError traceback ("pop from empty
    list"), with torch's warning of an unknown pickle protocol before it. One line now, naming the
    checkpoint."""
    (tmp_path / "best.pt").write_bytes(data)
    (tmp_path / "ds").mkdir()
    before = snapshot(tmp_path)
    r = run_cli("segment-export", "best.pt", "--data", "ds", "--out", "m.onnx", cwd=tmp_path)
    check_run(r, before, tmp_path, [], codes=(2,))
    assert "best.pt: not a checkpoint spinemesh can read (" in r.stderr, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1, r.stderr


def test_output_paths_and_project_names_of_markup_are_printed_as_they_are(tmp_path, artist_project):
    """``segment --out 'q[/]m.png'`` (a folder ``q[`` holding ``]m.png``), ``diff --out 'q[/]r'``
    and ``dataset`` of a project at ``p[/]hero`` into ``q[/]d`` wrote their files, then printed
    the path or the project's name as rich markup: a MarkupError traceback, exit 1, after the
    work. Each prints it as it is now, exit 0."""
    import shutil

    (tmp_path / "q[").mkdir()
    _sprite(tmp_path / "art.png")
    r = run_cli("segment", "art.png", "--mask", "alpha", "--out", "q[/]m.png", cwd=tmp_path)
    assert r.returncode == 0 and "q[/]m.png: 30x20 mask from alpha" in r.stdout, r.stdout + r.stderr
    r = run_cli("diff", str(artist_project), "--out", "q[/]r", "--methods", "default", "--limit", "1", cwd=tmp_path)
    assert r.returncode == 0 and "wrote q[/]r/report.md" in r.stdout, r.stdout + r.stderr
    (tmp_path / "games" / "p[").mkdir(parents=True)
    shutil.copytree(artist_project, tmp_path / "games" / "p[" / "]hero")
    r = run_cli("dataset", "games", "--out", "q[/]d", "--jobs", "1", cwd=tmp_path)
    assert r.returncode == 0 and "samples in q[/]d" in r.stdout and "games/p[/]hero" in r.stdout, r.stdout + r.stderr
    r = run_cli("dataset-stats", "q[/]d", "--plots", "q[/]plots", cwd=tmp_path)
    assert r.returncode == 0 and "q[/]d: " in r.stdout, r.stdout + r.stderr


# --- data sets: what an index row says ------------------------------------------------------------

@pytest.fixture(scope="module")
def built_dataset(artist_project, tmp_path_factory) -> Path:
    """A data set of the artist project, made by ``spinemesh dataset``."""
    import shutil

    tmp = tmp_path_factory.mktemp("dataset")
    (tmp / "games").mkdir()
    shutil.copytree(artist_project, tmp / "games" / "hero")
    r = run_cli("dataset", "games", "--out", "ds", "--jobs", "1", cwd=tmp)
    assert r.returncode == 0, r.stdout + r.stderr
    return tmp / "ds"


@pytest.mark.parametrize("change, said", [
    ({"shard": "/etc/passwd"}, "index.jsonl: absolute path '/etc/passwd' is not allowed"),
    ({"shard": "../../../../etc/hostname"}, "index.jsonl: path '../../../../etc/hostname' leads outside the data set"),
    ({"image": [0, 10 ** 12]}, "index.jsonl:1: index row of another form: image is [0, 1000000000000], not [offset, "),
    ({"image": [-5, 10]}, "index.jsonl:1: index row of another form: image is [-5, 10], not [offset, size]"),
    ({"width": 100000, "height": 100000}, "index.jsonl:1: sample 'x' 100000x100000 exceeds the limit"),
    ({"shard": None}, "index.jsonl:1: index row of another form: shard is None, not text"),
    ({"box": [0, 0, 100000, 5]}, "index.jsonl:1: index row of another form: box is [0, 0, 100000, 5], not [x, y, w, h]"),
    ({"width": "wide"}, "index.jsonl:1: index row of another form: width and height are 'wide' and "),
], ids=["absolute shard", "shard outside", "size 1e12", "offset -5", "100000 px", "no shard", "box outside",
        "width text"])
def test_a_data_set_row_is_bounded_and_kept_inside_before_it_is_read(tmp_path, built_dataset, change, said):
    """A data set's index names a shard and byte spans in it for each sample. A row naming
    ``/etc/passwd`` or ``../../etc/hostname`` was read there (``train --write-pack``,
    ``segment-eval``, ``segment-export``); a size of 1e12 or an image of 100000x100000 was "not
    enough memory"; an offset of -5 "Invalid argument"; a field missing, of text or a box
    outside its image a KeyError, TypeError or ValueError traceback. Each is one line naming the
    index (and its line) now, before the row is read."""
    import shutil

    shutil.copytree(built_dataset, tmp_path / "ds")
    index = tmp_path / "ds" / "index.jsonl"
    rows = [json.loads(line) for line in index.read_text().splitlines()]
    rows[0].update(id="x", **change)
    index.write_text("".join(json.dumps(row) + "\n" for row in rows))
    before = snapshot(tmp_path)
    r = run_cli("train", "--data", "ds", "--write-pack", "pack.npz", cwd=tmp_path)
    check_run(r, before, tmp_path, [], codes=(2,))
    assert f"error: ds/{said}" in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr


def test_a_sprite_pack_of_another_form_is_one_line(tmp_path, built_dataset):
    """``train --data PACK`` reads a sprite pack ``--write-pack`` wrote. A pack cut short, of a
    field missing or of objects, of offsets short or out of order, or a side other than train and
    val was a BadZipFile, KeyError, ValueError or IndexError traceback; junk bytes for a sprite
    said "cannot decode image" naming no file. Each is one line naming the pack now."""
    from spinemesh.errors import SpineMeshError
    from spinemesh.train.data import read_pack

    r = run_cli("train", "--data", str(built_dataset), "--write-pack", "pack.npz", cwd=tmp_path)
    assert r.returncode == 0, r.stdout + r.stderr
    good = dict(np.load(tmp_path / "pack.npz"))
    n = len(good["ids"])
    good["splits"] = np.array(["train", "val"] * (n // 2) + ["train"] * (n % 2))
    cases = {
        "no blob": ({"blob": None}, "'blob is not a file in the archive'"),
        "side test": ({"splits": np.array(["train"] * (n - 1) + ["test"])}, "a sprite's side is 'test'"),
        "offsets reversed": ({"offsets": good["offsets"][::-1].copy()}, "its offsets do not cut its bytes in order"),
        "offsets short": ({"offsets": good["offsets"][:3]}, f"{n} ids, {n} games, {n} sides and 3 offsets"),
        "objects": ({"ids": np.array([object()] * n, dtype=object)}, "Object arrays cannot be loaded"),
        "junk bytes": ({"blob": np.zeros_like(good["blob"])}, "a sprite of the pack cannot be read (cannot decode"),
    }
    assert len(read_pack(_pack(tmp_path / "good.npz", good, {}))["val"]) == n // 2
    for name, (change, said) in cases.items():
        with pytest.raises(SpineMeshError) as e:
            read_pack(_pack(tmp_path / f"{name}.npz", good, change))
        assert str(e.value).startswith(f"{tmp_path / name}.npz: ") and said in str(e.value), (name, str(e.value))
    (tmp_path / "cut.npz").write_bytes((tmp_path / "good.npz").read_bytes()[:500])
    before = snapshot(tmp_path)
    r = run_cli("train", "--data", "cut.npz", "--out", "run", "--epochs", "1", "--size", "64", cwd=tmp_path)
    check_run(r, before, tmp_path, [], codes=(2,))
    assert "error: cut.npz: not a sprite pack of `spinemesh train --write-pack`: File is not a zip file" in r.stderr


def _pack(path: Path, fields: dict, change: dict) -> Path:
    np.savez(path, **{k: v for k, v in {**fields, **change}.items() if v is not None})
    return path


@pytest.mark.parametrize("case", ["card FIFO", "card /dev/zero", "model FIFO"])
def test_a_model_or_card_that_is_no_file_is_one_line(tmp_path, case):
    """``segment --model m.onnx`` read the card ``m.json`` whatever it was: a FIFO waited for
    ever, a link to /dev/zero read until the memory ran out; a model that is a FIFO was "not
    found". Each is one line saying what the file is now."""
    import os
    import shutil

    models = Path(__file__).parents[1] / "spinemesh" / "models"
    if case == "model FIFO":
        os.mkfifo(tmp_path / "m.onnx")
        shutil.copy(models / "segment.json", tmp_path / "m.json")
        said = "m.onnx: segmentation model is a FIFO, not a regular file"
    else:
        shutil.copy(models / "segment.onnx", tmp_path / "m.onnx")
        if case == "card FIFO":
            os.mkfifo(tmp_path / "m.json")
        else:
            os.symlink("/dev/zero", tmp_path / "m.json")
        said = f"m.json: model card is a {'FIFO' if case == 'card FIFO' else 'device'}, not a regular file"
    _sprite(tmp_path / "art.png")
    before = snapshot(tmp_path)
    r = run_cli("segment", "art.png", "--model", "m.onnx", "--mask", "model", "--out", "mask.png", cwd=tmp_path,
                timeout=20)
    check_run(r, before, tmp_path, [], codes=(2,))
    assert f"error: {said}" in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr


@pytest.mark.parametrize("command", ["segment-export", "train"])
def test_a_checkpoint_or_pack_that_is_a_fifo_is_one_line(tmp_path, command):
    """``segment-export best.pt`` and ``train --data PACK`` of a FIFO waited for ever (torch and
    numpy read it whole); one line says what the file is now."""
    import os

    (tmp_path / "ds").mkdir()
    if command == "train":
        os.mkfifo(tmp_path / "pack.npz")
        args, said = ("train", "--data", "pack.npz", "--out", "run"), "pack.npz: sprite pack is a FIFO"
    else:
        os.mkfifo(tmp_path / "best.pt")
        args, said = ("segment-export", "best.pt", "--data", "ds", "--out", "m.onnx"), "best.pt: checkpoint is a FIFO"
    before = snapshot(tmp_path)
    r = run_cli(*args, cwd=tmp_path, timeout=30)
    check_run(r, before, tmp_path, [], codes=(2,))
    assert f"error: {said}, not a regular file" in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr


@pytest.mark.parametrize("case", ["FIFO", "missing"])
def test_a_shard_that_is_a_fifo_or_missing_is_one_line(tmp_path, built_dataset, case):
    """A data set's shard replaced by a FIFO waited for ever (``train --write-pack``); a missing
    one said "No such file or directory" alone. One line naming the shard now."""
    import os
    import shutil

    shutil.copytree(built_dataset, tmp_path / "ds")
    shard = min((tmp_path / "ds" / "shards").iterdir())
    shard.unlink()
    if case == "FIFO":
        os.mkfifo(shard)
    before = snapshot(tmp_path)
    r = run_cli("train", "--data", "ds", "--write-pack", "pack.npz", cwd=tmp_path, timeout=30)
    check_run(r, before, tmp_path, [], codes=(2,))
    said = "shard is a FIFO, not a regular file" if case == "FIFO" else "shard not found (sample "
    assert f"shards/{shard.name}: {said}" in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr


def test_a_project_named_in_bytes_not_utf8_is_compared_and_gathered(tmp_path, artist_project):
    """A project folder named in bytes that are not UTF-8 (``bad\\xff``): ``diff`` computed every
    mesh, then refused its own report.md ("text holds an invalid character"), exit 2, its assets
    half written; ``dataset`` ended in a UnicodeEncodeError traceback. Both write their files now,
    naming the project with U+FFFD for each such byte."""
    import os
    import shutil

    name = os.fsdecode(b"bad\xff")
    shutil.copytree(artist_project, tmp_path / "games" / name)
    r = run_cli("diff", f"games/{name}", "--out", "r", "--methods", "default", "--limit", "1", cwd=tmp_path)
    assert r.returncode == 0, r.stdout + r.stderr
    assert json.loads((tmp_path / "r" / "report.json").read_text())["rows"][0]["project"] == "bad\ufffd"
    r = run_cli("dataset", "games", "--out", "ds", "--jobs", "1", cwd=tmp_path)
    assert r.returncode == 0 and "Traceback" not in r.stderr, r.stdout + r.stderr
    projects = [json.loads(line) for line in (tmp_path / "ds" / "projects.jsonl").read_text("utf-8").splitlines()]
    assert [(p["project"], p["game"]) for p in projects] == [("games/bad\ufffd", "bad\ufffd")]


def test_an_image_with_nothing_to_mesh_is_named(tmp_path):
    """An image of no opaque pixel said "skipped: the image has no opaque pixel ...: nothing to
    mesh" in ``mesh FOLDER``, naming no image (the folder's others were meshed: which one was
    left?); ``mesh IMAGE`` likewise. Both lines name the image now."""
    from PIL import Image

    _sprite(tmp_path / "art" / "drawn.png")
    Image.fromarray(np.zeros((20, 20, 4), np.uint8)).save(tmp_path / "art" / "clear.png")
    r = run_cli("mesh", "art", "--out", "meshes", cwd=tmp_path)
    assert r.returncode == 3, r.stdout + r.stderr
    assert "skipped: art/clear.png: the image has no opaque pixel (alpha >= 8): nothing to mesh" in r.stderr, r.stderr
    r = run_cli("mesh", "art/clear.png", "--out", "m.json", cwd=tmp_path)
    assert r.returncode == 2 and "error: art/clear.png: the image has no opaque pixel" in r.stderr, r.stderr
