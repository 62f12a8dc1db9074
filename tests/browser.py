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
    errors = [line for line in r.stderr.splitlines() if "Uncaught" in line or "net::ERR_FILE_NOT_FOUND" in line
              or ("CONSOLE" in line and ("Error" in line or "Failed" in line))]
    assert not errors, "\n".join(errors)
    return r


def player_result(url: str, tmp: Path, budget_ms: int = 5000) -> dict:
    """What the preview player's test hook wrote in ``<pre id="sm-test">`` (see player.js)."""
    dom = run(url, tmp, "--dump-dom", budget_ms=budget_ms).stdout
    found = re.search(r'<pre id="sm-test">(.*?)</pre>', dom, re.S)
    assert found and found.group(1), f"the player wrote no test result:\n{dom[-1500:]}"
    return json.loads(found.group(1).replace("&amp;", "&").replace("&lt;", "<").replace("&gt;", ">"))
