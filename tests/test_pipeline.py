"""spinemesh in a build pipeline (CI, a Makefile, a cache keyed by file hashes).

- The same input gives the same bytes, from any folder, by relative or absolute paths, with any
  hash seed, time zone, locale, number of workers, and whatever the input files' times.
- A run into a folder an earlier run wrote leaves no file of that run the new one did not write
  again, and never removes a file spinemesh did not write.
- Exit statuses and logs a script can rely on.

The demo project drawn by our own code is the input (no ../shared data needed); the corpus test
runs where the data are.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from spinemesh.demo import make_demo_project

REPO = Path(__file__).resolve().parents[1]


def spinemesh(*args, cwd: Path, **env: str) -> subprocess.CompletedProcess:
    """``spinemesh ARGS`` in ``cwd`` with ``env`` added, as a build step runs it (no terminal)."""
    environ = dict(os.environ, COLUMNS="200", PYTHONPATH=str(REPO), **env)
    r = subprocess.run([sys.executable, "-m", "spinemesh", *map(str, args)], capture_output=True, text=True,
                       env=environ, cwd=cwd)
    return r


def files_of(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder`` (hidden ones too) by its path under it, with its bytes."""
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def without_times(report: bytes):
    """A JSON report with every timing taken out (the one thing a report may differ in)."""
    def strip(o):
        if isinstance(o, dict):
            return {k: strip(v) for k, v in o.items() if "seconds" not in k}
        return [strip(v) for v in o] if isinstance(o, list) else o

    return strip(json.loads(report))


def _build(where: Path, relative: bool, jobs: int, **env: str) -> dict[str, bytes]:
    """Every command a build runs on the demo project, into ``where``: relative paths from
    ``where``, or absolute ones from another folder; returns every file written."""
    make_demo_project(where / "demo")
    for f in (where / "demo").rglob("*"):  # a fresh checkout: other file times
        os.utime(f, (1_000_000_000 + jobs, 1_000_000_000 + jobs))
    cwd = where if relative else where.parent
    at = (lambda p: Path(p)) if relative else (lambda p: where / p)
    steps = [
        ("upgrade", at("demo"), "--out", at("meshed"), "--pack", "--weights", "auto", "--jobs", jobs,
         "--preview", at("preview"), "--report", at("upgrade.json")),
        ("upgrade", at("demo/demo.json"), "--out", at("meshed-json"), "--jobs", jobs),
        ("pack", at("meshed"), "--out", at("packed"), "--jobs", jobs, "--report", at("pack.json"),
         "--preview", at("pack-preview")),
        ("convert", at("demo/demo-binary.skel"), at("converted.json")),
        ("convert", at("converted.json"), at("converted.skel")),
        ("pose", at("meshed/demo.json"), "-a", "wave", "--times", "0.1,0.25", "--out", at("pose.json")),
    ]
    for step in steps:
        r = spinemesh(*step, cwd=cwd, **env)
        assert r.returncode == 0, (step, r.stdout[-2000:], r.stderr[-2000:])
    out = files_of(where)
    return {k: v for k, v in out.items() if not k.startswith("demo/")}


def test_the_same_bytes_from_any_folder_seed_zone_and_workers(tmp_path):
    """Two builds of the demo, one by relative paths with --jobs 1, hash seed 0, UTC and the C
    locale, the other by absolute paths from another folder with --jobs 2, hash seed 1, another
    time zone and a UTF-8 locale, input files of other times: every skeleton, atlas, page,
    preview file and pose is the same bytes; the reports differ in their timings only. (The
    preview's index and the pose file named the input and output by the paths given.)"""
    a = _build(tmp_path / "a" / "build", relative=True, jobs=1, PYTHONHASHSEED="0", TZ="UTC", LC_ALL="C")
    b = _build(tmp_path / "b" / "build", relative=False, jobs=2, PYTHONHASHSEED="1", TZ="Asia/Kathmandu",
               LC_ALL="C.UTF-8")
    assert sorted(a) == sorted(b)
    reports = {"upgrade.json", "pack.json"}
    differ = sorted(k for k in a if k not in reports and a[k] != b[k])
    assert not differ, differ
    for name in reports:
        assert without_times(a[name]) == without_times(b[name]), name
    assert any(k.startswith("preview/") for k in a) and "pose.json" in a
