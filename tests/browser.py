"""Headless Chromium for the tests of the HTML pages we write (installed by scripts/setup.sh)."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
from pathlib import Path

from conftest import unavailable

#: Flags of every run: no network, no GPU, and pages may read pixels of images beside them
#: (a file:// canvas is otherwise "tainted" and the player's test hook cannot read it back).
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
         "--disable-component-update", "--disable-sync", "--no-first-run", "--enable-logging=stderr", "--v=0",
         "--allow-file-access-from-files"]


def chromium() -> str:
    """The browser's path; a skip (a failure in CI) when it is not installed."""
    for name in ("chromium", "chromium-browser"):
        if shutil.which(name):
            return shutil.which(name)
    unavailable("chromium is not installed (scripts/setup.sh installs it as root)")


def run(url: str, tmp: Path, *args: str, budget_ms: int = 5000) -> subprocess.CompletedProcess:
    """Open ``url`` with ``args`` (``--dump-dom``, ``--screenshot=...``) and fail on a page error."""
    tmp.mkdir(parents=True, exist_ok=True)
    profile = tmp / f"profile{len(list(tmp.glob('profile*')))}"
    r = subprocess.run([chromium(), *FLAGS, f"--user-data-dir={profile}", f"--virtual-time-budget={budget_ms}",
                        *args, url], capture_output=True, text=True, timeout=180, env={**os.environ, "HOME": str(tmp)})
    assert r.returncode == 0, r.stderr[-2000:]
    errors = page_errors(r.stderr)
    assert not errors, "\n".join(errors)
    return r


def page_errors(stderr: str) -> list[str]:
    """The page's errors in the browser's log (``--enable-logging=stderr``): uncaught
    exceptions, console errors, files it could not load."""
    return [line for line in stderr.splitlines() if "Uncaught" in line or "net::ERR_FILE_NOT_FOUND" in line
            or ("CONSOLE" in line and ("Error" in line or "Failed" in line))]


def player_result(url: str, tmp: Path, *args: str, budget_ms: int = 5000) -> dict:
    """What the preview player's test hook wrote in ``<pre id="sm-test">`` (see player.js);
    ``args``: more of the browser's flags (``--window-size=1280,720``)."""
    dom = run(url, tmp, "--dump-dom", *args, budget_ms=budget_ms).stdout
    found = re.search(r'<pre id="sm-test">(.*?)</pre>', dom, re.S)
    assert found and found.group(1), f"the player wrote no test result:\n{dom[-1500:]}"
    return json.loads(found.group(1).replace("&amp;", "&").replace("&lt;", "<").replace("&gt;", ">"))


def canvases(got: dict) -> list:
    """The player's two canvases (original, upgraded) its test hook wrote, RGBA arrays."""
    import base64

    from spinemesh.images import decode_rgba

    return [decode_rgba(base64.b64decode(got[k].split(",", 1)[1])) for k in ("before", "after")]


def against_the_runtime(tool: Path, tmp: Path, preview: Path, page: str, anim_index: int, anim: str,
                        original: tuple[Path, Path], upgraded: tuple[Path, Path], time: float = 0.5,
                        frame: tuple[float, float, float, float] | None = None) -> list[dict]:
    """Render ``anim`` at ``time`` with the official runtime (``original`` and ``upgraded``:
    (atlas, skeleton), the second in the first's frame; the first in ``frame``, world x, y,
    width, height, when given, else in its file's bounds) and with our player (the preview's
    ``s/<page>``, its animation ``anim_index``) in that frame; the differences
    (:func:`runtime_tool.render_difference`, 32/255), original then upgraded."""
    from PIL import Image

    from runtime_tool import render, render_difference

    def at(pngs: list[Path]) -> Path:  # the render also writes the setup pose
        return next(p for p in pngs if p.name.endswith(f"{anim}@{time:g}.png"))

    theirs = [at(render(tool, *original, anim, f"{time:g}", tmp / "a", frame=frame))]
    theirs.append(at(render(tool, *upgraded, anim, f"{time:g}", tmp / "b", frame_from=tmp / "a.frame.json")))
    frame = json.loads((tmp / "a.frame.json").read_text())
    f = frame["frame"]
    view = f"{f['x']},{f['y']},{f['width']},{f['height']},{frame['ppu']}"
    got = player_result((preview / "s" / page).resolve().as_uri() + f"#at={anim_index},{time:g},{view}",
                        tmp / "chromium")
    out = []
    for i, ours in enumerate(canvases(got)):
        Image.fromarray(ours).save(tmp / f"ours{i}.png")
        out.append(render_difference(theirs[i], tmp / f"ours{i}.png", tol=32))
    return out
