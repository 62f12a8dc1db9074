"""What a user reads from ``upgrade --preview`` and ``pose``: the player says why its canvases are
blank or its frames few, the preview's bar counts the work it waits on, the index's tables are
headed, and a bad ``--times`` names the option. Runs on the demo project drawn by our own code."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from spinemesh.demo import make_demo_project

REPO = Path(__file__).resolve().parents[1]


def test_a_time_that_is_not_one_names_the_option(tmp_path):
    skeleton = make_demo_project(tmp_path / "demo") / "demo.json"
    for times, why in (("0.2,abc", "'abc' is not a number of seconds"),
                       ("-1", "'-1': times must be finite and not negative")):
        r = subprocess.run([sys.executable, "-m", "spinemesh", "pose", str(skeleton), "-a", "wave", f"--times={times}"],
                           check=False, capture_output=True, text=True, cwd=REPO)
        assert r.returncode == 2 and f"Invalid value for --times: {why}" in r.stderr, r.stderr
        assert "Traceback" not in r.stderr
