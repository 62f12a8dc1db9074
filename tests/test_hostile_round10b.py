"""Hostile input, tenth round, second half: the inputs of the commands the earlier rounds barely
attacked (``mesh``, ``segment``, ``segment-export``, ``convert``).

As in the earlier rounds (tests/test_hostile*.py), every input is made here by our own code;
each case checks what docs/safety.md promises: one clear line naming the file, never a
traceback, never a wrong output written silently, inputs unchanged.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from test_hostile import check_run, run_cli, snapshot


def _demo_json(tmp: Path) -> Path:
    """The demo project's JSON skeleton alone, in ``tmp``."""
    from spinemesh.demo import make_demo_project

    project = make_demo_project(tmp / "p", with_images_folder=False)
    (project / "demo-binary.skel").unlink()
    return project / "demo.json"


# --- convert: integers the binary format cannot hold ----------------------------------------------

@pytest.mark.parametrize("where", ["event", "key"])
@pytest.mark.parametrize("value", [2 ** 40, 2 ** 31, -(2 ** 31) - 1])
def test_an_integer_past_32_bits_is_not_written_cut(tmp_path, value, where):
    """An event's ``int`` (or a key's) is a varint of 32 bits in a ``.skel``. One of 2**40 was
    written cut to its low bits and read back 256 (2**31 read back -1), exit 0: the game got
    another number than the JSON held. Now the skeleton is refused in one line naming the field,
    and nothing is written."""
    skeleton = _demo_json(tmp_path)
    doc = json.loads(skeleton.read_text())
    doc["events"] = {"hit": {"int": value if where == "event" else 0}}
    key = {"time": 0, "name": "hit", **({"int": value} if where == "key" else {})}
    next(iter(doc["animations"].values()))["events"] = [key]
    skeleton.write_text(json.dumps(doc))
    before = snapshot(tmp_path)
    r = run_cli("convert", "p/demo.json", "out.skel", cwd=tmp_path)
    check_run(r, before, tmp_path, [], codes=(2,))
    assert "demo.json: cannot be written as a binary skeleton" in r.stderr, r.stderr
    assert f"int (the binary format's range), got {value}" in r.stderr, r.stderr
    assert len(r.stderr.strip().splitlines()) == 1, r.stderr


def test_the_ends_of_the_32_bit_range_go_through(tmp_path):
    """The largest and smallest 32-bit ints are written and read back exactly."""
    skeleton = _demo_json(tmp_path)
    doc = json.loads(skeleton.read_text())
    doc["events"] = {"low": {"int": -(2 ** 31)}, "high": {"int": 2 ** 31 - 1}}
    skeleton.write_text(json.dumps(doc))
    for args in (("p/demo.json", "out.skel"), ("out.skel", "back.json")):
        r = run_cli("convert", *args, cwd=tmp_path)
        assert r.returncode == 0, r.stdout + r.stderr
    back = json.loads((tmp_path / "back.json").read_text())["events"]
    assert back == {"low": {"int": -(2 ** 31)}, "high": {"int": 2 ** 31 - 1}}
