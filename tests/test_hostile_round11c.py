"""Hostile round eleven, third part: what ``pack`` and ``upgrade --pack`` may get wrong.

``pack`` rewrites the page images every runtime samples. Each case is the demo project upgraded to
meshes (``meshed``, made by our own code), then given what an export or a studio's folder may
hold: pages shared across atlases, atlases that disagree with their pages, page formats that are
already as small as they get. What is promised (docs/safety.md, "Pages that pack and upgrade
--pack write"): packing one atlas never breaks another, a page is written only when it comes back
texel for texel, and an atlas's files never grow.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from test_hostile_pages import _copy

REPO = Path(__file__).resolve().parents[1]


def _cli(*args, cwd: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(REPO), "COLUMNS": "250", "NO_COLOR": "1"}
    r = subprocess.run([sys.executable, "-m", "spinemesh", *map(str, args)], cwd=cwd, env=env,
                       capture_output=True, text=True, timeout=120, check=False)
    assert "Traceback" not in r.stdout + r.stderr, r.stderr[-3000:]
    return r


def _rows(report: Path) -> dict[str, dict]:
    return {row["atlas"]: row for row in json.loads(report.read_text())["atlases"]}


# --- pages shared across atlases --------------------------------------------------------------

#: A second atlas naming the demo's page that spinemesh leaves out but a runtime loads: a page
#: ``scale:`` beyond spinemesh's limits (the runtimes do not read it), and one naming a page the
#: export lacks besides (a runtime fails on it; the atlas still names the page).
UNUSED_TWINS = {
    "scale": lambda text: text.replace("filter: Linear, Linear", "filter: Linear, Linear\n\tscale: 5000", 1),
    "missing page": lambda text: text + "\nmissing.png\n\tsize: 64, 64\nzz\n\tbounds: 0, 0, 8, 8\n",
}


@pytest.mark.parametrize("twin", list(UNUSED_TWINS))
@pytest.mark.parametrize("command", ["pack", "upgrade"])
def test_a_page_an_unused_atlas_names_is_never_packed_for_another(meshed, tmp_path, twin, command):
    """``b.atlas`` names ``demo.png`` as ``demo.atlas`` does, but spinemesh leaves it out (its line
    says why): packed for ``demo.atlas``, the page drew other texels under ``b.atlas`` (the official
    4.2 runtime loads it, scale and all), with exit 3 for ``b.atlas``'s line alone."""
    project = _copy(meshed, tmp_path / "p")
    (project / "b.atlas").write_text(UNUSED_TWINS[twin]((project / "demo.atlas").read_text()))
    extra = ["--pack"] if command == "upgrade" else []
    r = _cli(command, project, "--out", tmp_path / "o", "--report", tmp_path / "r.json", "-j", "1", *extra,
             cwd=tmp_path)
    assert r.returncode == 3, r.stderr
    assert "b.atlas" in r.stderr and "atlas not used" in r.stderr
    row = _rows(tmp_path / "r.json")["demo.atlas"]
    assert row["status"] == "kept" and "also named by b.atlas" in row["reason"], row
    assert (tmp_path / "o" / "demo.png").read_bytes() == (project / "demo.png").read_bytes()
    assert (tmp_path / "o" / "b.atlas").read_bytes() == (project / "b.atlas").read_bytes()


def test_the_unused_atlas_draws_as_before_in_the_runtime(meshed, tmp_path, spine_runtime):
    """The proof behind the case above: ``b.atlas`` (page ``scale: 5000``) loads in the official
    4.2 runtime and draws the demo; after ``pack`` it draws the same pixels (it drew 23,056 of them
    otherwise, the page packed for ``demo.atlas``)."""
    from runtime_tool import render, render_difference

    project = _copy(meshed, tmp_path / "p")
    (project / "b.atlas").write_text(UNUSED_TWINS["scale"]((project / "demo.atlas").read_text()))
    _cli("pack", project, "--out", tmp_path / "o", "-j", "1", cwd=tmp_path)
    before = render(spine_runtime, project / "b.atlas", project / "demo.json", None, "0", tmp_path / "r" / "a")
    after = render(spine_runtime, tmp_path / "o" / "b.atlas", tmp_path / "o" / "demo.json", None, "0",
                   tmp_path / "r" / "b", frame_from=tmp_path / "r" / "a.frame.json")
    assert before and len(before) == len(after)
    for a, b in zip(before, after):
        diff = render_difference(a, b)
        assert diff["off"] == 0 and diff["lost"] == 0, diff


def test_an_atlas_that_cannot_be_read_keeps_every_page(meshed, tmp_path):
    """An atlas beyond the size limit (or unreadable) may name any page: none is packed."""
    from spinemesh.pack.run import pages_named_by_unused
    from spinemesh.project import find_project, project_atlases

    project = _copy(meshed, tmp_path / "p")
    big = project / "big.atlas"
    with open(big, "wb") as f:
        f.truncate(256 * 1024 * 1024 + 1)  # sparse: one byte over MAX_DOCUMENT_BYTES
    (project / "other.atlas").write_text("demo.png\nsize: 512, 256\nscale: 1e9\n")
    proj = find_project(project)
    pages = {f.resolve() for a in project_atlases(proj).values() for f in [project / a.pages[0].name]}
    found = pages_named_by_unused(proj, pages)
    assert set(found) == pages and found[(project / "demo.png").resolve()] in (big, project / "other.atlas")
    big.unlink()
    proj = find_project(project)
    project_atlases(proj)
    assert pages_named_by_unused(proj, pages) == {(project / "demo.png").resolve(): project / "other.atlas"}


# --- what the table and the report say of an atlas written as it was ---------------------------

def _jpeg_twin(project: Path) -> None:
    from PIL import Image

    Image.open(project / "demo.png").convert("RGB").save(project / "other.jpg", quality=90)
    (project / "other.atlas").write_text((project / "demo.atlas").read_text().replace("demo.png", "other.jpg", 1))


def _broken_twin(project: Path) -> None:
    """A second atlas whose page's header reads but whose image data does not decode."""
    shutil.copy(project / "demo.png", project / "other.png")
    (project / "other.atlas").write_text((project / "demo.atlas").read_text().replace("demo.png", "other.png", 1))
    data = bytearray((project / "other.png").read_bytes())
    at = data.find(b"IDAT")
    data[at + 20:at + 60] = bytes(40)
    (project / "other.png").write_bytes(bytes(data))


@pytest.mark.parametrize(("twin", "status", "code"), [(_jpeg_twin, "kept", 0), (_broken_twin, "failed", 3)],
                         ids=["jpeg page kept", "page that does not decode"])
@pytest.mark.parametrize("jobs", ["1", "2"])
def test_an_atlas_written_as_it_was_counts_its_texels_and_bytes(meshed, tmp_path, twin, status, code, jobs):
    """An atlas kept before its pages are decoded (a JPEG page) or failed was counted as 0 page
    texels: the total said ``131,072 -> 65,536 (-50%)`` for a project whose pages went from
    262,144 to 196,608 texels (-25%). Its texels come from its pages' headers, its bytes are its
    files' on disk, and the totals are the rows' sums."""
    from PIL import Image

    project = _copy(meshed, tmp_path / "p")
    twin(project)
    r = _cli("pack", project, "--out", tmp_path / "o", "--report", tmp_path / "r.json", "-j", jobs, cwd=tmp_path)
    assert r.returncode == code, r.stderr
    report = json.loads((tmp_path / "r.json").read_text())
    row = {a["atlas"]: a for a in report["atlases"]}["other.atlas"]
    page = next(project.glob("other.*g"))
    with Image.open(page) as im:
        texels = im.width * im.height
    on_disk = page.stat().st_size + (project / "other.atlas").stat().st_size
    assert row["status"] == status
    assert (row["texels_before"], row["texels_after"], row["bytes_before"], row["bytes_after"]) == \
        (texels, texels, on_disk, on_disk), row
    for key in ("texels_before", "texels_after", "bytes_before", "bytes_after"):
        assert report["totals"][key] == sum(a[key] for a in report["atlases"])
    total = report["totals"]
    assert total["texels_before"] == 2 * texels  # both pages, each of the demo's size
    assert f"{total['texels_before']:,} -> {total['texels_after']:,}" in r.stdout


@pytest.mark.parametrize("jobs", ["1", "2"])
def test_a_failed_atlas_is_named_on_stderr_and_the_others_written(meshed, tmp_path, jobs):
    """One atlas of two fails (its page does not decode), over one process and side by side: the
    other is packed, the failed one copied byte for byte and named in one ``error:`` line on
    stderr, as ``upgrade --pack`` names it and the exit table says (exit 3); it was in the table's
    note on stdout alone."""
    project = _copy(meshed, tmp_path / "p")
    _broken_twin(project)
    r = _cli("pack", project, "--out", tmp_path / "o", "--report", tmp_path / "r.json", "-j", jobs, cwd=tmp_path)
    assert r.returncode == 3, r.stderr
    (line,) = [line for line in r.stderr.splitlines() if line.strip()]
    assert line.startswith("error: other.atlas: not packed: ") and "other.png" in line, r.stderr
    rows = _rows(tmp_path / "r.json")
    assert rows["demo.atlas"]["status"] == "packed" and rows["other.atlas"]["status"] == "failed"
    for name in ("other.atlas", "other.png"):
        assert (tmp_path / "o" / name).read_bytes() == (project / name).read_bytes()


# --- bytes never grow ----------------------------------------------------------------------------

def _png_header(data: bytes) -> tuple[int, int]:
    """``(bit depth, colour type)`` of a PNG file's IHDR."""
    assert data[12:16] == b"IHDR"
    return data[24], data[25]


@pytest.mark.parametrize("mode", ["L", "1"])
def test_a_grey_page_is_packed_grey(meshed, tmp_path, mode):
    """A page of grey texels without alpha (8-bit or 1-bit) was packed as a palette PNG with a
    transparent background: the demo's packed files took 2,729 bytes, 2,052 with a grey page (and
    its atlas was kept for its bytes). Packed, it is grey as it was, its empty background opaque black
    (never sampled), every texel drawn the original's (the proof)."""
    from PIL import Image

    project = _copy(meshed, tmp_path / "p")
    with Image.open(project / "demo.png") as im:
        grey = im.convert("L")
    (grey.point(lambda v: 255 if v > 128 else 0).convert("1") if mode == "1" else grey).save(project / "demo.png")
    r = _cli("pack", project, "--out", tmp_path / "o", "--report", tmp_path / "r.json", "-j", "1", "--larger-files",
             cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    row = _rows(tmp_path / "r.json")["demo.atlas"]
    assert row["status"] == "packed", row
    depth, colour_type = _png_header((tmp_path / "o" / "demo.png").read_bytes())
    assert colour_type == 0 and depth <= (1 if mode == "1" else 8), (depth, colour_type)


# --- page rules at their edges ------------------------------------------------------------------

def test_an_atlas_the_page_rules_leave_no_room_for_says_so(meshed, tmp_path):
    """``--max-page 150``: one page of at most 150 x 150 texels cannot hold what the demo's regions
    take, and no atlas gets more pages than it had. The note blamed the fills ("no fill tried
    placed them on fewer"); it says what the rules allow against what the regions need. The atlas
    is kept, its page re-encoded losslessly."""
    r = _cli("pack", meshed, "--out", tmp_path / "o", "--report", tmp_path / "r.json", "-j", "1",
             "--max-page", "150", "--pages", "any", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    row = _rows(tmp_path / "r.json")["demo.atlas"]
    assert row["status"] == "kept" and "no fill tried" not in row["reason"], row
    assert "more than one page of at most 22,500 texels holds under the page rules" in row["reason"], row


# --- passed as they were, kept as tests --------------------------------------------------------

def _as_page(project: Path, ext: str, **save) -> None:
    """The demo's page stored again (another format or an optimal PNG), the atlas naming it."""
    from PIL import Image

    with Image.open(project / "demo.png") as im:
        rgba = im.convert("RGBA")
    (project / "demo.png").unlink()
    if ext == ".png-palette":
        rgba.quantize(colors=256, method=Image.Quantize.FASTOCTREE, dither=Image.Dither.NONE).save(project / "demo.png")
        ext = ".png"
    elif ext == ".jpg":
        rgba.convert("RGB").save(project / "demo.jpg", **save)
    else:
        rgba.save(project / f"demo{ext}", **save)
    if ext == ".png":
        import oxipng

        oxipng.optimize(project / "demo.png", level=6)  # as small as oxipng makes it
    atlas = project / "demo.atlas"
    atlas.write_text(atlas.read_text().replace("demo.png", f"demo{ext}", 1))


@pytest.mark.parametrize(("ext", "save"), [(".png", {}), (".png-palette", {}), (".jpg", {"quality": 90}),
                                           (".webp", {"lossless": True, "quality": 100, "method": 6, "exact": True})],
                         ids=["optimal RGBA PNG", "optimal palette PNG", "JPEG", "lossless WebP"])
def test_pages_already_small_never_grow(meshed, tmp_path, ext, save):
    """A page already as small as it gets is never written larger: packed, each of these took more
    bytes than as exported, so the atlas is kept, its files byte for byte, and the table and the
    report say the bytes on disk before and after."""
    from spinemesh.atlas import read_atlas

    project = _copy(meshed, tmp_path / "p")
    _as_page(project, ext, **save)
    r = _cli("pack", project, "--out", tmp_path / "o", "--report", tmp_path / "r.json", "-j", "1", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    row = _rows(tmp_path / "r.json")["demo.atlas"]
    page = read_atlas(project / "demo.atlas").pages[0].name
    on_disk = sum((folder / name).stat().st_size for folder in [tmp_path / "o"] for name in ("demo.atlas", page))
    assert row["status"] == "kept" and row["bytes_after"] == row["bytes_before"] == on_disk, row
    assert f"{on_disk:,} -> {on_disk:,} (same)" in r.stdout
    for name in ("demo.atlas", page):
        assert (tmp_path / "o" / name).read_bytes() == (project / name).read_bytes()


def _second_atlas(project: Path, page: str, folder: str = "") -> None:
    (project / folder).mkdir(exist_ok=True)
    (project / folder / "b.atlas").write_text((project / "demo.atlas").read_text().replace("demo.png", page, 1))


@pytest.mark.parametrize("how", ["./demo.png", "..\\demo.png", "symlink", "hard link"])
def test_one_page_under_two_names_packs_for_neither_or_each_apart(meshed, tmp_path, how):
    """A second atlas naming the demo's page another way (``./``, a Windows export's ``..\\`` from a
    folder below, a symlink) shares it: both atlases are kept, the page copied once. A hard link is
    two files in OUT: each atlas is packed onto its own page, and the project's files stay as they
    were."""
    project = _copy(meshed, tmp_path / "p")
    if how in ("symlink", "hard link"):
        (os.symlink if how == "symlink" else os.link)("demo.png" if how == "symlink" else project / "demo.png",
                                                     project / "demo2.png")
        _second_atlas(project, "demo2.png")
    else:
        _second_atlas(project, how, "sub" if how.startswith("..") else "")
    before = {p: p.read_bytes() for p in project.rglob("*") if p.is_file()}
    r = _cli("pack", project, "--out", tmp_path / "o", "--report", tmp_path / "r.json", "-j", "1", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    statuses = {row["status"] for row in _rows(tmp_path / "r.json").values()}
    assert statuses == ({"packed"} if how == "hard link" else {"kept"}), statuses
    if how != "hard link":
        assert (tmp_path / "o" / "demo.png").read_bytes() == before[project / "demo.png"]
    assert {p: p.read_bytes() for p in project.rglob("*") if p.is_file()} == before


#: Atlas lines that disagree with the page or with themselves, which pack packs, proven by the
#: official runtime: an ``orig`` smaller than the stored rectangle, offsets below 0 or past it,
#: two regions on the same texels (one of them turned).
ODD_REGIONS = {
    "orig smaller": ("offsets: 5, 4, 90, 90", "offsets: 0, 0, 40, 40"),
    "offsets below 0": ("offsets: 5, 4, 90, 90", "offsets: -20, -20, 90, 90"),
    "offsets past the rectangle": ("offsets: 5, 4, 90, 90", "offsets: 30, 30, 90, 90"),
    "overlapping turned": ("bounds: 2, 145, 25, 113", "bounds: 2, 2, 25, 113"),
}


@pytest.mark.parametrize("case", list(ODD_REGIONS))
def test_regions_that_disagree_with_their_page_pack_and_draw_alike(meshed, tmp_path, spine_runtime, case):
    from runtime_tool import render, render_difference

    project = _copy(meshed, tmp_path / "p")
    old, new = ODD_REGIONS[case]
    atlas = project / "demo.atlas"
    atlas.write_text(atlas.read_text().replace(old, new, 1))
    r = _cli("pack", project, "--out", tmp_path / "o", "--report", tmp_path / "r.json", "-j", "1", cwd=tmp_path)
    assert r.returncode == 0 and _rows(tmp_path / "r.json")["demo.atlas"]["status"] == "packed", r.stdout
    before = render(spine_runtime, atlas, project / "demo.json", "wave", "0,0.3", tmp_path / "r" / "a")
    after = render(spine_runtime, tmp_path / "o" / "demo.atlas", tmp_path / "o" / "demo.json", "wave", "0,0.3",
                   tmp_path / "r" / "b", frame_from=tmp_path / "r" / "a.frame.json")
    assert before and len(before) == len(after)
    for a, b in zip(before, after):
        diff = render_difference(a, b)
        assert diff["off"] == 0 and diff["lost"] == 0, (a.name, diff)
