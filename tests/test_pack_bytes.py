"""Bytes on disk of what ``pack`` writes: pages through oxipng, no atlas larger in bytes by default.

The project is the demo project (drawn by our own code) upgraded to meshes, so that ``pack``
moves and crops its regions. How the byte rule decides is forced where needed by making the
encoder or the rule say "larger"; what is written is checked for real (decoded, compared).
"""

from __future__ import annotations

import io
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np

from spinemesh.atlas import read_atlas
from spinemesh.images import cut_region, load_rgba
from spinemesh.pack import run
from spinemesh.pack.run import PackOptions, pack_project

REPO = Path(__file__).resolve().parents[1]


def _pillow_png(rgba: np.ndarray) -> bytes:
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(rgba).save(buf, format="PNG")
    return buf.getvalue()


def test_png_pages_are_written_through_oxipng(meshed, tmp_path):
    """Fewer bytes than Pillow's default for the same texels, and the very texels."""
    from spinemesh.pack.png import optimized_png

    rgba = np.ascontiguousarray(load_rgba(meshed / "demo.png"))
    data = optimized_png(rgba)
    assert len(data) < len(_pillow_png(rgba))
    np.testing.assert_array_equal(load_rgba_bytes(data), rgba)
    result = pack_project(meshed, tmp_path / "out")
    (row,) = result.atlases
    assert row.status == "packed"
    page = load_rgba(tmp_path / "out" / "demo.png")
    assert (tmp_path / "out" / "demo.png").stat().st_size < len(_pillow_png(np.ascontiguousarray(page)))


def load_rgba_bytes(data: bytes) -> np.ndarray:
    from spinemesh.images import decode_rgba

    return decode_rgba(data)


def test_the_optimiser_works_in_a_process_forked_after_it_ran():
    """oxipng's thread pool does not survive a fork: a forked child compresses through a helper."""
    code = (
        "import os, sys, numpy as np\n"
        "from spinemesh.pack.png import optimized_png\n"
        "a = np.random.default_rng(0).integers(0, 255, (40, 40, 4), dtype=np.uint8)\n"
        "n = len(optimized_png(a))\n"
        "pid = os.fork()\n"
        "if pid == 0:\n"
        "    os._exit(0 if len(optimized_png(a)) == n else 1)\n"
        "sys.exit(os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1]))\n")
    r = subprocess.run([sys.executable, "-c", code], env={**os.environ, "PYTHONPATH": str(REPO)}, timeout=120,
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr


def _bloated(image) -> bytes:
    """A PNG without compression: every packed page takes more bytes than the original."""
    from PIL import Image

    if isinstance(image, (bytes, bytearray)):
        image = np.asarray(Image.open(io.BytesIO(image)).convert("RGBA"))
    buf = io.BytesIO()
    Image.fromarray(np.ascontiguousarray(image)).save(buf, format="PNG", compress_level=0)
    return buf.getvalue()


def test_an_atlas_whose_files_would_grow_is_kept_unless_asked(meshed, tmp_path, monkeypatch):
    monkeypatch.setattr(run, "optimized_png", _bloated)
    result = pack_project(meshed, tmp_path / "kept")
    (row,) = result.atlases
    assert row.status == "kept" and "bytes against" in row.reason and "--larger-files" in row.reason, row.reason
    assert row.bytes_after == row.bytes_before
    assert (tmp_path / "kept" / "demo.png").read_bytes() == (meshed / "demo.png").read_bytes()
    result = pack_project(meshed, tmp_path / "larger", PackOptions(larger_files=True))
    (row,) = result.atlases
    assert row.status == "packed" and row.bytes_after > row.bytes_before and row.texels_after < row.texels_before


def test_rectangles_only_when_that_is_smaller(meshed, tmp_path, monkeypatch):
    """Noise between the regions (read by nothing) cleared: the same atlas in fewer bytes, same reads."""
    project = tmp_path / "noisy"
    shutil.copytree(meshed, project, ignore=shutil.ignore_patterns(".*"))
    atlas = read_atlas(project / "demo.atlas")
    page = np.array(load_rgba(project / "demo.png"))
    keep = np.zeros(page.shape[:2], bool)
    for r in atlas.regions:
        g = r.geometry()
        keep[max(0, g.y - 1):g.y + g.page_height + 1, max(0, g.x - 1):g.x + g.page_width + 1] = True
    noise = np.random.default_rng(1).integers(0, 256, page.shape, dtype=np.uint8)
    page[~keep] = noise[~keep]
    from PIL import Image

    Image.fromarray(page).save(project / "demo.png")

    def grows(*args):
        raise run.PackRefused("packed, its files would take more bytes")

    monkeypatch.setattr(run, "check_bytes_shrink", grows)
    result = pack_project(project, tmp_path / "out")
    (row,) = result.atlases
    assert row.status == "packed" and "rectangles' texels only" in row.reason, row.reason
    assert row.texels_after == row.texels_before and row.bytes_after < row.bytes_before
    assert (tmp_path / "out" / "demo.atlas").read_bytes() == (project / "demo.atlas").read_bytes()
    written = load_rgba(tmp_path / "out" / "demo.png")
    assert not written[~keep].any()
    for r in atlas.regions:
        np.testing.assert_array_equal(cut_region(written, r), cut_region(page, r), err_msg=r.name)


def test_bytes_before_and_after_per_atlas_and_in_total(meshed, tmp_path):
    library = tmp_path / "library"
    for name in ("a", "b"):
        shutil.copytree(meshed, library / name, ignore=shutil.ignore_patterns(".*"))
    report = tmp_path / "report.json"
    env = {**os.environ, "PYTHONPATH": str(REPO), "COLUMNS": "200", "NO_COLOR": "1"}
    r = subprocess.run([sys.executable, "-m", "spinemesh", "pack", str(library), "--out", str(tmp_path / "out"),
                        "--report", str(report), "--jobs", "1"], env=env, capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stdout + r.stderr
    data = json.loads(report.read_text())
    rows = data["atlases"]
    assert len(rows) == 2 and all(a["bytes_after"] < a["bytes_before"] for a in rows)
    for key in ("bytes_before", "bytes_after"):
        assert data["totals"][key] == sum(a[key] for a in rows)
    total = next(line for line in r.stdout.splitlines() if "total" in line)
    assert f"{data['totals']['bytes_before']:,} -> {data['totals']['bytes_after']:,}" in total
