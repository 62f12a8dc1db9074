"""``upgrade --preview``: the HTML page that shows what an upgrade changed.

Runs on the demo project drawn by our own code. The browser check needs Chromium: skipped
when it is absent, a failure in CI (``CI=true``), where the proof must run.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest

from spinemesh.demo import make_demo_project
from spinemesh.upgrade import Options, upgrade_project
from spinemesh.upgrade.preview import fill_rate, mesh_raster, write_preview


@pytest.fixture(scope="module")
def page(tmp_path_factory) -> tuple[Path, object]:
    tmp = tmp_path_factory.mktemp("preview")
    demo = make_demo_project(tmp / "demo")
    result = upgrade_project(demo, tmp / "out", Options())
    return write_preview(result, demo, tmp / "out", tmp / "preview"), result


def test_fill_rate_of_a_square_sprite():
    rgba = np.zeros((10, 10, 4), np.uint8)
    rgba[3:7, 2:6, 3] = 255
    # a mesh exactly around the opaque 4x4 square, as two triangles
    uvs = np.array([[2, 3], [6, 3], [6, 7], [2, 7]], float) / 10
    rate = fill_rate(rgba, (0, 0, 10, 10), uvs, np.array([[0, 1, 2], [0, 2, 3]]))
    assert (rate.before, rate.after, rate.transparent_before, rate.transparent_after) == (100, 16, 84, 0)
    # only the stored box is drawn by the region, and the mesh never draws outside it
    rate = fill_rate(rgba, (2, 3, 6, 7), uvs, np.array([[0, 1, 2], [0, 2, 3]]))
    assert (rate.before, rate.after, rate.transparent_before, rate.transparent_after) == (16, 16, 0, 0)


def test_mesh_raster_counts_texel_centres():
    uvs = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    assert mesh_raster(uvs, np.array([[0, 1, 2], [0, 2, 3]]), 7, 5).sum() == 35


def test_page_is_self_contained_and_adds_up(page):
    path, result = page
    html = path.read_text(encoding="utf-8")
    assert "<script" not in html and "http://" not in html and "https://" not in html
    assert all(src.startswith("data:image/png;base64,") for src in re.findall(r'src="([^"]*)"', html))
    meshed = [t for t in result.targets if t.status == "meshed"]
    assert html.count('class="card"') == len({(t.skeleton, t.key) for t in meshed})
    assert html.count('class="pose"') == len(result.written) == 2  # demo.json and its .skel twin
    # the demo's art is fully opaque or fully clear: every visible texel is still drawn, so the
    # texels no longer drawn are all transparent ones
    m = re.search(r"texels drawn</td><td>([\d,]+)</td><td>([\d,]+)</td>.*?fully transparent</td>"
                  r"<td>([\d,]+)</td><td>([\d,]+)</td>", html, re.S)
    before, after, clear_before, clear_after = (int(g.replace(",", "")) for g in m.groups())
    assert before - clear_before == after - clear_after
    assert clear_after < clear_before / 2, "the demo's meshes leave out most of the transparent area"


def _chromium() -> str | None:
    for name in ("chromium", "chromium-browser"):
        if shutil.which(name):
            return shutil.which(name)
    return None


def test_page_renders_in_headless_chromium(page, tmp_path):
    browser = _chromium()
    if browser is None:
        if os.environ.get("CI", "").lower() == "true":
            pytest.fail("chromium is needed in CI to prove the preview page renders")
        pytest.skip("chromium is not installed")
    path, _ = page
    shot = tmp_path / "preview.png"
    run = subprocess.run([browser, "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
                          "--no-first-run", "--enable-logging=stderr", "--v=0", f"--user-data-dir={tmp_path / 'p'}",
                          f"--screenshot={shot}", "--window-size=1200,1400", path.resolve().as_uri()],
                         capture_output=True, text=True, timeout=120, env={**os.environ, "HOME": str(tmp_path)})
    assert run.returncode == 0, run.stderr[-2000:]
    errors = [line for line in run.stderr.splitlines() if "CONSOLE" in line or "Uncaught" in line
              or "net::ERR" in line]
    assert not errors, "\n".join(errors)
    from PIL import Image

    img = np.asarray(Image.open(shot).convert("RGB")).astype(int)
    assert img.shape[:2] == (1400, 1200) and img.std() > 10
    # the setup pose shows the demo's blue body and the new meshes' orange wireframe
    near = lambda rgb: (np.abs(img - rgb).sum(axis=2) < 40).sum()  # noqa: E731
    assert near((70, 110, 200)) > 2000 and near((224, 88, 43)) > 200


def test_setup_pose_dresses_an_empty_default_skin():
    """A project whose default skin is empty (mix-and-match) is drawn with the skin that
    supplies most of the slots' setup attachments, then the default skin."""
    from spinemesh.upgrade.preview import pose_skins

    doc = {"slots": [{"name": "a", "bone": "root", "attachment": "x"}, {"name": "b", "bone": "root", "attachment": "y"}],
           "skins": [{"name": "default", "attachments": {}},
                     {"name": "one", "attachments": {"a": {"x": {}}}},
                     {"name": "both", "attachments": {"a": {"x": {}}, "b": {"y": {}}}}]}
    assert pose_skins(doc) == ["both", "default"]
    doc["skins"] = doc["skins"][:1]
    assert pose_skins(doc) == ["default"]
