"""``spinemesh pack``: pages packed by mesh outlines sample exactly what the original pages did.

The projects are made by our own code: the demo (:mod:`spinemesh.demo`: stripped whitespace, a
rotated region, a sequence) upgraded to meshes, so that most regions are drawn by meshes only.
The check that matters is independent of the packer: every mesh is sampled at points inside
its triangles through the runtimes' own UV formula (``MeshAttachment.updateUVs`` of spine-ts
3.7-4.2, written out again here) on the original page and on the packed one, and the
bilinear samples must be equal.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from spinemesh.atlas import read_atlas
from spinemesh.cli import app
from spinemesh.demo import make_demo_project
from spinemesh.images.decode import load_rgba
from spinemesh.images.regions import cut_region
from spinemesh.images.sources import AtlasImages
from spinemesh.pack.atlas_pack import PageRules, measured_padding
from spinemesh.pack.place import fill_pages
from spinemesh.pack.run import PackOptions, pack_project
from spinemesh.skeleton import image_paths, iter_attachments, load_skeleton
from spinemesh.upgrade import Options, upgrade_project

runner = CliRunner()

#: Random sample points per triangle (besides the vertices).
POINTS = 60


def _copy(project: Path, dest: Path, skip: tuple[str, ...] = ()) -> Path:
    """The project's files (not hidden ones, nor names ending in ``skip``) copied to ``dest``."""
    dest.mkdir()
    for f in project.iterdir():
        if f.is_file() and not f.name.startswith(".") and not f.name.endswith(skip):
            (dest / f.name).write_bytes(f.read_bytes())
    return dest


def _digest(folder: Path) -> dict:
    return {p.relative_to(folder).as_posix(): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def runtime_uvs(uvs: np.ndarray, region, page_w: int, page_h: int) -> np.ndarray:
    """Page coordinates (texels) of mesh UVs, as spine-ts 3.8-4.2 ``updateUVs`` computes them."""
    g = region.geometry()
    u, v = g.x / page_w, g.y / page_h
    ox, oy, w, h, ow, oh = g.offset_x, g.offset_y, g.width, g.height, g.original_width, g.original_height
    U, V = uvs[:, 0], uvs[:, 1]
    if g.degrees == 90:
        u -= (oh - oy - h) / page_w
        v -= (ow - ox - w) / page_h
        out = np.stack([u + V * oh / page_w, v + (1 - U) * ow / page_h], axis=1)
    elif g.degrees == 180:
        u -= (ow - ox - w) / page_w
        v -= oy / page_h
        out = np.stack([u + (1 - U) * ow / page_w, v + (1 - V) * oh / page_h], axis=1)
    elif g.degrees == 270:
        u -= oy / page_w
        v -= ox / page_h
        out = np.stack([u + (1 - V) * oh / page_w, v + U * ow / page_h], axis=1)
    else:
        u -= ox / page_w
        v -= (oh - oy - h) / page_h
        out = np.stack([u + U * ow / page_w, v + V * oh / page_h], axis=1)
    return out * (page_w, page_h)


def bilinear(page: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Bilinear samples (clamped to the edge) of ``page`` at texel coordinates, shape (N, 4) float."""
    h, w = page.shape[:2]
    x, y = points[:, 0] - 0.5, points[:, 1] - 0.5
    x0, y0 = np.floor(x).astype(int), np.floor(y).astype(int)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]

    def at(yy, xx):
        return page[np.clip(yy, 0, h - 1), np.clip(xx, 0, w - 1)].astype(float)

    return ((at(y0, x0) * (1 - fx) + at(y0, x0 + 1) * fx) * (1 - fy)
            + (at(y0 + 1, x0) * (1 - fx) + at(y0 + 1, x0 + 1) * fx) * fy)


def points_in_triangles(uvs: np.ndarray, triangles: np.ndarray, per_triangle: int, rng) -> np.ndarray:
    """Random UV points inside every triangle, vertices and edges included."""
    r = rng.random((len(triangles), per_triangle, 2))
    flip = r.sum(axis=-1) > 1
    r[flip] = 1 - r[flip]
    a, b, c = (uvs[triangles[:, i]][:, None, :] for i in range(3))
    inside = a + r[..., :1] * (b - a) + r[..., 1:] * (c - a)
    return np.concatenate([inside.reshape(-1, 2), uvs])


def _pages(atlas, root: Path) -> list[np.ndarray]:
    return [load_rgba(AtlasImages.page_path(atlas, p.name, root)) for p in atlas.pages]


def test_meshes_sample_the_same_texels(meshed, tmp_path):
    out = tmp_path / "packed"
    result = pack_project(meshed, out)
    (row,) = result.atlases
    assert row.status == "packed", row.reason
    assert row.texels_after < row.texels_before and row.by_outline > 0
    before, after = read_atlas(meshed / "demo.atlas"), read_atlas(out / "demo.atlas")
    pages_a, pages_b = _pages(before, meshed), _pages(after, out)
    doc = load_skeleton(meshed / "demo.json")
    rng = np.random.default_rng(7)
    checked = 0
    for ref in iter_attachments(doc):
        if ref.type != "mesh":
            continue
        uvs = np.asarray(ref.attachment["uvs"], float).reshape(-1, 2)
        tris = np.asarray(ref.attachment["triangles"], int).reshape(-1, 3)
        pts = points_in_triangles(uvs, tris, POINTS, rng)
        for name in image_paths(ref):  # a sequence's frames all draw with the mesh's UVs
            ra, rb = before.find(name), after.find(name)
            pa, pb = pages_a[ra.page], pages_b[rb.page]
            sa = bilinear(pa, runtime_uvs(pts, ra, pa.shape[1], pa.shape[0]))
            sb = bilinear(pb, runtime_uvs(pts, rb, pb.shape[1], pb.shape[0]))
            np.testing.assert_allclose(sb, sa, atol=1e-6, err_msg=name)
            checked += 1
    assert checked >= 3
    # a region kept by its rectangle keeps its texels exactly (cut the same, ring included)
    for outcome in (r for r in result.atlases[0].regions_by_rectangle):
        ra, rb = before.find(outcome["region"]), after.find(outcome["region"])
        np.testing.assert_array_equal(cut_region(pages_b[rb.page], rb), cut_region(pages_a[ra.page], ra))
    # skeletons are the same bytes; the input is untouched
    assert (out / "demo.json").read_bytes() == (meshed / "demo.json").read_bytes()


def test_input_untouched_output_refused_and_report(meshed, tmp_path):
    digest = _digest(meshed)
    out, report = tmp_path / "packed", tmp_path / "report.json"
    r = runner.invoke(app, ["pack", str(meshed), "--out", str(out), "--report", str(report)])
    assert r.exit_code == 0, r.output
    assert _digest(meshed) == digest
    data = json.loads(report.read_text())
    (row,) = data["atlases"]
    assert row["status"] == "packed" and row["texels_after"] < row["texels_before"]
    assert row["by_outline"] + row["by_rectangle"] == len(read_atlas(meshed / "demo.atlas").regions)
    assert row["bytes_before"] > 0 and row["bytes_after"] > 0
    again = _cli("pack", str(meshed), "--out", str(out))
    assert again.returncode != 0 and "not empty" in again.stderr and "Traceback" not in again.stderr
    assert runner.invoke(app, ["pack", str(meshed), "--out", str(out), "--overwrite"]).exit_code == 0
    inside = _cli("pack", str(meshed), "--out", str(meshed / "x"))
    assert inside.returncode != 0 and "Traceback" not in inside.stderr and len(inside.stderr.strip().splitlines()) == 1
    assert _digest(meshed) == digest


def _cli(*args: str):
    import os
    import subprocess
    import sys

    return subprocess.run([sys.executable, "-m", "spinemesh", *args], capture_output=True, text=True,
                          env=dict(os.environ, COLUMNS="200"))


def test_regions_keep_rectangles_and_say_why(tmp_path):
    """The demo as exported (region attachments): every region is drawn as a region."""
    demo = make_demo_project(tmp_path / "demo", with_images_folder=False)
    result = pack_project(demo, tmp_path / "packed")
    (row,) = result.atlases
    assert not row.by_outline  # none by outline: 0, or None where the atlas kept its layout
    assert all("region attachment" in r["reason"] or "not drawn" in r["reason"] for r in row.regions_by_rectangle) \
        or row.status == "kept"


def _jpeg_project(meshed: Path, dest: Path) -> Path:
    from PIL import Image

    project = _copy(meshed, dest, skip=(".png",))
    Image.open(meshed / "demo.png").convert("RGB").save(project / "demo.jpg")
    text = (meshed / "demo.atlas").read_text().replace("demo.png", "demo.jpg")
    (project / "demo.atlas").write_text(text)
    return project


def test_jpeg_pages_are_kept(meshed, tmp_path):
    project = _jpeg_project(meshed, tmp_path / "jpeg")
    result = pack_project(project, tmp_path / "out")
    (row,) = result.atlases
    assert row.status == "kept" and "JPEG" in row.reason
    assert (tmp_path / "out" / "demo.jpg").read_bytes() == (project / "demo.jpg").read_bytes()


def _webp_project(meshed: Path, dest: Path, lossless: bool) -> Path:
    from PIL import Image

    project = _copy(meshed, dest, skip=(".png",))
    Image.open(meshed / "demo.png").save(project / "demo.webp", lossless=lossless, quality=40)
    (project / "demo.atlas").write_text((meshed / "demo.atlas").read_text().replace("demo.png", "demo.webp"))
    return project


def test_lossy_webp_pages_are_kept_when_lossless_pages_would_be_larger(meshed, tmp_path):
    """A lossy page written back losslessly grows on disk: the atlas keeps its pages, saying why."""
    from spinemesh.pack.checks import is_lossy_webp

    lossy = _webp_project(meshed, tmp_path / "lossy", lossless=False)
    assert is_lossy_webp(lossy / "demo.webp")
    (row,) = pack_project(lossy, tmp_path / "out").atlases
    assert row.status == "kept" and "lossy WebP" in row.reason, row.reason
    assert (tmp_path / "out" / "demo.webp").read_bytes() == (lossy / "demo.webp").read_bytes()

    lossless = _webp_project(meshed, tmp_path / "lossless", lossless=True)
    assert not is_lossy_webp(lossless / "demo.webp")
    # a lossless page is no reason to keep it (the demo's page is tiny: its bytes are let grow here)
    (row,) = pack_project(lossless, tmp_path / "out2", PackOptions(larger_files=True)).atlases
    assert row.status == "packed", row.reason


def test_the_last_line_counts_atlases_packed_and_kept_and_a_kept_row_counts_no_regions(meshed, tmp_path):
    """A run that keeps an atlas does not say it packed it: the line counts each outcome, and a
    kept atlas's row shows no regions packed by outline or by rectangle (they stay where they were),
    in the table (``-``) and in the report (null, where a packed atlas has counts and the page
    texels its regions take)."""
    library = tmp_path / "library"
    library.mkdir()
    _copy(meshed, library / "meshed")
    _jpeg_project(meshed, library / "jpeg")  # kept: JPEG is never written again
    report = tmp_path / "report.json"
    r = _cli("pack", str(library), "--out", str(tmp_path / "out"), "--jobs", "1", "--larger-files",
             "--report", str(report))
    assert r.returncode == 0, r.stdout + r.stderr
    lines = r.stdout.splitlines()
    assert lines[-1].startswith("packed 1 of 2 atlases, 1 kept in its layout (the note says why); "), lines[-1]
    kept = next(line for line in lines if line.startswith("│ jpeg"))
    packed = next(line for line in lines if line.startswith("│ meshed"))
    assert [c.strip() for c in kept.split("│")[5:7]] == ["-", "-"], kept
    assert [c.strip() for c in packed.split("│")[5:7]] != ["-", "-"], packed
    rows = {row["atlas"].split("/")[0]: row for row in json.loads(report.read_text())["atlases"]}
    counts = ("by_outline", "by_rectangle", "rotated", "texels_used")
    assert rows["jpeg"]["status"] == "kept" and [rows["jpeg"][k] for k in counts] == [None] * 4, rows["jpeg"]
    assert rows["meshed"]["status"] == "packed" and rows["meshed"]["by_outline"] > 0, rows["meshed"]
    assert 0 < rows["meshed"]["texels_used"] <= rows["meshed"]["texels_after"]
    assert "footprint_texels" not in rows["meshed"]


def test_a_preview_inside_or_around_out_is_refused_in_one_line(meshed, tmp_path):
    """Its pictures would ship with the packed project (or OUT would hold the preview): refused
    before any work, as ``upgrade`` refuses it."""
    out = tmp_path / "out"
    for preview in (out / "preview", out, tmp_path):
        r = _cli("pack", str(meshed), "--out", str(out), "--preview", str(preview))
        assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
        (line,) = r.stderr.strip().splitlines()
        assert "--preview" in line and "overlaps the output folder" in line, line
        assert not out.exists()


def test_a_report_that_would_replace_a_packed_file_is_refused(meshed, tmp_path):
    """``--report OUT/demo.atlas`` replaced the packed atlas with JSON: refused in one line, the
    atlas kept, the run done in part (exit 3: the atlas is written, the report not); a report of
    its own name inside OUT is written."""
    out = tmp_path / "out"
    r = _cli("pack", str(meshed), "--out", str(out), "--report", str(out / "demo.atlas"), "--jobs", "1")
    assert r.returncode == 3 and "Traceback" not in r.stderr, r.stderr
    (line,) = r.stderr.strip().splitlines()
    assert "--report would replace a file in the output folder" in line and "demo.atlas" in line, line
    assert "--report not written" in line, line
    assert (out / "demo.atlas").read_text().lstrip()[:1] != "{"
    r = _cli("pack", str(meshed), "--out", str(tmp_path / "out2"), "--report", str(tmp_path / "out2" / "r.json"),
             "--jobs", "1")
    assert r.returncode == 0 and (tmp_path / "out2" / "r.json").read_text().startswith("{"), r.stderr


def test_progress_is_told_every_atlas_of_the_run_before_the_first(meshed, tmp_path):
    """The run's bar (atlases done of all, with the time left) needs the count up front: a library
    knows all its atlases before it packs one."""
    from spinemesh.pack.run import PackProgress, pack_library

    class Told(PackProgress):
        def __init__(self) -> None:
            self.said: list = []

        def atlases(self, count: int) -> None:
            self.said.append(("atlases", count))

        def done(self, name: str) -> None:
            self.said.append(("done", name))

    library = tmp_path / "library"
    library.mkdir()
    _copy(meshed, library / "a")
    _copy(meshed, library / "b")
    told = Told()
    pack_library(library, tmp_path / "out", PackOptions(jobs=1), progress=told)
    assert told.said == [("atlases", 2), ("done", "a/demo.atlas"), ("done", "b/demo.atlas")], told.said
    told = Told()
    pack_project(library / "a", tmp_path / "out-a", PackOptions(jobs=1), progress=told)
    assert told.said == [("atlases", 1), ("done", "demo.atlas")], told.said


def test_a_kept_atlas_says_it_re_encodes_its_pages(meshed, tmp_path):
    """An atlas kept for what packing saves has its PNG pages re-encoded where smaller: its bar
    says so after the placements, with the atlas named on the bar (the command's console)."""
    from spinemesh.cli.pack import atlas_bars
    from spinemesh.cli._app import progress_bar
    from spinemesh.pack.run import PackProgress

    class Steps(PackProgress):
        def __init__(self) -> None:
            self.said: list = []

        def step(self, name: str, what: str) -> None:
            self.said.append(what)

    steps = Steps()  # no region fits a page of 16x16 texels: kept
    (row,) = pack_project(meshed, tmp_path / "out", PackOptions(jobs=1, rules=PageRules("any", 16)),
                          progress=steps).atlases
    assert row.status == "kept", row.reason
    assert steps.said[0] == "reading pages" and steps.said[-1] == "re-encoding its pages", steps.said
    with progress_bar("pack") as bars:
        shown = atlas_bars(bars)
        shown.atlas("a/[b].atlas", 2)  # names are the project's: never markup
        shown.step("a/[b].atlas", "writing pages")
        (task,) = bars.tasks
        assert task.description == r"writing pages: a/\[b].atlas", task.description
        shown.done("a/[b].atlas")
        assert task.description.startswith("done: ") and task.completed == task.total
    with progress_bar("pack") as bars:  # several atlases: one bar counts them, each goes once done
        shown = atlas_bars(bars)
        shown.atlases(2)
        shown.atlas("a.atlas", 1)
        shown.atlas("b.atlas", 1)
        shown.done("a.atlas")
        assert [t.description for t in bars.tasks] == ["atlases", "b.atlas"]
        assert bars.tasks[0].completed == 1


def test_changes_read_as_shares_never_minus_zero():
    from spinemesh.cli.pack import share_change

    assert share_change(131_072, 65_536) == "-50%"
    assert share_change(100, 100) == "same"
    assert share_change(1_779_602, 1_778_912) == "-0.04%"  # whole percents said "-0%"
    assert share_change(77_933, 77_976) == "+0.1%"
    assert share_change(1000, 1004) == "+0.4%"


def test_broken_skeleton_pins_every_region(meshed, tmp_path):
    project = _copy(meshed, tmp_path / "broken")
    (project / "other.json").write_text('{"skeleton": {"spine": "4.2.0"}, "bones": [')
    result = pack_project(project, tmp_path / "out")
    (row,) = result.atlases
    assert not row.by_outline  # none by outline: 0, or None where the atlas kept its layout
    assert any("cannot be read" in e or "invalid JSON" in e for e in result.errors)


@pytest.mark.parametrize("tight", [False, True])
def test_footprints_never_meet_and_keep_the_padding(tight):
    import cv2

    rng = np.random.default_rng(3)
    masks = []
    for _ in range(60):
        w, h = (int(v) for v in rng.integers(5, 60, 2))
        m = np.zeros((h, w), np.uint8)
        cv2.ellipse(m, (w // 2, h // 2), (max(1, w // 2 - 1), max(1, h // 2 - 1)), 0, 0, 360, 1, -1)
        masks.append([m.astype(bool), np.rot90(m.astype(bool))])
    placements, used = fill_pages(masks, 256, 256, 2, tight=tight)
    assert all(p is not None for p in placements)
    for page in range(len(used)):
        grown = np.zeros((260, 260), np.int32)
        for cand, p in zip(masks, placements):
            if p.page != page:
                continue
            m = cand[p.orientation]
            # each footprint grown by one texel on every side: two of them may touch (gap 2 = padding) but not meet
            g = cv2.dilate(m.astype(np.uint8), np.ones((3, 3), np.uint8))
            grown[p.y + 1:p.y + 1 + m.shape[0], p.x + 1:p.x + 1 + m.shape[1]] += g
        assert grown.max() == 1


def test_interlocking_shapes_share_rectangles():
    """Two L shapes whose rectangles must overlap to fit a page their rectangles could not share."""
    ell = np.zeros((20, 20), bool)
    ell[:, :6] = True
    ell[14:, :] = True
    flipped = ell[::-1, ::-1]
    placements, used = fill_pages([[ell], [flipped]], 26, 20, 0)
    assert all(p is not None for p in placements) and len(used) == 1


def test_tightest_fit_keeps_the_used_area_small_and_within_the_limit():
    """Squares that tile a 40x40 square: the tightest fit finds it on a wide page; never over max_area."""
    squares = [[np.ones((20, 20), bool)] for _ in range(4)]
    placements, used = fill_pages(squares, 200, 200, 0, tight=True)
    assert all(p is not None for p in placements) and used == [(40, 40)]
    placements, used = fill_pages(squares, 200, 200, 0, tight=True, max_area=40 * 40 - 1)
    assert all(p is not None for p in placements) and all(w * h < 40 * 40 for w, h in used)
    assert len(used) >= 2


def test_a_fill_that_cannot_beat_the_budget_gives_up():
    squares = [[np.ones((20, 20), bool)] for _ in range(4)]
    placements, _ = fill_pages(squares, 200, 200, 0, tight=True, budget=40 * 40 - 1)
    assert any(p is None for p in placements)


def _shapes(seed: int, count: int, low: int, high: int) -> list:
    """``count`` footprints ``low`` to ``high`` texels across, half ellipses, half rectangles, as items."""
    import cv2
    from types import SimpleNamespace

    rng = np.random.default_rng(seed)
    items = []
    for _ in range(count):
        w, h = (int(v) for v in rng.integers(low, high, 2))
        m = np.zeros((h, w), np.uint8)
        if rng.random() < 0.5:
            cv2.ellipse(m, (w // 2, h // 2), (w // 2 - 1, h // 2 - 1), 0, 0, 360, 1, -1)
        else:
            m[:] = 1
        masks = [m.astype(bool), np.ascontiguousarray(np.rot90(m.astype(bool)))]
        items.append(SimpleNamespace(masks=masks, hard_masks=masks))
    return items


def test_other_orders_shrink_the_last_power_of_two_page(monkeypatch):
    """Several power-of-two pages: filled largest box first, these footprints leave a third page;
    filled by drawn texels or longest side, two pages hold them all."""
    from spinemesh.pack import atlas_pack

    items = _shapes(334, 12, 8, 120)
    _, with_orders = atlas_pack._pack_group(items, 128, 128, 128 * 128, True, 1, 3, 3 * 128 * 128)
    monkeypatch.setattr(atlas_pack, "other_orders", lambda candidates: [])
    _, default_only = atlas_pack._pack_group(items, 128, 128, 128 * 128, True, 1, 3, 3 * 128 * 128)
    assert len(default_only) == 3 and with_orders == [(128, 128), (128, 128)]


def _without_page_shapes(monkeypatch):
    """The fills as before the tightest fit ranked pages by other shapes (square pages, largest box first)."""
    from spinemesh.pack import atlas_pack

    plan = atlas_pack.fill_plan
    monkeypatch.setattr(atlas_pack, "fill_plan", lambda *args: [f for f in plan(*args)
                                                                if not (f[0] == "tightest" and f[2] is not None)])


@pytest.mark.parametrize("shape, used", [("square", [(60, 60)]), ("perimeter", [(80, 40)]), ("area", [(80, 40)])])
def test_the_tightest_fit_ranks_pages_by_the_shape_asked(shape, used):
    """Eight squares on a page at most 80 wide: by the longer side the page stays square (60x60, room for
    a ninth); by width + height or by area it takes two rows of four (80x40, fewer texels)."""
    squares = [[np.ones((20, 20), bool)] for _ in range(8)]
    placements, got = fill_pages(squares, 80, 80, 0, tight=True, shape=shape)
    assert all(p is not None for p in placements) and got == used
    with pytest.raises(ValueError, match="page shape 'round'"):
        fill_pages(squares, 80, 80, 0, tight=True, shape="round")


def test_pages_ranked_by_other_shapes_pack_smaller_and_never_larger(monkeypatch):
    """Without powers of two the tightest fit runs again with pages ranked by width + height, by area,
    and by width + height with the footprints of most texels first, after every other fill: a group
    packs on fewer texels where one of them does better (seed 145: 110x316 against 239x150), and
    never on more."""
    from spinemesh.pack import atlas_pack

    texels = {}
    for seed in (145, 121, 0, 1, 2, 3):
        items = _shapes(seed, 8, 20, 120)
        for label in ("new", "old"):
            if label == "old":
                _without_page_shapes(monkeypatch)
            placements, sizes = atlas_pack._pack_group(items, 512, 512, 512 * 512, False, 1, 1)
            assert all(p is not None for p in placements)
            texels[seed, label] = sum(w * h for w, h in sizes)
            monkeypatch.undo()
        assert texels[seed, "new"] <= texels[seed, "old"]
    assert texels[145, "new"] == 110 * 316 < texels[145, "old"] == 239 * 150
    assert texels[121, "new"] < texels[121, "old"]
    # powers of two: the rounded page ranks places first, and the plan is as before; so for large groups
    assert all(f[2] is None or f[0] == "widths" for f in atlas_pack.fill_plan(True, True, 3, 8))
    many = atlas_pack.SHAPE_FILLS_UP_TO + 1
    assert atlas_pack.fill_plan(False, True, 1, many) == [f for f in atlas_pack.fill_plan(False, True, 1, 8)
                                                         if not (f[0] == "tightest" and f[2] is not None)]


def test_footprints_larger_than_the_atlas_are_refused_before_any_fill():
    from spinemesh.pack.atlas_pack import PackRefused, _pack_group

    items = _shapes(0, 4, 20, 40)
    texels = sum(int(it.masks[0].sum()) for it in items)
    with pytest.raises(PackRefused, match=r"its regions need 1\d\d% of the page texels, so no packing"):
        _pack_group(items, 256, 256, 256 * 256, False, 0, 1, texels)
    _pack_group(items, 256, 256, 256 * 256, False, 0, 1, 256 * 256)  # room enough: packed


def test_kept_notes_say_what_the_footprints_need_and_the_next_page_holds():
    from spinemesh.pack.atlas_pack import kept_note, largest_pot_pages_below

    assert kept_note(61 * 1024 * 512 // 100 + 1, 1024 * 512, 1, 1024 * 1024, True) == \
        "its regions need 61% of the page texels; the next smaller power-of-two page holds 50%"
    assert "pages hold 88%" in kept_note(10, 4 * 1024 * 1024, 4, 1024 * 1024, True)  # three pages and a half
    # a need under what the smaller page holds: the fills tried there failed (shapes, padding)
    assert kept_note(18 * 2048 * 2048 // 100, 2048 * 2048, 1, 2048 * 2048, True) == \
        "its regions need 18% of the page texels; the next smaller power-of-two page holds 50%, and no fill " \
        "tried placed them on it"
    assert kept_note(90, 100, 1, 100, False) == \
        "its regions need 90% of the page texels, and no fill tried placed them on fewer"
    # fewer texels than the atlas has, more than the pages the rules allow hold (--max-page)
    assert kept_note(90, 100, 2, 40, False) == \
        "its regions need 90 texels, more than 2 pages of at most 40 texels hold under the page rules (--max-page, --pages)"
    assert largest_pot_pages_below(2048 * 2048, 1, 2048 * 2048) == 2048 * 1024
    assert largest_pot_pages_below(3 * 512 * 512, 2, 512 * 512) == 2 * 512 * 512
    assert largest_pot_pages_below(256, 1, 2048 * 2048) == 0


def test_a_file_that_is_no_skeleton_is_refused_in_one_line(meshed, tmp_path):
    r = _cli("pack", str(meshed / "demo.png"), "--out", str(tmp_path / "o"))
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1 and "demo.png" in r.stderr and "not a Spine skeleton" in r.stderr
    assert not (tmp_path / "o").exists()


def test_measured_padding():
    from spinemesh.atlas import RegionGeometry

    def g(x, y, w, h):
        return RegionGeometry(x, y, w, h, 0, 0, w, h, 0)

    assert measured_padding([g(0, 0, 10, 10), g(13, 0, 10, 10), g(0, 12, 10, 10)]) == 2
    assert measured_padding([g(0, 0, 10, 10), g(5, 5, 10, 10)]) == 0  # overlapping: not counted


def test_preview_shows_pages_before_and_after(meshed, tmp_path):
    import re

    r = runner.invoke(app, ["pack", str(meshed), "--out", str(tmp_path / "out"), "--preview", str(tmp_path / "pv")])
    assert r.exit_code == 0, r.output
    page = (tmp_path / "pv" / "index.html").read_text()
    assert page.count("<img") == 2 and "before" in page and "after" in page and "demo.png" in page
    # the pictures are files beside the page, named by their content, loaded when scrolled to
    assert "data:" not in page and len(page) < 10_000
    sources = re.findall(r'<img loading="lazy" src="(img/[0-9a-f]{20}\.png)"', page)
    assert len(sources) == 2, page
    for src in sources:
        assert load_rgba(tmp_path / "pv" / src)[..., 3].any()


def test_preview_opens_in_headless_chromium_with_its_pictures(meshed, tmp_path):
    from browser import run

    r = runner.invoke(app, ["pack", str(meshed), "--out", str(tmp_path / "out"), "--preview", str(tmp_path / "pv")])
    assert r.exit_code == 0, r.output
    shot = tmp_path / "shot.png"
    # the screenshot must show the pages' art (a picture that did not load leaves 70 such pixels)
    run((tmp_path / "pv" / "index.html").resolve().as_uri(), tmp_path / "chromium", f"--screenshot={shot}",
        "--window-size=1400,1800")
    rgb = load_rgba(shot)[..., :3].astype(int)
    coloured = (rgb.max(axis=2) - rgb.min(axis=2)) > 60  # the page itself is grey: art only
    assert coloured.sum() > 2000, coloured.sum()


def test_preview_on_a_phone_shows_its_pages_at_the_screens_width(meshed, tmp_path):
    """On a phone's screen (360 pixels) the page is laid out at the screen's width, its pictures
    within it: without a viewport a phone laid it out at 980 pixels and shrank it, and a page
    picture of 512 pixels widened the page past the screen."""
    from browser import DevTools

    r = runner.invoke(app, ["pack", str(meshed), "--out", str(tmp_path / "out"), "--preview", str(tmp_path / "pv")])
    assert r.exit_code == 0, r.output
    tools = DevTools(tmp_path / "profile")
    try:
        tools.as_a_phone()
        tools.call("Page.navigate", url=(tmp_path / "pv" / "index.html").resolve().as_uri())
        assert tools.wait("document.readyState === 'complete'", timeout=60)
        got = tools.layout("img")
    finally:
        tools.close()
    assert got["window"] == 360 and got["scroll"] <= 360, got
    assert len(got["boxes"]) == 2 and all(0 <= left and right <= 360 for left, right in got["boxes"]), got
    assert min(right - left for left, right in got["boxes"]) > 200, got  # and not a thumbnail


def _sampled_alike(a: Path, b: Path, skeleton: str = "demo.json", atlas: str = "demo.atlas") -> int:
    """Every mesh of ``a``'s skeleton samples the same on ``b``'s pages as on ``a``'s; how many regions checked."""
    before, after = read_atlas(a / atlas), read_atlas(b / atlas)
    pages_a, pages_b = _pages(before, a), _pages(after, b)
    rng = np.random.default_rng(11)
    checked = 0
    for ref in iter_attachments(load_skeleton(a / skeleton)):
        if ref.type != "mesh":
            continue
        uvs = np.asarray(ref.attachment["uvs"], float).reshape(-1, 2)
        tris = np.asarray(ref.attachment["triangles"], int).reshape(-1, 3)
        pts = points_in_triangles(uvs, tris, POINTS, rng)
        for name in image_paths(ref):
            ra, rb = before.find(name), after.find(name)
            pa, pb = pages_a[ra.page], pages_b[rb.page]
            np.testing.assert_allclose(bilinear(pb, runtime_uvs(pts, rb, pb.shape[1], pb.shape[0])),
                                       bilinear(pa, runtime_uvs(pts, ra, pa.shape[1], pa.shape[0])), atol=1e-6,
                                       err_msg=name)
            checked += 1
    return checked


def test_upgrade_pack_is_upgrade_then_pack(tmp_path):
    """--pack packs what the upgrade wrote (here with --repack too), skeletons unchanged."""
    demo = make_demo_project(tmp_path / "demo", with_images_folder=False)
    plain, packed = tmp_path / "plain", tmp_path / "packed"
    upgrade_project(demo, plain, Options(min_saving=None, jobs=1, repack=True))
    result = upgrade_project(demo, packed, Options(min_saving=None, jobs=1, repack=True, pack=True))
    assert not result.partial, result.errors
    (row,) = result.atlases
    assert row.status == "packed" and row.texels_after < row.texels_before
    assert (packed / "demo.json").read_bytes() == (plain / "demo.json").read_bytes()
    assert _sampled_alike(plain, packed) >= 3
    # pages the packed atlas does not name are gone; every page it names is there
    named = {p.name for p in read_atlas(packed / "demo.atlas").pages}
    assert {p.name for p in packed.glob("*.png")} == named
    report = tmp_path / "r.json"
    r = runner.invoke(app, ["upgrade", str(demo), "--out", str(tmp_path / "cli"), "--pack", "--min-saving", "0",
                            "--report", str(report), "--jobs", "1"])
    assert r.exit_code == 0, r.output
    assert json.loads(report.read_text())["atlases"][0]["status"] == "packed"


def test_palette_pages_stay_palette_pages(meshed, tmp_path):
    """A page a quantiser wrote as a palette PNG is written back as one, texel for texel."""
    from PIL import Image

    project = _copy(meshed, tmp_path / "palette")
    Image.open(meshed / "demo.png").quantize(colors=64, method=Image.Quantize.FASTOCTREE).save(project / "demo.png")
    assert Image.open(project / "demo.png").mode == "P"
    result = pack_project(project, tmp_path / "out")
    assert result.atlases[0].status == "packed"
    assert Image.open(tmp_path / "out" / "demo.png").mode == "P"
    assert _sampled_alike(project, tmp_path / "out") >= 3


def test_the_sampling_check_catches_a_footprint_one_texel_short(meshed, tmp_path, monkeypatch):
    """Negative control: footprints eroded by one texel fail pack's own proof (the atlas is kept),
    and, written without the proof, this file's sampling check."""
    import cv2

    from spinemesh.pack import outlines, run

    real = outlines.sampled_texels

    def short(*args):
        return cv2.erode(real(*args).astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)

    monkeypatch.setattr(outlines, "sampled_texels", short)
    result = pack_project(meshed, tmp_path / "proven")
    assert result.atlases[0].status == "kept" and "failed the proof" in result.atlases[0].reason
    assert (tmp_path / "proven" / "demo.png").read_bytes() == (meshed / "demo.png").read_bytes()
    monkeypatch.setattr(run, "prove_written", lambda *args: 0)
    result = pack_project(meshed, tmp_path / "out")
    assert result.atlases[0].status == "packed"
    with pytest.raises(AssertionError):
        _sampled_alike(meshed, tmp_path / "out")


def test_a_library_is_packed_project_by_project(meshed, tmp_path):
    import shutil

    from spinemesh.pack.run import pack_library

    library = tmp_path / "library"
    for name in ("a", "b/c"):
        shutil.copytree(meshed, library / name, ignore=shutil.ignore_patterns(".*"))
    result = pack_library(library, tmp_path / "out")
    assert sorted(a.atlas for a in result.atlases) == ["a/demo.atlas", "b/c/demo.atlas"]
    assert all(a.status == "packed" for a in result.atlases)
    assert _sampled_alike(library / "b" / "c", tmp_path / "out" / "b" / "c") >= 3


def test_hard_texels_are_those_near_art_in_the_footprint():
    """Hard: within one texel (8-neighbourhood) of a footprint texel that is not all zero; art outside
    the footprint does not count; a texel of alpha 0 but colour (straight alpha) is art."""
    from spinemesh.pack.outlines import hard_texels

    core = np.zeros((12, 12), bool)
    core[1:11, 1:11] = True
    texels = np.zeros((12, 12, 4), np.uint8)
    texels[5, 5] = (10, 20, 30, 255)
    texels[8, 2] = (7, 0, 0, 0)       # colour under alpha 0: not all zero
    texels[0, 0] = (255, 255, 255, 255)  # outside the footprint
    hard = hard_texels(core, texels)
    expected = np.zeros((12, 12), bool)
    expected[4:7, 4:7] = True
    expected[7:10, 1:4] = True
    expected &= core
    assert (hard == expected).all()
    assert not (hard & ~core).any()


def _ring_footprints(count: int, side: int, art: int) -> tuple[list, list]:
    """``count`` square footprints ``side`` texels across whose centre ``art`` texels (plus the one-texel
    reach) are hard and the ring around it soft: ``(candidates, hard)`` for :func:`fill_pages`."""
    masks, hards = [], []
    for _ in range(count):
        m = np.ones((side, side), bool)
        h = np.zeros_like(m)
        lo = (side - art) // 2 - 1
        h[lo:lo + art + 2, lo:lo + art + 2] = True
        masks.append([m])
        hards.append([h])
    return masks, hards


@pytest.mark.parametrize("tight", [False, True])
def test_soft_texels_overlap_and_hard_ones_never_meet(tight):
    """Footprints whose soft rings overlap fit a page their whole masks could not share; hard texels
    keep the padding from anything of another footprint."""
    import cv2

    masks, hards = _ring_footprints(4, 20, 6)
    # all hard, two 20x20 footprints and the padding of 2 between them take 42 texels: one a page
    placements, used = fill_pages(masks, 40, 40, 2, tight=tight)
    assert len(used) == 4
    # 6 soft texels a side: 16 texels apart (the hard centre 2 from the other's edge), 2x2 on a page
    placements, used = fill_pages(masks, 40, 40, 2, tight=tight, hard=hards)
    assert all(p is not None for p in placements) and len(used) == 1
    full = np.zeros((40, 40), np.int32)
    for cand, p in zip(masks, placements):
        full[p.y:p.y + 20, p.x:p.x + 20] += cand[p.orientation]
    assert full.max() > 1  # they do overlap
    for i, (hard, p) in enumerate(zip(hards, placements)):
        grown = np.zeros((44, 44), np.uint8)
        grown[p.y:p.y + 24, p.x:p.x + 24] = cv2.dilate(np.pad(hard[0], 2).astype(np.uint8), np.ones((5, 5), np.uint8))
        for j, (cand, q) in enumerate(zip(masks, placements)):
            if j != i:
                assert not grown[q.y + 2:q.y + 22, q.x + 2:q.x + 22][cand[0]].any()


def test_packed_soft_footprints_overlap_and_sample_the_original_texels():
    """Two meshed regions of art in the middle of transparent images: packed, their footprints
    overlap where both are soft, and the new page holds, under each footprint, the texels the
    original page held there."""
    from spinemesh.atlas import parse_atlas
    from spinemesh.pack.atlas_pack import pack_atlas
    from spinemesh.pack.outlines import content_box, footprint, window_texels
    from spinemesh.pack.uses import MeshUse, RegionUses

    text = ("page.png\nsize: 80,40\nformat: RGBA8888\nfilter: Linear,Linear\nrepeat: none\n"
            "a\n  rotate: false\n  xy: 2, 2\n  size: 36, 36\n  orig: 36, 36\n  offset: 0, 0\n  index: -1\n"
            "b\n  rotate: false\n  xy: 40, 2\n  size: 36, 36\n  orig: 36, 36\n  offset: 0, 0\n  index: -1\n")
    atlas = parse_atlas(text, "test.atlas")
    page = np.zeros((40, 80, 4), np.uint8)
    rng = np.random.default_rng(5)
    for x in (2, 40):  # art in the middle 12x12 of each 36x36 image, nothing around it
        page[14:26, x + 12:x + 24] = rng.integers(1, 256, (12, 12, 4), dtype=np.uint8)
    quad = MeshUse(np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float), np.array([[0, 1, 2], [0, 2, 3]]), True)
    uses = {"a": RegionUses(meshes=[quad]), "b": RegionUses(meshes=[quad])}
    packed = pack_atlas(atlas, [page], uses, rotate=False)
    (new_page,) = packed.pages.values()
    # two 38x38 footprints (36x36 images and the ring) side by side take 76 texels; padding 2 is the
    # two rings, so their hard centres may come within a texel of the other footprint
    assert packed.padding == 2 and new_page.shape[1] < 2 * 38
    placed = []
    for before, after in zip(atlas.regions, packed.atlas.regions):
        g0, g1 = before.geometry(), after.geometry()
        fp0, fp1 = footprint(g0, uses[before.name]), footprint(g1, uses[after.name])
        assert fp0.core.shape == fp1.core.shape and (fp0.core == fp1.core).all()
        old, new = window_texels(page, g0, fp0.window), window_texels(new_page, g1, fp1.window)
        assert (old[fp0.core] == new[fp1.core]).all()
        cx0, cy0, _, _ = content_box(g1)  # stored upright: page texel = (x, y) + window texel - content corner
        placed.append((g1.x + fp1.window[0] - cx0, g1.y + fp1.window[1] - cy0, fp1.core))
    (ax, ay, a), (bx, by, b) = placed
    on_a = np.zeros(new_page.shape[:2], bool)
    on_a[ay:ay + a.shape[0], ax:ax + a.shape[1]] = a
    on_b = np.zeros_like(on_a)
    on_b[by:by + b.shape[0], bx:bx + b.shape[1]] = b
    assert (on_a & on_b).any()  # the footprints overlap ...
    assert not new_page[on_a & on_b].any()  # ... where the page holds zeros


def test_upgrade_of_one_skeleton_file_packs_for_the_other_skeletons_of_its_folder(tmp_path):
    """``upgrade demo.json --pack`` writes demo.json and the atlas it shares with demo-binary.skel,
    which a game still loads with it, drawing regions: those keep their rectangles (packing by
    demo.json's new meshes alone would crop them under demo-binary.skel's region attachments)."""
    demo = make_demo_project(tmp_path / "demo", with_images_folder=False)
    out = tmp_path / "out"
    result = upgrade_project(demo / "demo.json", out, Options(min_saving=None, jobs=1, pack=True))
    assert not (out / "demo-binary.skel").exists()
    (row,) = result.atlases
    drawn = {p for ref in iter_attachments(load_skeleton(demo / "demo-binary.skel")) if ref.type == "region"
             for p in image_paths(ref)}
    assert drawn and not row.by_outline, row.regions_by_rectangle
    alone = tmp_path / "alone"  # without the other skeleton, the same upgrade packs by outline
    alone.mkdir()
    for name in ("demo.json", "demo.atlas", "demo.png"):
        (alone / name).write_bytes((demo / name).read_bytes())
    (row,) = upgrade_project(alone / "demo.json", tmp_path / "out-alone", Options(min_saving=None, jobs=1,
                                                                                 pack=True)).atlases
    assert row.by_outline > 0
