"""Hostile input, seventh round: what a page file or an atlas page says besides its texels
(frames, EXIF orientation, wrap, text, filters, premultiplied alpha), atlas text as odd editors
save it, and the 4.3 constraints and sliders added after round six.

As in rounds five and six (tests/test_hostile_wave4.py, tests/test_hostile_round6.py), every
project and skeleton is made here by our own code; each case checks what docs/safety.md promises:
a page is written only when it draws as the original, else its atlas is kept byte for byte; no
traceback, one line naming the file, nothing non-finite written, bounded time.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from test_hostile_wave4 import _same_texels_drawn
from test_skeleton_binary_v43 import runtime43  # noqa: F401  (fixture)

from spinemesh.pack.run import PackOptions, pack_project


# --- pack: what a page file says besides its texels ---------------------------------------------

def _demo_texels(project: Path):
    from PIL import Image

    with Image.open(project / "demo.png") as im:
        return im.convert("RGBA")


def _exif(orientation: int) -> bytes:
    from PIL import Image

    exif = Image.Exif()
    exif[0x0112] = orientation
    return exif.tobytes()


def _apng(project: Path, im, default_apart: bool) -> None:
    from PIL import Image

    red = Image.new("RGBA", im.size, (255, 0, 0, 255))
    extra = {"default_image": True} if default_apart else {}
    im.save(project / "demo.png", save_all=True, append_images=[red, im] if default_apart else [red],
            duration=100, **extra)


def _webp(project: Path, im, **options) -> None:
    (project / "demo.png").unlink()
    atlas = project / "demo.atlas"
    atlas.write_text(atlas.read_text().replace("demo.png", "demo.webp"))
    im.save(project / "demo.webp", lossless=True, exact=True, **options)


def _animated_webp(project: Path, im) -> None:
    from PIL import Image

    _webp(project, im, save_all=True, append_images=[Image.new("RGBA", im.size, (255, 0, 0, 255))], duration=100)


#: The file identifier every KTX 2 texture starts with.
KTX2_HEAD = b"\xabKTX 20\xbb\r\n\x1a\n"


def _renamed_page(project: Path, name: str, write) -> None:
    (project / "demo.png").unlink()
    atlas = project / "demo.atlas"
    atlas.write_text(atlas.read_text().replace("demo.png", name))
    write(project / name)


def _atlas_bytes(edit):
    def change(project: Path, im) -> None:
        atlas = project / "demo.atlas"
        atlas.write_bytes(edit(atlas.read_bytes()))
    return change


def _field(line: str):
    def edit(project: Path, im) -> None:
        atlas = project / "demo.atlas"
        atlas.write_text(atlas.read_text().replace("filter: Linear, Linear", line, 1))
    return edit


#: Pages a packed page would silently draw otherwise than: (how the project is made, words the
#: reason must hold). Each once came out packed (exit 0): a still page of the first frame, the
#: orientation gone, a repeating page shared with other regions.
KEPT_PAGES = {
    "an APNG page": (lambda p, im: _apng(p, im, False), "animated (2 frames)"),
    "an APNG whose default image is not a frame": (lambda p, im: _apng(p, im, True), "animated (3 frames)"),
    "an animated WebP page": (_animated_webp, "animated (2 frames)"),
    "a PNG page turned by EXIF": (lambda p, im: im.save(p / "demo.png", exif=_exif(6)), "EXIF orientation 6"),
    "a PNG page mirrored by EXIF": (lambda p, im: im.save(p / "demo.png", exif=_exif(2)), "EXIF orientation 2"),
    "a WebP page turned by EXIF": (lambda p, im: _webp(p, im, exif=_exif(8)), "EXIF orientation 8"),
    "a page that repeats on x and y": (_field("filter: Linear, Linear\n\trepeat: xy"), "repeats (xy)"),
    "a page that repeats on x": (_field("filter: Linear, Linear\n\trepeat: x"), "repeats (x)"),
    # passed as they were: formats spinemesh cannot write are kept, never rewritten under their name
    "a BMP page": (lambda p, im: _renamed_page(p, "demo.bmp", lambda f: im.save(f, "BMP")), "is not PNG, WebP"),
    "a KTX2 page": (lambda p, im: _renamed_page(p, "demo.ktx2", lambda f: f.write_bytes(KTX2_HEAD + bytes(64))),
                    "is not PNG, WebP"),
}


@pytest.mark.parametrize("case", sorted(KEPT_PAGES))
def test_a_page_runtimes_draw_otherwise_than_its_texels_keeps_its_atlas(meshed, tmp_path, case):
    make, words = KEPT_PAGES[case]
    project = tmp_path / "p"
    shutil.copytree(meshed, project, ignore=shutil.ignore_patterns(".*"))
    make(project, _demo_texels(meshed))
    before = {p.name: p.read_bytes() for p in project.iterdir()}
    result = pack_project(project, tmp_path / "out", PackOptions(larger_files=True))
    (row,) = result.atlases
    assert row.status == "kept" and words in row.reason and "'demo." in row.reason, row.reason
    for name, data in before.items():  # the atlas and its page byte for byte (never re-encoded)
        assert (tmp_path / "out" / name).read_bytes() == data, name
        assert (project / name).read_bytes() == data, name


#: Pages whose extras say nothing a runtime draws by, or that pack already handles: packed, every
#: texel drawn the original's (the proof's own claim, checked here by hand, through Pillow).
PACKED_PAGES = {
    "text chunks": lambda p, im: im.save(p / "demo.png", pnginfo=_text_chunks()),
    "EXIF orientation 1": lambda p, im: im.save(p / "demo.png", exif=_exif(1)),
    "an APNG of one frame": lambda p, im: im.save(p / "demo.png", save_all=True, append_images=[]),
    "a MipMap filter": _field("filter: MipMapLinearLinear, Linear"),
    "repeat: none": _field("filter: Linear, Linear\n\trepeat: none"),
    "a still WebP with EXIF orientation 1": lambda p, im: _webp(p, im, exif=_exif(1)),
    "an atlas of CRLF lines": _atlas_bytes(lambda b: b.replace(b"\n", b"\r\n")),
    "an atlas with a byte-order mark": _atlas_bytes(lambda b: b"\xef\xbb\xbf" + b),
}


def _text_chunks():
    from PIL.PngImagePlugin import PngInfo

    info = PngInfo()
    info.add_text("Software", "hand")
    info.add_itxt("Comment", "é", zip=True)
    return info


@pytest.mark.parametrize("case", sorted(PACKED_PAGES))
def test_pages_whose_extras_draw_nothing_pack_to_the_same_texels(meshed, tmp_path, case):
    project = tmp_path / "p"
    shutil.copytree(meshed, project, ignore=shutil.ignore_patterns(".*"))
    PACKED_PAGES[case](project, _demo_texels(meshed))
    result = pack_project(project, tmp_path / "out", PackOptions(larger_files=True))
    (row,) = result.atlases
    assert row.status == "packed", row.reason
    assert _same_texels_drawn(project, tmp_path / "out") > 20_000


def test_a_page_that_is_no_image_names_its_file_not_a_stream(meshed, tmp_path):
    """A TGA (or anything Pillow cannot name) saved as ``demo.png``: the atlas failed with
    Pillow's words, ``cannot identify image file <_io.BytesIO object at 0x7f...>`` (a memory
    address, not the file); now it says what the file is not."""
    project = tmp_path / "p"
    shutil.copytree(meshed, project, ignore=shutil.ignore_patterns(".*"))
    _demo_texels(meshed).save(project / "demo.png", "TGA")
    result = pack_project(project, tmp_path / "out")
    (row,) = result.atlases
    assert row.status == "failed" and "0x" not in row.reason and "BytesIO" not in row.reason, row.reason
    assert "demo.png: cannot decode image: not a PNG, WebP, AVIF or JPEG file" in row.reason, row.reason
    assert (tmp_path / "out" / "demo.png").read_bytes() == (project / "demo.png").read_bytes()


# --- the preview: memory refused while one skeleton's animations are sampled ---------------------

def _library(tmp_path: Path) -> Path:
    """Two copies of the demo project, one whose skeleton has the animations "doomed" and "late"."""
    import json

    from spinemesh.demo import make_demo_project

    for name in ("a", "b"):
        demo = make_demo_project(tmp_path / "lib" / name)
        (demo / "demo-binary.skel").unlink()
        if name == "a":
            doc = json.loads((demo / "demo.json").read_text())
            turn = {"bones": {"arm": {"rotate": [{"value": 0}, {"time": 2, "value": 90}]}}}
            doc["animations"] |= {"doomed": turn, "late": turn}
            (demo / "demo.json").write_text(json.dumps(doc))
    return tmp_path / "lib"


def _no_memory_for_doomed(real):
    def sample(sides, sampling, names):
        if "doomed" in names:
            raise MemoryError
        return real(sides, sampling, names)
    return sample


@pytest.mark.parametrize("jobs", [1, 2])
def test_memory_refused_while_the_preview_samples_costs_those_animations_only(tmp_path, monkeypatch, jobs):
    """A MemoryError while one skeleton's animations were sampled (in this process, or on a worker,
    where the task hands it back) ended the whole preview; now with ``--jobs 2`` those
    animations alone are left out, in one line on the page, and with one process that skeleton's
    player (the process samples a skeleton's animations together); every other page is written
    and plays."""
    import re

    from test_hostile_wave4 import within

    from spinemesh.player import frames
    from spinemesh.upgrade import Options, preview, upgrade_library
    from spinemesh.upgrade.preview import write_preview

    lib = _library(tmp_path)
    result = upgrade_library(lib, tmp_path / "out", Options(jobs=1))
    monkeypatch.setattr(preview, "CHUNK_SECONDS", 0.0)  # a worker's task per animation
    monkeypatch.setattr(frames, "sample_and_encode", _no_memory_for_doomed(frames.sample_and_encode))
    with within(120):
        index = write_preview(result, lib, tmp_path / "out", tmp_path / "v", jobs=jobs)
    pages = {p: p.read_text(encoding="utf-8") for p in index.parent.glob("s/*.html")}
    assert len(pages) == 2
    lines = [x for text in pages.values() for x in re.findall(r"<li>([^<]*)</li>", text)]
    (line,) = [x for x in lines if "memory" in x]
    assert "not enough memory to sample its poses" in line, line
    models = [m.read_text(encoding="utf-8") for m in index.parent.glob("data/*/model.js")]
    played = sorted(re.findall(r'"name":"([^"]+)","dur"', m) for m in models)
    if jobs == 1:
        assert "the player could not pose this skeleton" in line
        assert played == [["setup pose", "wave"]]  # the other skeleton's player
    else:  # the animations sampled with "doomed" in one task are left out with it, no others
        assert "doomed" in line and "not shown" in line, line
        assert ["setup pose", "wave"] in played, played  # the other skeleton's, whole
        assert any("late" in m and "doomed" not in m for m in played), played


# --- 4.3 transforms and sliders in cycles, in crowds, through the binary ---------------------------

def _sliders_in_a_cycle(doc):
    """Slider "timed" plays "a", which keys the time of slider "by_x", which plays "b", which keys
    "timed": each drives the other's animation."""
    doc["animations"]["a"] = {"slider": {"by_x": {"time": [{"value": 0}, {"time": 1, "value": 3}]}},
                              "bones": {"knob": {"translate": [{"x": 0}, {"time": 1, "x": 40}]}}}
    doc["animations"]["b"] = {"slider": {"timed": {"time": [{"value": 0}, {"time": 1, "value": 3}],
                                                   "mix": [{"value": 1}]}}}
    doc["constraints"][0]["animation"], doc["constraints"][1]["animation"] = "a", "b"


def _crowd_of_transforms(doc):
    """3,000 transforms criss-crossing a chain of 200 bones (real skeletons have tens)."""
    doc["bones"] += [{"name": f"b{i}", "parent": "root" if i == 0 else f"b{i - 1}", "x": 1, "length": 1}
                     for i in range(200)]
    doc["constraints"] += [{"type": "transform", "name": f"t{i}", "source": f"b{i * 7 % 200}",
                            "bones": [f"b{(i * 13 + 1) % 200}"], "mixRotate": 1, "mixX": 1,
                            "properties": {"rotate": {"to": {"rotate": {"scale": 1.5}}}, "x": {"to": {"x": {}}}}}
                           for i in range(3000)]


def _crowd_of_sliders(doc):
    doc["constraints"] += [{"type": "slider", "name": f"s{i}", "animation": "wave", "bone": "knob",
                            "property": "x", "scale": 0.01, "loop": True} for i in range(3000)]


def _with(constraint: int, **fields):
    def change(doc):
        doc["constraints"][constraint].update(fields)
    return change


#: 4.3 documents round six did not try: (document, change). Each poses finite within its bound,
#: and our binary writer's file reads back to a document that poses the same.
CYCLES_AND_CROWDS = {
    "two sliders driving each other's animations": ("slider", _sliders_in_a_cycle),
    "3,000 sliders on one bone": ("slider", _crowd_of_sliders),
    "sliders of scale, range and mix 1e9": ("slider", lambda d: [c.update(scale=1e9, mix=1e9, to=1e9)
                                                                for c in d["constraints"]]),
    "a transform onto its source's ancestor": ("transform", _with(0, bones=["root"])),
    "a transform whose source lies below its target": ("transform", _with(0, source="lid", bones=["face"])),
    "transform offsets, mixes and mapping factors of 1e9": ("transform", lambda d: d["constraints"][0].update(
        x=1e9, rotation=1e9, mixRotate=1e9, properties={"rotate": {"to": {"rotate": {"scale": 1e9, "offset": 1e9,
                                                                                       "max": 1e9}}}})),
    "3,000 transforms over 200 bones": ("transform", _crowd_of_transforms),
}


def _poses(doc: dict, path: Path) -> list:
    import json

    from spinemesh.anim import Sampler
    from spinemesh.anim.dump import dump
    from spinemesh.skeleton import load_skeleton

    sampler = Sampler(load_skeleton(path))
    return [json.loads(json.dumps(dump(sampler, name, [0.05, 0.5, 1.5, 3.3]), allow_nan=False))["poses"]
            for name in doc["animations"]]


@pytest.mark.parametrize("case", list(CYCLES_AND_CROWDS))
def test_43_cycles_and_crowds_pose_finite_and_survive_the_binary(tmp_path, case):
    import json

    from test_anim43 import slider_doc, transform_doc
    from test_hostile_wave4 import within

    from spinemesh.skeleton_binary import encode_skel

    kind, change = CYCLES_AND_CROWDS[case]
    doc = slider_doc() if kind == "slider" else transform_doc()
    change(doc)
    (tmp_path / "x.json").write_text(json.dumps(doc))
    with within(60):
        poses = _poses(doc, tmp_path / "x.json")
        (tmp_path / "x.skel").write_bytes(encode_skel(doc))
        again = _poses(doc, tmp_path / "x.skel")
    assert np.allclose(_numbers(poses), _numbers(again), rtol=1e-4, atol=1e-2, equal_nan=True)


def _numbers(poses) -> np.ndarray:
    """Every bone's world numbers of every pose (None, a bone flagged, as NaN: flagged alike)."""
    return np.array([v if v is not None else np.nan for anim in poses for pose in anim
                     for world in pose["bones"].values() for v in (world or [None] * 6)], float)


def test_convert_names_a_number_beyond_a_float32_as_such(tmp_path):
    """A 4.3 slider's mix of 1e308 (the document's check lets it through; the sampler clamps it)
    cannot be stored in a binary skeleton's 32-bit floats: ``convert`` once said "expected a
    number for mix, got 1e+308", of a number; it says what the binary cannot hold."""
    import json
    import subprocess
    import sys

    from test_anim43 import slider_doc

    doc = slider_doc()
    doc["constraints"][0]["mix"] = 1e308
    (tmp_path / "x.json").write_text(json.dumps(doc))
    r = subprocess.run([sys.executable, "-m", "spinemesh", "convert", "x.json", "x.skel"], cwd=tmp_path,
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    (line,) = [x for x in r.stderr.splitlines() if x.startswith("error:")]
    assert "x.json" in line and "a number a 32-bit float holds" in line and "1e+308" in line, line
    assert not (tmp_path / "x.skel").exists()


# --- outputs that are inputs under another name ---------------------------------------------------

@pytest.mark.parametrize("target", ["p/demo.json", "p/demo.atlas", "p/demo.png"])
def test_pose_never_streams_into_an_input_through_a_hard_link(tmp_path, target):
    """``spinemesh pose p/hero.json >> elsewhere.json``, where elsewhere.json is a hard link to the
    skeleton (or to its atlas or page): the check compared paths, so the poses were appended to
    the skeleton itself (exit 0). A file written in place with several names is now looked for
    among the inputs and the project's files; an ``--out`` needs no such check (it is renamed
    into place, which breaks the link)."""
    import subprocess
    import sys

    from test_hostile import snapshot

    from spinemesh.demo import make_demo_project

    make_demo_project(tmp_path / "p")
    (tmp_path / "elsewhere").hardlink_to(tmp_path / target)
    before = snapshot(tmp_path / "p")
    with open(tmp_path / "elsewhere", "a", encoding="utf-8") as stdout:
        r = subprocess.run([sys.executable, "-m", "spinemesh", "pose", "p/demo.json", "-a", "wave", "--times", "0,0.5"],
                           cwd=tmp_path, stdout=stdout, stderr=subprocess.PIPE, text=True, timeout=60)
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    (line,) = [x for x in r.stderr.splitlines() if x.startswith("error:")]
    assert "standard output" in line and "hard link" in line and Path(target).name in line, line
    assert snapshot(tmp_path / "p") == before
    for out in ("--out", None):  # a link replaced by --out's rename, and a file of one name, are written
        (tmp_path / "elsewhere").unlink()
        (tmp_path / "elsewhere").hardlink_to(tmp_path / target)
        args = ["--out", "elsewhere"] if out else []
        with open(tmp_path / ("other" if out else "fresh.json"), "w", encoding="utf-8") as stdout:
            r = subprocess.run([sys.executable, "-m", "spinemesh", "pose", "p/demo.json", "-a", "wave", "--times",
                                "0,0.5", *args], cwd=tmp_path, stdout=stdout, stderr=subprocess.PIPE, text=True,
                               timeout=60)
        assert r.returncode == 0, r.stderr
        assert snapshot(tmp_path / "p") == before


def test_outputs_hard_linked_to_inputs_and_symlinked_projects_leave_the_inputs_alone(tmp_path, meshed):
    """An output folder spinemesh wrote, holding hard links to the project's own files, written
    again with ``--overwrite`` (``upgrade`` and ``pack``): every file is replaced by a rename, so
    the project keeps its bytes. A project named through a symlink is read as the project, and an
    output inside it, named through the link, is refused."""
    from test_hostile import check_run, run_cli, snapshot

    project = tmp_path / "p"
    shutil.copytree(meshed, project, ignore=shutil.ignore_patterns(".*"))
    (tmp_path / "link").symlink_to(project, target_is_directory=True)
    for command in ("upgrade", "pack"):
        out = tmp_path / f"o-{command}"
        out.mkdir()
        (out / ".spinemesh-output").write_bytes((meshed / ".spinemesh-output").read_bytes())
        for f in project.iterdir():
            (out / f.name).hardlink_to(f)
        before = {k: v for k, v in snapshot(tmp_path).items() if not k.startswith("o-")}
        r = run_cli(command, "p", "--out", out.name, "--overwrite", cwd=tmp_path)
        check_run(r, before, tmp_path, ["o-upgrade", "o-pack"], codes=(0,))
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "link", "--out", "o-link", cwd=tmp_path)
    check_run(r, before, tmp_path, ["o-link"], codes=(0,))
    for command in ("upgrade", "pack"):
        before = snapshot(tmp_path)
        r = run_cli(command, "link", "--out", "link/o", cwd=tmp_path)
        check_run(r, before, tmp_path, [], codes=(2,))
        assert "lies inside the input link" in r.stderr, r.stderr


#: 4.3 fields a binary skeleton stores as floats: (document, where the field is, its JSON path).
_MARK = 0.123456789
BINARY_43_FIELDS = {
    "slider mix": ("slider", lambda d: d["constraints"][1], "mix", "/constraints/1/mix"),
    "slider from": ("slider", lambda d: d["constraints"][1], "from", "/constraints/1/from"),
    "slider time key": ("slider", lambda d: d["animations"]["play"]["slider"]["timed"]["time"][1], "value",
                        "/animations/play/slider/timed/time/1/value"),
    "transform mapping scale": ("transform", lambda d: d["constraints"][0]["properties"]["x"]["to"]["x"], "scale",
                                "/constraints/0/properties/x/to/x/scale"),
    "transform mapping max": ("transform", lambda d: d["constraints"][0]["properties"]["x"]["to"]["x"], "max",
                              "/constraints/0/properties/x/to/x/max"),
    "path spacing": ("path", lambda d: d["constraints"][0], "spacing", "/constraints/0/spacing"),
    "physics inertia": ("physics", lambda d: d["constraints"][0], "inertia", "/constraints/0/inertia"),
}


@pytest.mark.parametrize("value", ["nan", "inf"])
@pytest.mark.parametrize("case", list(BINARY_43_FIELDS))
def test_a_43_binary_float_that_is_not_finite_is_refused_where_it_lies(tmp_path, case, value):
    """A .skel whose 4.3 slider, mapping, path or physics float is NaN or infinite (bytes no editor
    writes): every command that reads it (``pose``, ``convert``, ``upgrade``) refuses it in one
    line naming the field's place, never sampling it or writing it as JSON."""
    import struct

    import test_anim43

    from spinemesh.errors import SpineMeshError
    from spinemesh.skeleton import load_skeleton
    from spinemesh.skeleton_binary import encode_skel

    kind, holder, key, where = BINARY_43_FIELDS[case]
    doc = getattr(test_anim43, f"{kind}_doc")()
    holder(doc)[key] = _MARK
    data = encode_skel(doc)
    for fmt in ("<f", ">f"):  # the writer's byte order, whichever it is
        data = data.replace(struct.pack(fmt, _MARK), struct.pack(fmt, float(value)))
    assert data != encode_skel(doc)
    (tmp_path / "x.skel").write_bytes(data)
    with pytest.raises(SpineMeshError, match="non-finite") as e:
        load_skeleton(tmp_path / "x.skel")
    assert where in str(e.value) and "x.skel" in str(e.value)


# --- premultiplied pages: texels of alpha 0 that still draw ----------------------------------------

def test_a_premultiplied_glow_of_alpha_0_stays_inside_the_meshes_and_packs(tmp_path):
    """On a ``pma: true`` page a texel of alpha 0 and colour above 0 draws (additive light): a
    glow ring 4 texels wide around every sprite, alpha 0, must lie inside the meshes ``upgrade``
    makes (a mask by alpha would cut it away), and ``pack`` must write it where the meshes read."""
    import cv2
    from PIL import Image

    from spinemesh.atlas import read_atlas
    from spinemesh.demo import make_demo_project
    from spinemesh.images.decode import load_rgba
    from spinemesh.images.regions import cut_region
    from spinemesh.skeleton import iter_skins, load_skeleton
    from spinemesh.upgrade import Options, upgrade_project

    project = make_demo_project(tmp_path / "p", with_images_folder=False)
    (project / "demo-binary.skel").unlink()
    rgba = np.asarray(Image.open(project / "demo.png").convert("RGBA")).astype(np.int32)
    alpha = rgba[..., 3]
    stored = rgba.copy()
    stored[..., :3] = rgba[..., :3] * alpha[..., None] // 255
    glow = (cv2.dilate((alpha > 0).astype(np.uint8), np.ones((9, 9), np.uint8)) > 0) & (alpha == 0)
    stored[glow, 0], stored[glow, 1] = 120, 60
    Image.fromarray(stored.astype(np.uint8)).save(project / "demo.png")
    atlas = project / "demo.atlas"
    atlas.write_text(atlas.read_text().replace("filter: Linear, Linear", "filter: Linear, Linear\n\tpma: true", 1))
    upgrade_project(project, tmp_path / "o", Options(min_saving=None, jobs=1))

    regions = {r.name: r for r in read_atlas(atlas).regions}
    page = load_rgba(project / "demo.png")
    checked = 0
    for _, slots in iter_skins(load_skeleton(tmp_path / "o" / "demo.json")):
        for key, a in (kv for atts in slots.values() for kv in atts.items()):
            if a.get("type") != "mesh" or (a.get("path") or key) not in regions:
                continue
            image = cut_region(page, regions[a.get("path") or key])
            h, w = image.shape[:2]
            shown = image[..., :3].max(axis=2) > 2
            inside = np.zeros((h, w), np.uint8)
            points = np.round(np.asarray(a["uvs"], float).reshape(-1, 2) * (w, h) * 16).astype(np.int32)
            for tri in np.asarray(a["triangles"]).reshape(-1, 3):
                cv2.fillPoly(inside, [points[tri]], 1, shift=4)
            inside = cv2.dilate(inside, np.ones((3, 3), np.uint8)).astype(bool)  # texels the edges sample
            assert not (shown & ~inside).any(), f"{key}: {int((shown & ~inside).sum())} glowing texels cut away"
            checked += int(shown.sum())
    assert checked > 30_000
    result = pack_project(tmp_path / "o", tmp_path / "packed", PackOptions(larger_files=True))
    (row,) = result.atlases
    assert row.status == "packed", row.reason
    assert _same_texels_drawn(tmp_path / "o", tmp_path / "packed") > 20_000


def test_weights_never_replaces_a_users_files_in_its_output_folder(tmp_path, meshed):
    """``spinemesh weights hero/ --out ~/Documents``: weights wrote into any folder, replacing a
    user's file named like one of the project's (``demo.json`` here) silently, exit 0. Its OUT is
    now held as ``upgrade``'s and ``pack``'s are: refused when not empty, unless --overwrite, and
    --overwrite replaces only a folder spinemesh wrote."""
    from test_hostile import check_run, run_cli, snapshot

    shutil.copytree(meshed, tmp_path / "p", ignore=shutil.ignore_patterns(".*"))
    docs = tmp_path / "docs"
    docs.mkdir()
    (docs / "demo.json").write_text("my own notes")
    before = snapshot(tmp_path)
    for extra in ([], ["--overwrite"]):
        r = run_cli("weights", "p", "--out", "docs", *extra, cwd=tmp_path)
        check_run(r, before, tmp_path, [], codes=(2,))
        assert "docs: output folder is not empty" in r.stderr, r.stderr
    for _ in range(2):  # its own folder is written, then replaced whole
        r = run_cli("weights", "p", "--out", "w", "--overwrite", cwd=tmp_path)
        check_run(r, before, tmp_path, ["w"], codes=(0,))
    assert sorted(p.name for p in (tmp_path / "w").iterdir()) == sorted(
        [".spinemesh-output", *(p.name for p in (tmp_path / "p").iterdir())])


# --- colours as the runtimes read them -----------------------------------------------------------

def _colour_spellings_doc() -> dict:
    """A 4.3 skeleton whose colours are spelt as a hand may write them and the runtimes still read:
    six digits where eight are read (alpha 1), a leading ``#`` (skipped), on slots, attachments,
    ``rgba`` keys and a dark colour."""
    box = {"x": 8, "width": 16, "height": 6}
    slots = [{"name": "six", "bone": "root", "attachment": "box", "color": "ff8040"},
             {"name": "hash", "bone": "root", "attachment": "box", "color": "#80c0ffc0", "dark": "#336699"},
             {"name": "att", "bone": "root", "attachment": "box"},
             {"name": "keyed", "bone": "root", "attachment": "box"}]
    atts = {"six": {"box": box}, "hash": {"box": box}, "att": {"box": {**box, "color": "#2040a0"}},
            "keyed": {"box": box}}
    keys = {"keyed": {"rgba": [{"time": 0, "color": "#10203040"}, {"time": 1, "color": "e0c0a0"}]}}
    return {"skeleton": {"spine": "4.3.23"}, "bones": [{"name": "root"}], "slots": slots,
            "skins": [{"name": "default", "attachments": atts}], "animations": {"tint": {"slots": keys}}}


def test_colours_of_six_digits_or_a_hash_are_read_as_spine_core_reads_them(runtime43, tmp_path):  # noqa: F811
    """The sampler read ``"color": "ff8040"`` on a slot (six digits where eight are read) and any
    ``#rrggbbaa`` as white, where spine-core (and libGDX) skip the ``#`` and take alpha 1 when
    there are not eight digits: ``pose`` and the player drew white what a game draws orange, and
    the ``.skel`` our writer made of it posed orange. Both now pose as spine-core 4.3 draws."""
    from test_anim43_dark import _colours_43, _compare

    results = _colours_43(runtime43, _colour_spellings_doc(), tmp_path, binary=False)
    assert _compare(results)["compared"] >= 4 * 10
    ours = {a["slot"]: a for a in results[0][2]}
    assert ours["six"]["color"] == pytest.approx([1.0, 128 / 255, 64 / 255, 1.0], abs=1e-6)
    # the .skel our writer makes of it draws alike
    assert _compare(_colours_43(runtime43, _colour_spellings_doc(), tmp_path, binary=True))["compared"] >= 4 * 10


@pytest.mark.parametrize("version", ["4.3", "3.8"])
@pytest.mark.parametrize("dark", ["ff", "12345", 123])
def test_convert_refuses_a_dark_colour_no_runtime_reads(tmp_path, dark, version):
    """A slot's dark colour of fewer than six digits (or a number): our binary writer stored
    ``"ff"`` as 0000ff, a blue the document never said, exit 0 (and a number ended in a
    TypeError's words); ``convert`` now refuses it in one line naming the slot's colour."""
    import json
    import subprocess
    import sys

    from test_anim43_dark import dark_doc

    doc = dark_doc() if version == "4.3" else {"skeleton": {"spine": "3.8.99"}, "bones": [{"name": "root"}],
                                               "slots": [{"name": "s", "bone": "root", "dark": "336699"}]}
    doc["slots"][0]["dark"] = dark
    (tmp_path / "x.json").write_text(json.dumps(doc))
    r = subprocess.run([sys.executable, "-m", "spinemesh", "convert", "x.json", "x.skel"], cwd=tmp_path,
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    (line,) = [x for x in r.stderr.splitlines() if x.startswith("error:")]
    assert "x.json" in line and "of six digits" in line and repr(dark) in line, line
    assert not (tmp_path / "x.skel").exists()


# --- what a fuzzer of the 4.3 fixtures found ------------------------------------------------------
# (random fields of the slider, transform, path and physics fixtures set to 0, -1, +-1e9, 1e-30,
# 3.4e38, 1e308, 2**31, text, null, true, [] or {}: 17,000 documents, three kinds of failure)

def test_43_bones_under_a_parent_scaled_to_nothing_pose_as_spine_core(runtime43, tmp_path):  # noqa: F811
    """A 4.3 bone whose local values are taken back from the world under a parent scaled to 0
    divided by zero: Python raised where spine-core divides to an infinity and goes on, and the
    bones the constraints move from there were flagged (``brow``, ``tag``), or a whole animation
    refused ("float division by zero"). They now pose as spine-core 4.3 poses them."""
    from test_anim43 import _against_43, transform_doc

    doc = transform_doc()
    next(b for b in doc["bones"] if b["name"] == "face")["scaleX"] = 0
    results = _against_43(runtime43, doc, tmp_path)
    for r in results:
        assert not {"brow", "tag"} & set(r["flagged"]), (r["label"], r["flagged"])
        assert r["bone"] < 1e-4 and not r["problems"], r
    assert len(results) >= 10


@pytest.mark.parametrize("fps", [45, 60])
def test_43_physics_damped_below_zero_flags_its_bone_instead_of_refusing_the_animation(fps):
    """Damping keyed to -1e9 on a constraint stepping 45 times a second: ``damping ** (60 / 45)``
    is a complex number in Python (NaN in the runtimes), and the animation was refused ("'>' not
    supported between instances of 'float' and 'complex'"). The bone is flagged, the others posed."""
    import json

    from test_anim43 import physics_doc
    from test_hostile_wave4 import within

    from spinemesh.anim import Sampler
    from spinemesh.anim.dump import dump

    doc = physics_doc()
    next(c for c in doc["constraints"] if c["name"] == "cheek")["fps"] = fps
    doc["animations"]["sway"]["physics"]["cheek"]["damping"] = [{"value": -1e9}]
    with within(30):
        poses = json.loads(json.dumps(dump(Sampler(doc), "sway", [0.1, 0.7, 1.5]), allow_nan=False))["poses"]
    assert all(p["bones"]["chin"] is not None and "chin" not in p["inexact"] for p in poses)
    assert any("cheek" in p["inexact"] for p in poses)


def test_a_slider_whose_animation_is_not_a_name_is_refused_in_one_line(tmp_path):
    """``"animation": {}`` on a 4.3 slider ended every command in a traceback (an object is no
    dictionary key); the document's check refuses it where it lies, as any name of the wrong type."""
    import json
    import subprocess
    import sys

    from test_anim43 import slider_doc

    doc = slider_doc()
    doc["constraints"][2]["animation"] = {}
    (tmp_path / "x.json").write_text(json.dumps(doc))
    r = subprocess.run([sys.executable, "-m", "spinemesh", "pose", "x.json", "-a", "nod", "--times", "0.5"],
                       cwd=tmp_path, capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    (line,) = [x for x in r.stderr.splitlines() if x.startswith("error:")]
    assert "x.json" in line and "constraints[2].animation: expected a name, found an object" in line, line


def _path_doc_with(change):
    from test_anim43 import path_doc

    doc = path_doc()
    change(doc["skins"][0]["attachments"])
    return doc


#: A path attachment's numbers no load checks (its vertices are read only where a path constraint
#: follows it): each once ended ``pose`` in a traceback, in "not enough memory", or refused the
#: setup pose; now the path is unreadable, its constraint's bones flagged, the rest posed.
BROKEN_PATHS = {
    "a weighted path's bone index of text": lambda a: a["cable"]["p"]["vertices"].__setitem__(35, "nope"),
    "a weighted path's weight of a list": lambda a: a["cable"]["p"]["vertices"].__setitem__(28, []),
    "a path's vertex of an object": lambda a: a["track"]["p"]["vertices"].__setitem__(3, {}),
    "a vertexCount of 2**31": lambda a: a["cable"]["p"].update(vertexCount=2 ** 31),
    "a vertexCount of 2**63": lambda a: a["ring"]["p"].update(vertexCount=2 ** 63),
}


@pytest.mark.parametrize("case", list(BROKEN_PATHS))
def test_a_path_of_broken_numbers_flags_its_bones(tmp_path, case):
    import json
    import subprocess
    import sys

    (tmp_path / "p").mkdir()
    (tmp_path / "p" / "x.json").write_text(json.dumps(_path_doc_with(BROKEN_PATHS[case])))
    r = subprocess.run([sys.executable, "-m", "spinemesh", "pose", "p/x.json", "-a", "go", "--times", "0.1,0.7",
                        "--out", "pose.json"], cwd=tmp_path, capture_output=True, text=True, timeout=60)
    assert r.returncode == 0 and "Traceback" not in r.stderr, r.stderr[-2000:]
    poses = json.loads((tmp_path / "pose.json").read_text())["poses"]
    assert all(p["bones"]["rail"] is not None and "rail" not in p["inexact"] for p in poses)


@pytest.mark.parametrize("version", ["4.3", "4.2"])
@pytest.mark.parametrize("mass", [0, -0.0])
def test_convert_of_a_physics_mass_of_zero_is_one_line(tmp_path, version, mass):
    """The binary stores a physics constraint's inverse mass: ``convert`` of a mass of 0 (which
    the document's check lets through and ``pose`` plays) ended in a ZeroDivisionError traceback."""
    import json
    import subprocess
    import sys

    from test_anim43 import physics_doc
    from test_hostile_round6 import _as_42

    doc = physics_doc()
    doc["constraints"][0]["mass"] = mass
    (tmp_path / "x.json").write_text(json.dumps(doc if version == "4.3" else _as_42(doc)))
    r = subprocess.run([sys.executable, "-m", "spinemesh", "convert", "x.json", "x.skel"], cwd=tmp_path,
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr[-2000:]
    (line,) = [x for x in r.stderr.splitlines() if x.startswith("error:")]
    assert "x.json" in line and "mass other than 0" in line, line
    assert not (tmp_path / "x.skel").exists()


@pytest.mark.parametrize("command", ["upgrade", "pack"])
def test_a_preview_never_replaces_a_users_files(tmp_path, meshed, command):
    """``--preview ~/Documents``: the preview's index.html, player.js, s/, data/ and img/ replaced a
    user's files of those names (exit 0). A folder that holds files but no spinemesh preview is now
    refused before anything is written; an earlier preview is written over, as before."""
    from test_hostile import check_run, run_cli, snapshot

    shutil.copytree(meshed, tmp_path / "p", ignore=shutil.ignore_patterns(".*"))
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "index.html").write_text("my own page")
    before = snapshot(tmp_path)
    r = run_cli(command, "p", "--out", "o", "--preview", "docs", cwd=tmp_path)
    check_run(r, before, tmp_path, [], codes=(2,))
    assert "docs: preview folder is not empty and holds no spinemesh preview" in r.stderr, r.stderr
    for out in ("o1", "o2"):  # its own preview, written again
        r = run_cli(command, "p", "--out", out, "--preview", "v", cwd=tmp_path)
        check_run(r, before, tmp_path, ["o1", "o2", "v"], codes=(0,))


@pytest.mark.parametrize("command, option", [("weights", "--preview"), ("upgrade", "--images")])
def test_pictures_never_replace_a_users_files(tmp_path, meshed, command, option):
    """``weights --preview ~/Documents`` and ``upgrade --images ~/Documents`` wrote their pictures
    into a folder of a user's files, replacing those named like ours (exit 0). Such a folder is now
    refused before anything is written, as the HTML previews are; one they wrote before is written
    into again."""
    from test_hostile import check_run, run_cli, snapshot

    from spinemesh.demo import make_demo_project

    if command == "weights":  # meshes to weigh; upgrade cuts the regions of the demo as exported
        shutil.copytree(meshed, tmp_path / "p", ignore=shutil.ignore_patterns(".*"))
    else:
        make_demo_project(tmp_path / "p", with_images_folder=False)
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "notes.txt").write_text("my own notes")
    before = snapshot(tmp_path)
    r = run_cli(command, "p", "--out", "o", option, "docs", cwd=tmp_path)
    check_run(r, before, tmp_path, [], codes=(2,))
    what = "preview folder" if option == "--preview" else "--images folder"
    assert f"docs: {what} is not empty and holds no spinemesh" in r.stderr, r.stderr
    for out in ("o1", "o2"):  # its own folder, written into again
        r = run_cli(command, "p", "--out", out, option, "v", cwd=tmp_path)
        check_run(r, before, tmp_path, ["o1", "o2", "v"], codes=(0,))
    assert any(p.suffix == ".png" for p in (tmp_path / "v").rglob("*")), list((tmp_path / "v").rglob("*"))


#: Pages ``upgrade --repack`` would move a sequence's frames off onto a new page drawn otherwise
#: (still, upright, shared): how the page is made, words the reason must hold.
NO_NEW_PAGE = {
    "an APNG page": (lambda p, im: _apng(p, im, False), "animated (2 frames)"),
    "a PNG page turned by EXIF": (lambda p, im: im.save(p / "demo.png", exif=_exif(6)), "EXIF orientation 6"),
    "a page that repeats": (_field("filter: Linear, Linear\n\trepeat: xy"), "repeats (xy)"),
}


@pytest.mark.parametrize("case", sorted(NO_NEW_PAGE))
def test_repack_never_moves_frames_off_a_page_drawn_otherwise(tmp_path, case):
    """``upgrade --repack`` cut a differently trimmed sequence's frames from an animated page, a page
    turned by EXIF or one that repeats onto a new still, upright, shared page (exit 0), what
    ``pack`` refuses for the same reasons. The sequence now stays a region, with pack's reason."""
    from PIL import Image
    from test_hostile import check_run, run_cli, snapshot

    from spinemesh.demo import demo_images, make_demo_project, pack_atlas

    make, words = NO_NEW_PAGE[case]
    project = make_demo_project(tmp_path / "p", with_images_folder=False)
    (project / "demo-binary.skel").unlink()
    text, page = pack_atlas(demo_images(), "demo.png", rotate={"demo-arm"})   # the spark's frames trimmed
    (project / "demo.atlas").write_text(text)
    make(project, Image.fromarray(page, "RGBA"))
    atlas = (project / "demo.atlas").read_text()
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", "o", "--repack", "--min-saving", "0", "--report", "r.json", cwd=tmp_path)
    check_run(r, before, tmp_path, ["o", "r.json"], codes=(0,))
    assert not sorted((tmp_path / "o").glob("*untrimmed*"))
    assert (tmp_path / "o" / "demo.atlas").read_text() == atlas
    report = json.loads((tmp_path / "r.json").read_text())
    (spark,) = [t for t in report["attachments"] if "spark" in t["name"]]
    assert spark["status"] == "kept" and words in spark["reason"] and "'demo.png'" in spark["reason"], spark
    assert words in " ".join(r.stdout.split()), r.stdout   # the console says it too


@pytest.mark.parametrize("name, save, words", [
    ("demo.bmp", lambda im, f: im.save(f, "BMP"), "the page formats spinemesh reads and writes"),
    ("demo.ktx2", lambda im, f: f.write_bytes(KTX2_HEAD + bytes(64)), "the page formats spinemesh reads and writes"),
    ("demo.jpg", lambda im, f: im.convert("RGB").save(f, "JPEG", quality=95), "JPEG, which has no alpha"),
])
def test_a_kept_page_of_another_format_is_said_as_it_is(meshed, tmp_path, name, save, words):
    """A BMP or KTX2 page was kept with the reason that JPEG pages have no alpha and lose texels:
    only a JPEG page is said to be one."""
    project = tmp_path / "p"
    shutil.copytree(meshed, project, ignore=shutil.ignore_patterns(".*"))
    im = _demo_texels(meshed)
    _renamed_page(project, name, lambda f: save(im, f))
    (row,) = pack_project(project, tmp_path / "out", PackOptions(larger_files=True)).atlases
    assert row.status == "kept" and f"page {name!r} is not PNG, WebP or AVIF" in row.reason, row.reason
    assert words in row.reason and ("JPEG" in row.reason) == name.endswith(".jpg"), row.reason


def _colour_spellings_38() -> dict:
    """A 3.8 skeleton with ``#`` colours on a slot, its dark colour, an attachment and keys."""
    keys = {"color": [{"time": 0, "color": "#10203040"}, {"time": 1, "color": "e0c0a0"}],
            "twoColor": [{"time": 0, "light": "#ffffffff", "dark": "#102030"}]}
    return {"skeleton": {"spine": "3.8.99"}, "bones": [{"name": "root"}],
            "slots": [{"name": "s", "bone": "root", "attachment": "box", "color": "#ff8040", "dark": "#336699"}],
            "skins": [{"name": "default", "attachments": {"s": {"box": {"width": 16, "height": 6,
                                                                        "color": "#2040a0"}}}}],
            "animations": {"tint": {"slots": {"s": keys}}}}


@pytest.mark.parametrize("version", ["4.3", "3.8"])
def test_convert_reads_a_hash_colour_as_the_sampler_does(tmp_path, version):
    """``convert`` refused ``"#ff8040"`` (a slot's, an attachment's, a key's, a dark colour) that
    the sampler, spine-core and libGDX read, skipping the ``#``: it now writes the colour the
    sampler draws, the ``.skel`` byte for byte that of the same document without the ``#``, and
    reads it back without one, as Spine writes colours."""
    import subprocess
    import sys

    from spinemesh.anim.timelines import color_channels

    doc = _colour_spellings_doc() if version == "4.3" else _colour_spellings_38()
    plain = json.loads(json.dumps(doc).replace('"#', '"'))
    (tmp_path / "x.json").write_text(json.dumps(doc))
    (tmp_path / "plain.json").write_text(json.dumps(plain))
    for source, target in (("x.json", "x.skel"), ("plain.json", "plain.skel"), ("x.skel", "back.json")):
        r = subprocess.run([sys.executable, "-m", "spinemesh", "convert", source, target], cwd=tmp_path,
                           capture_output=True, text=True, timeout=60, check=False)
        assert r.returncode == 0, r.stderr
    assert (tmp_path / "x.skel").read_bytes() == (tmp_path / "plain.skel").read_bytes()
    back = (tmp_path / "back.json").read_text()
    assert "#" not in back and "ff8040" in back, back
    assert color_channels("#ff804080", 4) == color_channels("ff804080", 4) == [1.0, 128 / 255, 64 / 255, 128 / 255]
