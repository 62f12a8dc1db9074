"""Hostile input, ninth round: the output side (a disk that fills mid-write, outputs that are
files or links), JSON at its edges (keys written twice, UTF-16, numbers of hundreds of digits),
page pixel formats and atlas dialects.

As in the earlier rounds (tests/test_hostile*.py), every project is made here by our own code;
each case checks what docs/safety.md promises: one clear line naming the file, never a
traceback, never a wrong output written silently, inputs unchanged.
"""

from __future__ import annotations

import json
import os
import resource
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from test_hostile import TIME_LIMIT, check_run, json_demo, run_cli, snapshot

# --- atlas dialects -----------------------------------------------------------------------------

@pytest.mark.parametrize("degrees", ["-270", "450", "-90", "True"])
def test_a_turn_the_runtimes_do_not_make_keeps_its_region(tmp_path, degrees):
    """``rotate: -270`` or ``450``: spine-core, libGDX and spine-c turn a region by exactly 90,
    180 or 270 degrees and draw any other number unturned. Read modulo 360, such a region was cut
    turned, meshed, and ``--pack`` wrote it back as ``rotate: 90`` (exit 0): the game then drew
    another picture than before. ``rotate: True`` likewise (the 4.x runtimes compare with ``true``
    exactly: spine-core draws it unturned, libGDX fails to load it). Now the region is refused in
    one line naming the atlas's line; its attachments stay regions and the atlas is kept, its text
    byte for byte."""
    project = json_demo(tmp_path)
    atlas = project / "demo.atlas"
    atlas.write_text(atlas.read_text().replace("rotate: 90", f"rotate: {degrees}"))
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", "o", "--pack", "--jobs", "1", cwd=tmp_path)
    check_run(r, before, tmp_path, ["o/"], codes=(3,))
    assert "demo.atlas:16: region 'demo-arm': rotate must be " in r.stderr, r.stderr
    assert (tmp_path / "o" / "demo.atlas").read_bytes() == atlas.read_bytes()
    arm = json.loads((tmp_path / "o" / "demo.json").read_text())["skins"][0]["attachments"]["arm"]["demo-arm"]
    assert arm.get("type", "region") == "region"


# --- JSON edges ---------------------------------------------------------------------------------

@pytest.mark.parametrize("value", ["1" + "0" * 400, "1e300", '"wide"'], ids=["400 digits", "1e300", "text"])
def test_pose_never_draws_an_attachment_of_an_unusable_number_elsewhere(tmp_path, value):
    """A region attachment whose ``y`` is an integer of 400 digits or 1e300 (no float32 holds
    either: the runtimes' quad is infinite) was posed with ``y`` 0, the field's default, and
    ``pose`` ended with 0: a pose no runtime draws. Now such an attachment is not drawn, a warning
    names its field, and the run ends with 3; the other attachments are posed as before."""
    project = json_demo(tmp_path)
    skeleton = project / "demo.json"
    text = skeleton.read_text()
    skeleton.write_text(text.replace('"y": 10,', f'"y": {value},', 1))
    assert skeleton.read_text() != text
    before = snapshot(tmp_path)
    r = run_cli("pose", "p/demo.json", "--out", "pose.json", cwd=tmp_path)
    check_run(r, before, tmp_path, ["pose.json"], codes=(3,))
    assert "skins[0].attachments.head.demo-head.y: expected a finite number" in r.stderr, r.stderr
    drawn = [a["slot"] for a in json.loads((tmp_path / "pose.json").read_text())["poses"][0]["attachments"]]
    assert drawn == ["arm", "body", "ring", "blobs", "spark"], drawn


@pytest.mark.parametrize("keys", ['"x": 50, "x": 0.0', '"X": 50, "x": 0.0'], ids=["twice", "twice but for case"])
def test_an_attachment_naming_a_field_twice_is_left_as_written(tmp_path, keys):
    """``{"x": 50, "x": 0}`` (a merge gone wrong): spine-c, spine-cpp and libGDX read the first
    ``x`` whose name matches ignoring case, spine-ts and Python the last. The region was meshed at
    the last and written back once, so the C runtimes' head moved by 50 (exit 0). Now such an
    attachment stays a region, byte for byte, with one line naming the field; ``convert`` and
    ``pose`` say the same."""
    project = json_demo(tmp_path)
    skeleton = project / "demo.json"
    text = skeleton.read_text()
    head = '"demo-head": {\n\t\t\t\t\t\t"x": 0.0,'
    assert head in text
    skeleton.write_text(text.replace(head, '"demo-head": {\n\t\t\t\t\t\t' + keys + ",", 1))
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", "o", "--jobs", "1", "--min-saving", "0", cwd=tmp_path)
    check_run(r, before, tmp_path, ["o/"], codes=(3,))
    assert "demo-head.x: written twice" in r.stderr.replace(".X:", ".x:"), r.stderr
    written = (tmp_path / "o" / "demo.json").read_text()
    assert '"demo-head": {\n\t\t\t\t\t\t' + keys + "," in written
    assert written.count('"type": "mesh"') >= 4  # the others are meshed
    for args, outputs in ((["convert", "p/demo.json", "c.skel"], []), (["pose", "p/demo.json", "--out", "pose.json"],
                                                                       ["pose.json"])):
        r = run_cli(*args, cwd=tmp_path)
        check_run(r, before, tmp_path, ["o/", *outputs], codes=(2, 3))
        assert "written twice" in r.stderr, r.stderr
    assert not (tmp_path / "c.skel").exists()


def test_the_json_parser_marks_only_objects_that_name_a_key_twice():
    """Keys repeated exactly or but for case are marked, in any object; other objects are plain."""
    from spinemesh.skeleton import parse_skeleton_json
    from spinemesh.skeleton_check import KeyedTwice

    doc = parse_skeleton_json('{"a": {"x": 1, "X": 2, "y": 3}, "b": {"y": 1, "y": 2}, "c": {"Head": 1, "head2": 2}}')
    assert doc["a"].twice == {"x"} and doc["b"].twice == {"y"} and doc["b"] == {"y": 2}
    assert type(doc) is dict and type(doc["c"]) is dict and not isinstance(doc["c"], KeyedTwice)


@pytest.mark.parametrize("encoding", ["utf-16", "utf-16-le", "utf-32"])
def test_a_skeleton_saved_as_utf16_is_said_so(tmp_path, encoding):
    """A skeleton a Windows editor saved as "Unicode" (UTF-16 or UTF-32, with or without a
    byte-order mark) was read as a binary and refused as "expected a Spine version string in the
    header"; the runtimes read JSON as UTF-8 only, and now the line says what the file is."""
    project = json_demo(tmp_path)
    skeleton = project / "demo.json"
    skeleton.write_bytes(skeleton.read_text().encode(encoding))
    before = snapshot(tmp_path)
    commands = [["convert", "p/demo.json", "c.skel"]]
    if encoding != "utf-16-le":  # without a byte-order mark, no "skeleton" object is seen: no skeleton to pose
        commands.append(["pose", "p/demo.json"])
    for args in commands:
        r = run_cli(*args, cwd=tmp_path)
        check_run(r, before, tmp_path, [], codes=(2,))
        assert f"demo.json: skeleton is {encoding[:6].upper()} text" in r.stderr, r.stderr


@pytest.mark.parametrize("later_line", ["\tbounds: 105, 2, 81, 81", "\txy: 105, 2"], ids=["bounds twice", "bounds then xy"])
def test_a_region_line_written_twice_is_read_as_the_runtimes_read_it(tmp_path, later_line):
    """spine-core, libGDX and spine-c set a region's fields line by line: of two ``bounds:``
    lines, or an ``xy:`` after ``bounds:``, the later line places the region. The first one was
    taken (the ring's texels cut, meshed and packed as the head's, exit 0). Now the project
    upgrades and packs exactly as the one with that line alone."""
    clean = json_demo(tmp_path / "clean")
    r = run_cli("upgrade", "p", "--out", "o", "--pack", "--jobs", "1", cwd=tmp_path / "clean")
    assert r.returncode == 0, r.stderr
    project = json_demo(tmp_path)
    atlas = project / "demo.atlas"
    text = atlas.read_text()
    head = "demo-head\n\tbounds: 105, 2, 81, 81\n"
    assert head in text
    atlas.write_text(text.replace(head, f"demo-head\n\tbounds: 188, 2, 81, 81\n{later_line}\n"))
    before = snapshot(tmp_path / "p")
    r = run_cli("upgrade", "p", "--out", "o", "--pack", "--jobs", "1", cwd=tmp_path)
    check_run(r, before, tmp_path / "p", [], codes=(0,))
    for name in ("demo.json", "demo.atlas", "demo.png"):
        assert (tmp_path / "o" / name).read_bytes() == (clean.parent / "o" / name).read_bytes(), name


# --- page pixel formats -------------------------------------------------------------------------

@pytest.mark.parametrize("chunk", ["gAMA", "iCCP"])
def test_editor_images_say_what_their_page_says_of_its_colours(tmp_path, chunk):
    """``upgrade --images`` cut each region of a page of gamma 1.0 (or with a colour profile) into
    a PNG with no colour chunk: an editor or a browser that manages colour showed it in other
    colours than the page, and re-imported, the art changed. Each editor image now carries its
    page's colour chunks, as the pages ``pack`` and ``--repack`` write do."""
    import struct
    import zlib

    from spinemesh.pack.png import colour_chunks, with_colour_chunks

    project = json_demo(tmp_path)
    page = project / "demo.png"
    body = struct.pack(">I", 100000) if chunk == "gAMA" else b"mine\0\0" + zlib.compress(_srgb_profile())
    page.write_bytes(with_colour_chunks(page.read_bytes(), ((chunk.encode(), body),)))
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", "o", "--images", "editor", "--jobs", "1", cwd=tmp_path)
    check_run(r, before, tmp_path, ["o/", "editor/"], codes=(0,))
    written = sorted((tmp_path / "editor").rglob("*.png"))
    assert len(written) == 8, written
    for image in written:
        assert colour_chunks(image.read_bytes()) == ((chunk.encode(), body),), image


def _srgb_profile() -> bytes:
    from PIL import ImageCms

    return ImageCms.ImageCmsProfile(ImageCms.createProfile("sRGB")).tobytes()


@pytest.mark.parametrize("where", ["skins", "a bone's y"])
def test_a_skeleton_naming_a_part_twice_is_refused_in_one_line(tmp_path, where):
    """``"skins"`` written twice at the top level: upgrade meshed the second list and wrote the
    document back with it alone, so the C runtimes, which had drawn the first, drew other art
    (exit 0). A field the program reads written twice elsewhere in the document (a bone's ``y``)
    is the same ambiguity: the skeleton is refused in one line naming the field; the project's
    other skeleton is upgraded."""
    project = json_demo(tmp_path)
    skeleton = project / "demo.json"
    text = skeleton.read_text()
    (project / "other.json").write_text(text)
    if where == "skins":
        start, end = text.index('\t"skins"'), text.index('\t"animations"')
        text = text[:start] + text[start:end] + text[start:end].replace('"y": 10,', '"y": 60,', 1) + text[end:]
        field = "skins: written twice"
    else:
        bone = '"name": "head",\n\t\t\t"parent": "body",\n\t\t\t"y": 120'
        assert bone in text
        text = text.replace(bone, bone + ',\n\t\t\t"y": 40', 1)
        field = "bones[2].y: written twice"
    skeleton.write_text(text)
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", "o", "--jobs", "1", cwd=tmp_path)
    check_run(r, before, tmp_path, ["o/"], codes=(3,))
    assert f"demo.json: {field}" in r.stderr, r.stderr
    assert (tmp_path / "o" / "other.json").read_text().count('"type": "mesh"') >= 4
    r = run_cli("pose", "p/demo.json", cwd=tmp_path)
    check_run(r, before, tmp_path, ["o/"], codes=(2,))
    assert field in r.stderr, r.stderr


@pytest.mark.parametrize("degrees", ["180", "270"])
def test_a_region_attachment_on_a_region_turned_by_180_or_270_stays_a_region(tmp_path, degrees):
    """Every runtime turns a region stored at 180 or 270 degrees for a mesh, but draws a region
    attachment on it unturned (spine-core's dump of this project gives the ring the UVs of an
    unturned region). Upgraded, the ring's mesh turned the texels, another picture than the game
    drew (exit 0). The Spine editor turns only regions that meshes draw (the corpus's 26 such
    regions are all meshes'), so such a region attachment is left as it is, with the reason."""
    project = json_demo(tmp_path)
    atlas = project / "demo.atlas"
    ring = "demo-ring\n\tbounds: 188, 2, 93, 93\n"
    assert ring in atlas.read_text()
    atlas.write_text(atlas.read_text().replace(ring, ring + f"\trotate: {degrees}\n"))
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", "o", "--jobs", "1", "--min-saving", "0", cwd=tmp_path)
    check_run(r, before, tmp_path, ["o/"], codes=(3,))
    assert f"'demo-ring' is stored turned by {degrees} degrees" in r.stderr, r.stderr
    attachments = json.loads((tmp_path / "o" / "demo.json").read_text())["skins"][0]["attachments"]
    assert attachments["ring"]["demo-ring"].get("type", "region") == "region"
    assert attachments["head"]["demo-head"]["type"] == "mesh"


def _old_syntax(atlas: Path) -> None:
    """Rewrite a 4.x atlas in the old libGDX syntax: ``xy``, ``size``, ``orig``, ``offset``,
    ``index: -1``, ``rotate: true``, page ``format`` and ``repeat`` lines, two-space indents."""
    from spinemesh.atlas import read_atlas

    parsed = read_atlas(atlas)
    page = parsed.pages[0]
    lines = ["", page.name, "size: {}".format(",".join(page.get("size"))), "format: RGBA8888",
             "filter: Linear,Linear", "repeat: none"]
    for region in parsed.regions:
        g = region.geometry()
        lines += [region.name, f"  rotate: {'true' if g.degrees == 90 else 'false'}", f"  xy: {g.x}, {g.y}",
                  f"  size: {g.width}, {g.height}", f"  orig: {g.original_width}, {g.original_height}",
                  f"  offset: {g.offset_x}, {g.offset_y}", "  index: -1"]
    atlas.write_text("\n".join(lines) + "\n")


def test_the_old_atlas_syntax_upgrades_to_the_same_meshes_and_draws_so_in_the_runtime(tmp_path, spine_runtime):
    """An atlas in the old libGDX syntax upgrades (``--pack`` too) to the very meshes of its 4.x
    form, written back in its own syntax; spine-core draws the upgraded project's meshes over the
    original regions (``compare.mjs`` on the two dumps); and it draws a region attachment on a
    region stored at 270 degrees unturned, the reason such an attachment stays a region."""
    from runtime_tool import compare_dumps, dump

    clean = json_demo(tmp_path / "clean")
    old = json_demo(tmp_path)
    _old_syntax(old / "demo.atlas")
    for cwd in (tmp_path / "clean", tmp_path):
        r = run_cli("upgrade", "p", "--out", "o", "--pack", "--jobs", "1", cwd=cwd)
        assert r.returncode == 0, r.stderr
    assert (tmp_path / "o" / "demo.json").read_bytes() == (clean.parent / "o" / "demo.json").read_bytes()
    written = (tmp_path / "o" / "demo.atlas").read_text()
    assert "\n  xy: " in written and "bounds" not in written
    # the meshes over the page as it was (the harness's compare decodes 8-bit pages only)
    r = run_cli("upgrade", "p", "--out", "m", "--jobs", "1", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    dump(spine_runtime, old / "demo.atlas", old / "demo.json", "wave", "0,0.5", tmp_path / "a.json")
    dump(spine_runtime, tmp_path / "m" / "demo.atlas", tmp_path / "m" / "demo.json", "wave", "0,0.5", tmp_path / "b.json")
    ok, text = compare_dumps(spine_runtime, tmp_path / "a.json", tmp_path / "b.json")
    assert ok, text

    atlas = clean / "demo.atlas"
    ring = "demo-ring\n\tbounds: 188, 2, 93, 93\n"
    uvs = []
    for turn in ("", "\trotate: 270\n"):
        atlas.write_text(atlas.read_text().replace(ring, ring + turn) if turn else atlas.read_text())
        dump(spine_runtime, atlas, clean / "demo.json", None, "0", tmp_path / "ring.json")
        poses = json.loads((tmp_path / "ring.json").read_text())["poses"]
        uvs.append(next(a["uvs"] for a in poses[0]["attachments"] if a["slot"] == "ring"))
    assert uvs[0] == uvs[1]


def test_editor_images_of_a_scaled_page_have_no_dark_fringe(tmp_path):
    """A page exported at ``scale: 0.5`` gives editor images twice its size. They were resized as
    straight RGBA, so the black of transparent texels ran into the edge: the head's half-transparent
    outline, skin-coloured (250, 210, 170) on the page, came out as dark as (21, ...), a dark fringe
    once re-imported. Resized premultiplied, the outline keeps the skin's colour."""
    import numpy as np
    from PIL import Image

    project = json_demo(tmp_path)
    atlas = project / "demo.atlas"
    atlas.write_text(atlas.read_text().replace("\tfilter: Linear, Linear\n", "\tfilter: Linear, Linear\n\tscale: 0.5\n", 1))
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", "o", "--images", "editor", "--jobs", "1", cwd=tmp_path)
    check_run(r, before, tmp_path, ["o/", "editor/"], codes=(0,))
    head = np.asarray(Image.open(tmp_path / "editor" / "demo-head.png").convert("RGBA")).astype(int)
    assert head.shape == (180, 180, 4)
    edge = (head[..., 3] > 20) & (head[..., 3] < 235)
    assert edge.sum() > 500
    assert np.abs(head[edge][:, :3] - (250, 210, 170)).max() <= 12, head[edge][:, :3].min(0)


def test_a_page_the_runtimes_read_as_straight_is_cut_straight(tmp_path):
    """``pma: True``: spine-core, libGDX and spine-c compare the value with ``true`` exactly, so
    the page is straight there; it was read as premultiplied, and its editor images divided by
    alpha (their half-transparent texels made brighter). They are now those of a straight page."""
    import numpy as np
    from PIL import Image

    for name, pma in (("straight", ""), ("capital", "\tpma: True\n")):
        project = json_demo(tmp_path / name)
        page = np.asarray(Image.open(project / "demo.png").convert("RGBA")).copy()
        page[..., 3] //= 2  # half-transparent art
        Image.fromarray(page).save(project / "demo.png")
        atlas = project / "demo.atlas"
        atlas.write_text(atlas.read_text().replace("\tfilter: Linear, Linear\n", "\tfilter: Linear, Linear\n" + pma, 1))
        r = run_cli("upgrade", "p", "--out", "o", "--images", "editor", "--jobs", "1", cwd=tmp_path / name)
        assert r.returncode == 0, r.stderr
    for image in sorted((tmp_path / "straight" / "editor").rglob("*.png")):
        twin = tmp_path / "capital" / "editor" / image.relative_to(tmp_path / "straight" / "editor")
        assert twin.read_bytes() == image.read_bytes(), image.name


def _profile_fits(data: bytes) -> bool:
    """Whether a PNG file's colour profile is of the colour space its texels allow (grey on grey)."""
    from spinemesh.pack.png import chunk_meaning, png_chunks

    chunks = png_chunks(data)
    grey = chunks[0][1][9] in (0, 4)
    spaces = [chunk_meaning(kind, body)[16:20] for kind, body in chunks if kind == b"iCCP"]
    return all(space == (b"GRAY" if grey else b"RGB ") for space in spaces)


def test_a_grey_page_s_colour_profile_is_never_put_on_colour_texels(tmp_path):
    """A grey-and-alpha page with a grey (``GRAY``) colour profile: ``pack`` wrote it as a palette
    page carrying that profile, and ``--images`` as RGBA images carrying it; PNG allows a grey
    profile on grey texels only, so libpng and browsers ignore it there: the profile was dropped
    in effect. The packed atlas is now kept, with the reason, and the editor images are written
    grey, carrying the profile."""
    from PIL import Image

    from spinemesh.pack.png import colour_chunks

    project = json_demo(tmp_path)
    grey_profile = bytearray(_srgb_profile())
    grey_profile[16:20] = b"GRAY"  # the header's colour space: all a reader looks at to take or leave it
    Image.open(project / "demo.png").convert("LA").save(project / "demo.png", icc_profile=bytes(grey_profile))
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", "o", "--pack", "--images", "editor", "--jobs", "1", cwd=tmp_path)
    check_run(r, before, tmp_path, ["o/", "editor/"], codes=(0,))
    assert _profile_fits((tmp_path / "o" / "demo.png").read_bytes())
    assert "would carry a colour profile of the GRAY colour space on colour texels" in r.stdout + r.stderr
    assert (tmp_path / "o" / "demo.atlas").read_bytes() == (project / "demo.atlas").read_bytes()
    for image in sorted((tmp_path / "editor").rglob("*.png")):
        data = image.read_bytes()
        assert _profile_fits(data) and Image.open(image).mode == "LA", image
        assert [kind for kind, _ in colour_chunks(data)] == [b"iCCP"]


@pytest.mark.parametrize("field", ['"x": 0.0, "x": 0.0', '"x": 2e9'], ids=["written twice", "beyond the limit"])
def test_pack_keeps_the_rectangle_of_a_region_an_unusable_attachment_draws(tmp_path, field):
    """A second skeleton draws the head as a region attachment that names ``x`` twice (every
    runtime draws it, at one ``x`` or the other) or places it at 2e9 (drawn, far away): its
    fields cannot be used, so ``pack`` passed it over and packed the head by the outline of the
    first skeleton's mesh, where other regions' texels may lie inside its rectangle (exit 0).
    Now such an attachment pins its region to its stored rectangle, with the reason."""
    project = json_demo(tmp_path)
    original = (project / "demo.json").read_text()
    r = run_cli("upgrade", "p", "--out", "m", "--jobs", "1", "--min-saving", "0", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    head = '"demo-head": {\n\t\t\t\t\t\t"x": 0.0,'
    assert head in original
    (tmp_path / "m" / "other.json").write_text(original.replace(head, '"demo-head": {\n\t\t\t\t\t\t' + field + ","))
    before = snapshot(tmp_path)
    r = run_cli("pack", "m", "--out", "k", "--report", "k.json", "--jobs", "1", cwd=tmp_path)
    check_run(r, before, tmp_path, ["k/", "k.json"], codes=(0,))
    report = json.loads((tmp_path / "k.json").read_text())
    (atlas,) = report["atlases"]
    pinned = {row["region"]: row["reason"] for row in atlas["regions_by_rectangle"]}
    assert "demo-head" in pinned and "other.json" in pinned["demo-head"], atlas


# --- the output side ----------------------------------------------------------------------------

def _run_with_file_limit(limit: int, *args, cwd: Path) -> subprocess.CompletedProcess:
    """``python -m spinemesh ARGS`` where no file may grow past ``limit`` bytes: every write past it
    fails with EFBIG, as on a full disk (SIGXFSZ ignored)."""
    def limited():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    env = {**os.environ, "COLUMNS": "60", "NO_COLOR": "1", "OMP_NUM_THREADS": "1"}
    return subprocess.run([sys.executable, "-m", "spinemesh", *args], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=TIME_LIMIT, preexec_fn=limited, check=False)


@pytest.mark.parametrize("command", ["pack", "upgrade --pack", "weights"])
@pytest.mark.parametrize("limit", [500, 1000, 2500])
def test_a_full_disk_never_leaves_an_atlas_without_its_page(tmp_path, limit, command):
    """A disk that fills while ``pack``, ``upgrade --pack`` or ``weights`` writes: the packed atlas
    and its page are written as one or not at all; but the original atlas was copied (487 bytes
    fit) while its page (3.6 kB) was not, an atlas that would not load. Now an atlas is copied
    after its pages and not without them; every file there is whole, none temporary, the run
    ends with 3 and one line a file."""
    from spinemesh.atlas import read_atlas

    json_demo(tmp_path)
    r = run_cli("upgrade", "p", "--out", "m", "--jobs", "1", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    before = snapshot(tmp_path)
    source = "p" if command == "upgrade --pack" else "m"
    jobs = [] if command == "weights" else ["--jobs", "1"]  # weights runs in one process
    r = _run_with_file_limit(limit, *command.split(), source, "--out", "o", *jobs, cwd=tmp_path)
    check_run(r, before, tmp_path, ["o/"], codes=(3,))
    assert "File too large" in r.stderr, r.stderr
    out = tmp_path / "o"
    if not out.exists():  # nothing whole fitted: the failed run took away the folder it made
        return
    for atlas in out.glob("*.atlas"):
        for page in read_atlas(atlas).pages:
            assert (atlas.parent / page.name).is_file(), f"{atlas.name} is there without {page.name}"
    for f in out.iterdir():  # at 2,500 bytes the packed page fits, and its atlas is written packed
        if not f.name.startswith(".") and command == "pack" and limit < 2500:
            assert f.read_bytes() == (tmp_path / "m" / f.name).read_bytes(), f.name


def test_a_field_named_but_for_case_is_left_as_written(tmp_path):
    """``{"X": 50, "y": 10, ...}`` and no ``x``: spine-c, spine-cpp and libGDX match names ignoring
    case and place the head at x 50; spine-ts and the program read no ``x`` (0). The region was
    meshed at 0 and written so, moving the head in the C runtimes (exit 0); now it stays as
    written, with one line naming the field."""
    project = json_demo(tmp_path)
    skeleton = project / "demo.json"
    head = '"demo-head": {\n\t\t\t\t\t\t"x": 0.0,'
    skeleton.write_text(skeleton.read_text().replace(head, '"demo-head": {\n\t\t\t\t\t\t"X": 50,'))
    before = snapshot(tmp_path)
    r = run_cli("upgrade", "p", "--out", "o", "--jobs", "1", "--min-saving", "0", cwd=tmp_path)
    check_run(r, before, tmp_path, ["o/"], codes=(3,))
    assert "demo-head.X: read as 'x' by spine-c" in r.stderr, r.stderr
    assert '"demo-head": {\n\t\t\t\t\t\t"X": 50,' in (tmp_path / "o" / "demo.json").read_text()
