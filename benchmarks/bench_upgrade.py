"""Whole-project upgrade: wall time per worker setting, side by side, and where the time goes.

    .venv/bin/python benchmarks/bench_upgrade.py                       # --jobs 1 and 2
    .venv/bin/python benchmarks/bench_upgrade.py --jobs 1 2 4 --dask   # + a local Dask cluster
    .venv/bin/python benchmarks/bench_upgrade.py --projects            # + one row per project

For each setting it upgrades spineboy-pro (4.2, ``.json`` and ``.skel``) and then every 4.2
example at once as a library (``upgrade_library``: one set of workers for all projects),
each run in a fresh process so that start-up and peak memory (ru_maxrss of the process and
its workers) belong to that run alone. Speed-up is against the first setting. Outputs are
compared byte for byte across settings: a setting that gives other bytes is reported.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

EXAMPLES = Path(__file__).resolve().parents[2] / "shared" / "spine-examples" / "4.2"

CHILD = r"""
import json, resource, sys, time
from spinemesh.upgrade import Options, is_library, upgrade_library, upgrade_project
project, out, jobs, dask = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4] or None
t = time.perf_counter()
run = upgrade_library if is_library(project) else upgrade_project
r = run(project, out, Options(jobs=jobs, dask=dask))
wall = time.perf_counter() - t
print(json.dumps({"wall": wall, **r.seconds, "meshed": r.counts().get("meshed", 0),
                  "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                  "children_peak_mb": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024}))
"""


def tree_digest(folder: Path) -> str:
    h = hashlib.sha256()
    for p in sorted(folder.rglob("*")):
        if p.is_file():
            h.update(p.relative_to(folder).as_posix().encode() + b"\0" + p.read_bytes())
    return h.hexdigest()[:16]


def run(project: Path, jobs: int, dask: str | None) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "out"
        r = subprocess.run([sys.executable, "-c", CHILD, str(project), str(out), str(jobs), dask or ""],
                           capture_output=True, text=True)
        if r.returncode != 0:
            sys.exit(f"upgrade of {project} failed:\n{r.stderr[-3000:]}")
        row = json.loads(r.stdout.strip().splitlines()[-1])
        row["digest"] = tree_digest(out)
    row["peak"] = max(row["peak_mb"], row["children_peak_mb"])
    return row


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--jobs", type=int, nargs="+", default=[1, 2], help="worker settings to compare")
    ap.add_argument("--dask", action="store_true", help="also a local Dask cluster with the largest --jobs")
    ap.add_argument("--projects", action="store_true", help="also one row per 4.2 project (first setting)")
    ap.add_argument("--examples", type=Path, default=EXAMPLES, help="the 4.2 examples folder")
    args = ap.parse_args()
    if not args.examples.is_dir():
        sys.exit(f"{args.examples} is absent")
    settings = [(f"--jobs {j}", j, None) for j in args.jobs]
    if args.dask:
        settings.append((f"--dask local ({max(args.jobs)} workers)", max(args.jobs), "local"))
    cases = [("spineboy-pro.json", args.examples / "spineboy/spineboy-pro.json"),
             ("spineboy-pro.skel", args.examples / "spineboy/spineboy-pro.skel"),
             ("all 4.2 examples", args.examples)]
    print(f"cores available: {len(os.sched_getaffinity(0))}, load average {os.getloadavg()[0]:.1f}")
    results = {}
    for label, jobs, dask in settings:
        for name, path in cases:
            results[label, name] = run(path, jobs, dask)
            print(f"  {label:28} {name:18} {results[label, name]['wall']:7.2f} s", file=sys.stderr)

    base = settings[0][0]
    print(f"\n{'setting':28} {'case':18} {'meshed':>6} {'wall s':>7} {'speed-up':>8} {'read s':>7} "
          f"{'mesh s':>7} {'write s':>7} {'peak MB':>8}  same bytes")
    for label, _, _ in settings:
        for name, _ in cases:
            r = results[label, name]
            b = results[base, name]
            print(f"{label:28} {name:18} {r['meshed']:6d} {r['wall']:7.2f} {b['wall'] / r['wall']:7.2f}x "
                  f"{r['read']:7.2f} {r['mesh']:7.2f} {r['write']:7.2f} {r['peak']:8.0f}  "
                  f"{'yes' if r['digest'] == b['digest'] else 'NO'}")
    if args.projects:
        label, jobs, dask = settings[0]
        print(f"\nper project, {label}")
        for project in sorted(p for p in args.examples.iterdir() if p.is_dir()):
            r = run(project, jobs, dask)
            print(f"{project.name + '/':24} {r['meshed']:6d} {r['wall']:7.2f} {r['read']:7.2f} {r['mesh']:7.2f} "
                  f"{r['write']:7.2f} {r['peak']:8.0f}")


if __name__ == "__main__":
    main()
