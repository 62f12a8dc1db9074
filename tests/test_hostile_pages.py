"""Hostile pages: atlases and page images that would make ``pack`` and ``upgrade --pack`` write wrong texels.

Every case is a copy of the demo project (drawn by our own code, :mod:`spinemesh.demo`) upgraded to
meshes, then changed the way an unlucky export or a hostile user would: AVIF pages, a ``size:``
line that disagrees with its image, one image named by two pages, two atlases of one stem under
``--repack``, packed texels or geometry gone wrong. What is promised (docs/safety.md, "Pages
that pack writes"): a page is written only when its bytes decode to the texels meant, an atlas
only when every texel drawing it reads is the original's; otherwise it is kept as it was, with
the reason, and the run goes on.
"""

from __future__ import annotations

import copy
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from spinemesh.atlas import read_atlas
from spinemesh.images.decode import load_rgba
from spinemesh.pack.atlas_pack import PackRefused
from spinemesh.pack.page_files import encode_page
from spinemesh.pack.run import pack_library, pack_project

REPO = Path(__file__).resolve().parents[1]


def _copy(meshed: Path, dest: Path) -> Path:
    shutil.copytree(meshed, dest, ignore=shutil.ignore_patterns(".*"))
    return dest


def _files(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file() and not p.name.startswith(".")}


def _cli(*args, cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(REPO), "COLUMNS": "200", "NO_COLOR": "1"}
    return subprocess.run([sys.executable, "-m", "spinemesh", *map(str, args)], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=120)


# --- pages come back texel for texel -----------------------------------------------------------

@pytest.mark.parametrize("ext", [".png", ".webp"])
def test_lossless_pages_decode_to_the_texels_written(ext):
    rng = np.random.default_rng(3)
    rgba = rng.integers(0, 256, (37, 53, 4), dtype=np.uint8)
    rgba[rgba[..., 3] == 0] = 0
    page = encode_page(rgba, "p" + ext)
    np.testing.assert_array_equal(page.texels, rgba)
    np.testing.assert_array_equal(load_rgba_bytes(page.data), rgba)


def load_rgba_bytes(data: bytes) -> np.ndarray:
    from spinemesh.images.decode import decode_rgba

    return decode_rgba(data)


def test_avif_pages_that_do_not_come_back_are_refused():
    """Pillow's AVIF writer ignores ``lossless=True``: such a page is refused, never written lossy."""
    from PIL import features

    if not features.check("avif"):
        pytest.skip("this Pillow has no AVIF")
    rgba = np.random.default_rng(4).integers(0, 256, (32, 32, 4), dtype=np.uint8)
    with pytest.raises(PackRefused, match="texel for texel"):
        encode_page(rgba, "p.avif")


def test_an_avif_atlas_is_kept_as_it_was(meshed, tmp_path):
    from PIL import Image, features

    if not features.check("avif"):
        pytest.skip("this Pillow has no AVIF")
    project = _copy(meshed, tmp_path / "avif")
    Image.open(project / "demo.png").save(project / "demo.avif", quality=100)
    (project / "demo.png").unlink()
    atlas = project / "demo.atlas"
    atlas.write_text(atlas.read_text().replace("demo.png", "demo.avif"))
    result = pack_project(project, tmp_path / "out")
    (row,) = result.atlases
    assert row.status == "kept" and "AVIF" in row.reason and "texel for texel" in row.reason
    assert (tmp_path / "out" / "demo.avif").read_bytes() == (project / "demo.avif").read_bytes()
    assert (tmp_path / "out" / "demo.atlas").read_bytes() == atlas.read_bytes()


# --- pages against their images, and against each other -------------------------------------------

def _resize_page(project: Path, how: str) -> None:
    from PIL import Image

    page = project / "demo.png"
    im = Image.open(page).convert("RGBA")
    if how == "twice":
        im = im.resize((im.width * 2, im.height * 2), Image.NEAREST)
    elif how == "half":
        im = im.resize((im.width // 2, im.height // 2), Image.NEAREST)
    else:  # padded larger: the same texels, more of them right and below
        padded = Image.new("RGBA", (im.width + 64, im.height + 32))
        padded.paste(im, (0, 0))
        im = padded
    im.save(page)


@pytest.mark.parametrize("how", ["twice", "half", "padded"])
def test_a_size_line_that_disagrees_with_its_image_is_not_packed(meshed, tmp_path, how):
    project = _copy(meshed, tmp_path / how)
    _resize_page(project, how)
    before = _files(project)
    result = pack_project(project, tmp_path / "out")
    (row,) = result.atlases
    assert row.status == "kept" and "'demo.png'" in row.reason and "size line" in row.reason, row.reason
    assert _files(tmp_path / "out") == before and _files(project) == before


def test_upgrade_warns_of_a_page_runtimes_draw_differently(meshed, tmp_path):
    """spine-c scales UVs by the size line, libGDX by the texture: a warning naming atlas and page."""
    project = _copy(meshed, tmp_path / "padded")
    _resize_page(project, "padded")
    report = tmp_path / "report.json"
    r = _cli("upgrade", project, "--out", tmp_path / "out", "--pack", "--jobs", "1", "--report", report,
             cwd=tmp_path)
    assert "Traceback" not in r.stdout + r.stderr
    assert r.returncode == 0, r.stdout + r.stderr
    warning = [line for line in r.stderr.splitlines() if line.startswith("warning:") and "size line" in line]
    assert warning and "demo.atlas" in warning[0] and "'demo.png'" in warning[0], r.stderr
    data = json.loads(report.read_text())
    assert any("demo.atlas" in w and "size line" in w for w in data["warnings"])
    assert data["atlases"][0]["status"] == "kept"
    assert data["atlas_totals"]["bytes_after"] == data["atlases"][0]["bytes_after"] == data["atlases"][0]["bytes_before"]
    r = _cli("info", project, cwd=tmp_path)  # the same rule in every command
    assert r.returncode == 0 and "Traceback" not in r.stdout + r.stderr, r.stdout + r.stderr
    assert any(line.startswith("warning:") and "'demo.png'" in line for line in r.stderr.splitlines()), r.stderr


def _named_twice(project: Path, fields: str) -> None:
    """The regions from ``demo-arm`` on moved under a second page naming the same image."""
    atlas = project / "demo.atlas"
    text = atlas.read_text()
    atlas.write_text(text.replace("demo-arm\n", f"\ndemo.png\n\tsize: 512, 256\n\tfilter: {fields}\ndemo-arm\n"))


@pytest.mark.parametrize("fields", ["Nearest, Nearest", "Linear, Linear"])
def test_a_page_named_twice_is_kept(meshed, tmp_path, fields):
    project = _copy(meshed, tmp_path / "twice")
    _named_twice(project, fields)
    before = _files(project)
    result = pack_project(project, tmp_path / "out")
    (row,) = result.atlases
    assert row.status == "kept" and "names the image of the page at line 1 again" in row.reason, row.reason
    assert _files(tmp_path / "out") == before


def test_a_library_with_one_hostile_project_packs_the_others(meshed, tmp_path):
    library = tmp_path / "library"
    _copy(meshed, library / "good")
    _named_twice(_copy(meshed, library / "twice"), "Nearest, Nearest")
    _resize_page(_copy(meshed, library / "padded"), "padded")
    result = pack_library(library, tmp_path / "out")
    status = {a.atlas: a.status for a in result.atlases}
    assert status == {"good/demo.atlas": "packed", "twice/demo.atlas": "kept", "padded/demo.atlas": "kept"}
    r = _cli("pack", library, "--out", tmp_path / "cli", cwd=tmp_path)
    assert r.returncode == 0 and "Traceback" not in r.stdout + r.stderr, r.stdout + r.stderr


# --- the proof ---------------------------------------------------------------------------------------

def test_triangle_reads_are_the_texels_within_one_texel_on_both_axes():
    """Against shapely: a texel is read when the triangle meets the open square of side 2 around its centre."""
    from shapely.geometry import Polygon, box

    from spinemesh.pack.proof import triangle_reads

    rng = np.random.default_rng(5)
    for _ in range(40):
        pts = rng.uniform(0, 12, (3, 2))
        if rng.random() < 0.3:
            pts = np.round(pts * 2) / 2  # on texel edges and centres: the boundary cases
        tri = Polygon(pts)
        if tri.area < 1e-6:
            continue
        (x0, y0), mask = triangle_reads(pts, np.array([[0, 1, 2]]))
        for j in range(mask.shape[0]):
            for i in range(mask.shape[1]):
                cx, cy = x0 + i + 0.5, y0 + j + 0.5
                expected = tri.intersection(box(cx - 1, cy - 1, cx + 1, cy + 1)).area > 1e-12
                assert mask[j, i] == expected, (pts.tolist(), i + x0, j + y0)


def test_the_proof_catches_a_texel_or_a_region_gone_wrong(meshed, tmp_path, monkeypatch):
    """Packed texels changed under a mesh, or a region moved by one texel: the atlas is kept."""
    from spinemesh.pack import atlas_pack, run
    from spinemesh.pack.proof import ProofFailed, prove_packed
    from spinemesh.pack.uses import collect_uses
    from spinemesh.project import find_project

    out = tmp_path / "packed"
    assert pack_project(meshed, out).atlases[0].status == "packed"
    before, after = read_atlas(meshed / "demo.atlas"), read_atlas(out / "demo.atlas")
    uses = collect_uses(find_project(meshed)).regions[meshed / "demo.atlas"]
    pages_a, pages_b = [load_rgba(meshed / "demo.png")], [load_rgba(out / "demo.png")]
    assert prove_packed(before, pages_a, after, pages_b, uses) > 10_000
    moved = copy.deepcopy(after)
    bounds = next(e for e in moved.find("demo-head").entries if e.key == "bounds")
    bounds.values[0] = str(int(bounds.values[0]) + 1)  # one texel to the right
    with pytest.raises(ProofFailed, match="demo-head"):
        prove_packed(before, pages_a, moved, pages_b, uses)
    # a texel under a mesh changed by the packer: pack keeps the atlas
    real = atlas_pack.compose

    def one_texel_off(*args, **kwargs):
        packed = real(*args, **kwargs)
        page = next(iter(packed.pages.values()))
        y, x = np.argwhere(page[..., 3] > 0)[len(np.argwhere(page[..., 3] > 0)) // 2]
        page[y, x, 0] ^= 1
        return packed

    monkeypatch.setattr(run, "compose", one_texel_off)
    result = pack_project(meshed, tmp_path / "wrong")
    assert result.atlases[0].status == "kept" and "failed the proof" in result.atlases[0].reason
    assert (tmp_path / "wrong" / "demo.png").read_bytes() == (meshed / "demo.png").read_bytes()


def test_uvs_far_outside_their_image_are_not_proven_nor_allocated(meshed, tmp_path):
    """A mesh whose UVs reach 100,000 images away: the atlas is kept, in a second, without a traceback."""
    project = _copy(meshed, tmp_path / "far")
    doc = json.loads((project / "demo.json").read_text())
    (project / "demo-binary.skel").unlink()
    meshes = [att for slots in doc["skins"][0]["attachments"].values() for att in slots.values()
              if att.get("type") == "mesh"]
    meshes[0]["uvs"] = [v * 100_000 for v in meshes[0]["uvs"]]
    (project / "demo.json").write_text(json.dumps(doc))
    result = pack_project(project, tmp_path / "out")
    (row,) = result.atlases
    assert row.status == "kept" and "beyond the limits of an image" in row.reason, row.reason


# --- --repack: new pages never share a name ---------------------------------------------------------

def test_atlases_of_one_stem_repack_onto_pages_of_their_own(tmp_path):
    """``x.atlas`` and ``x.2.atlas`` in one folder: each one's untrimmed frames on its own new page."""
    from spinemesh.demo import demo_images, pack_atlas
    from spinemesh.files.atomic import atomic_write_png, atomic_write_text
    from spinemesh.images.regions import cut_region
    from spinemesh.images.sources import AtlasImages
    from spinemesh.upgrade.repack import write_repacked_atlas

    images = demo_images()
    project, out = tmp_path / "project", tmp_path / "out"
    frames = {f"demo-spark/frame{i}" for i in (1, 2, 3)}
    for stem, flip in (("x", False), ("x.2", True)):
        text, page = pack_atlas(images, f"{stem}.png", rotate={"demo-spark/frame2"})
        page = np.ascontiguousarray(page[..., [2, 1, 0, 3]]) if flip else page  # other texels
        atomic_write_text(project / f"{stem}.atlas", text)
        atomic_write_png(project / f"{stem}.png", page)
    written = []
    for stem in ("x", "x.2"):
        written += write_repacked_atlas(project / f"{stem}.atlas", frames, project, out)
    assert len(set(written)) == len(written) == 2, written
    for stem in ("x", "x.2"):
        a, b = read_atlas(project / f"{stem}.atlas"), read_atlas(out / f"{stem}.atlas")
        for name in frames:
            ra, rb = a.find(name), b.find(name)
            pa = load_rgba(AtlasImages.page_path(a, a.pages[ra.page].name, project))
            pb = load_rgba(AtlasImages.page_path(b, b.pages[rb.page].name, out))
            np.testing.assert_array_equal(cut_region(pb, rb), cut_region(pa, ra), err_msg=f"{stem}: {name}")


# --- nothing to pack ----------------------------------------------------------------------------

def test_a_project_without_a_usable_atlas_is_refused_in_one_line_before_anything_is_written(meshed, tmp_path):
    """Pages not shipped (an export whose images were left out), or no atlas at all: ``pack``
    exits 2 with one line naming the project and the page, and writes no OUT."""
    project = _copy(meshed, tmp_path / "no-page")
    (project / "demo.png").unlink()
    r = _cli("pack", project, "--out", tmp_path / "out", cwd=tmp_path)
    assert r.returncode == 2 and "Traceback" not in r.stdout + r.stderr, r.stdout + r.stderr
    (line,) = r.stderr.strip().splitlines()
    assert line.startswith(f"error: {project}: no atlas to pack: ") and "demo.atlas" in line and "'demo.png'" in line
    assert not (tmp_path / "out").exists()
    (project / "demo.atlas").unlink()
    r = _cli("pack", project, "--out", tmp_path / "out", cwd=tmp_path)
    no_atlas_file = "no atlas to pack: no atlas file (.atlas) in it nor in a folder below it"
    assert r.returncode == 2 and r.stderr.strip() == f"error: {project}: {no_atlas_file}", r.stdout + r.stderr
    assert not (tmp_path / "out").exists()
    # an empty folder, or one of empty folders, is one project without an atlas, not a folder of
    # projects none of which has one
    (tmp_path / "empty").mkdir()
    (tmp_path / "empty-folders" / "a" / "b").mkdir(parents=True)
    for empty in (tmp_path / "empty", tmp_path / "empty-folders"):
        r = _cli("pack", empty, "--out", tmp_path / "out", cwd=tmp_path)
        assert r.returncode == 2 and r.stderr.strip() == f"error: {empty}: {no_atlas_file}", r.stdout + r.stderr
        assert not (tmp_path / "out").exists()


def test_pack_prints_its_errors_as_error_lines_on_stderr(meshed, tmp_path):
    """A library whose second project ships no page: the first is packed, the second is named on
    stderr with ``error:`` (as upgrade prints them); a library with no usable atlas at all exits 2
    with one line naming it and the first atlas left out, and writes no OUT (as for one project)."""
    library = tmp_path / "library"
    _copy(meshed, library / "good")
    (_copy(meshed, library / "no-page") / "demo.png").unlink()
    r = _cli("pack", library, "--out", tmp_path / "out", cwd=tmp_path)
    assert r.returncode == 3 and "Traceback" not in r.stdout + r.stderr, r.stdout + r.stderr
    (line,) = r.stderr.strip().splitlines()
    assert line.startswith("error: ") and "no-page" in line and "'demo.png'" in line, r.stderr
    (library / "good" / "demo.png").unlink()
    r = _cli("pack", library, "--out", tmp_path / "out2", cwd=tmp_path)
    assert r.returncode == 2 and "Traceback" not in r.stdout + r.stderr, r.stdout + r.stderr
    (line,) = r.stderr.strip().splitlines()
    assert line.startswith(f"error: {library}: no atlas to pack in any of its projects: ") and "'demo.png'" in line
    assert line.endswith("(and 1 more atlas left out)"), line
    assert not (tmp_path / "out2").exists()


def test_upgrade_pack_says_a_page_the_export_lacks_once(tmp_path):
    """The atlas whose page is not shipped is left out by the upgrade and then, copied to OUT, by
    its packing: one error line naming the project's atlas, none naming the copy in OUT."""
    from spinemesh.demo import make_demo_project

    project = make_demo_project(tmp_path / "demo")
    (project / "demo.png").unlink()
    report = tmp_path / "report.json"
    r = _cli("upgrade", project, "--out", tmp_path / "out", "--pack", "--jobs", "1", "--report", report,
             cwd=tmp_path)
    assert r.returncode in (0, 3) and "Traceback" not in r.stdout + r.stderr, r.stdout + r.stderr
    said = [line for line in r.stderr.splitlines() if "'demo.png' not found" in line]
    assert said == [f"error: {project / 'demo.atlas'}:1: page image 'demo.png' not found; atlas not used"], r.stderr
    # the report names the project's files from its name (the same bytes from any folder)
    assert [e for e in json.loads(report.read_text())["errors"] if "demo.png" in e] == [
        said[0][len("error: "):].replace(str(project), "demo")]


def test_upgrade_pack_says_a_skeleton_it_cannot_read_once(tmp_path):
    """A skeleton of the project that cannot be read is said not read by the upgrade, and not
    again by its packing (which reads the skeletons written, and those of the folder not given)."""
    from spinemesh.demo import make_demo_project

    project = make_demo_project(tmp_path / "demo")
    (project / "broken.json").write_text('{"skeleton": {"spine": "4.1.00"}, "bones": [ broken')
    report = tmp_path / "report.json"
    r = _cli("upgrade", project, "--out", tmp_path / "out", "--pack", "--jobs", "1", "--report", report,
             cwd=tmp_path)
    assert r.returncode == 3 and "Traceback" not in r.stdout + r.stderr, r.stdout + r.stderr
    assert [e for e in json.loads(report.read_text())["errors"] if "broken.json" in e] == [
        "demo/broken.json:1: invalid JSON: Expecting value (column 46)"]  # named from the project
