"""Whole-project upgrade: wall time, peak memory and the split between reading, meshing and writing.

    .venv/bin/python benchmarks/bench_upgrade.py [--jobs N]

Runs spineboy-pro (4.2, .json and .skel) and then every 4.2 example project, each in a fresh
process so that peak memory (ru_maxrss) belongs to that run alone.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

EXAMPLES = Path(__file__).resolve().parents[2] / "shared" / "spine-examples" / "4.2"

CHILD = r"""
import json, resource, sys, time
from spinemesh.upgrade import Options, upgrade_project
t = time.perf_counter()
r = upgrade_project(sys.argv[1], sys.argv[2], Options(jobs=int(sys.argv[3])))
wall = time.perf_counter() - t
print(json.dumps({"wall": wall, **r.seconds, "meshed": r.counts().get("meshed", 0),
                  "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                  "children_peak_mb": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024}))
"""


def run(project: Path, jobs: int) -> dict:
    with tempfile.TemporaryDirectory() as out:
        r = subprocess.run([sys.executable, "-c", CHILD, str(project), out, str(jobs)],
                           capture_output=True, text=True, check=True)
    return json.loads(r.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--jobs", type=int, default=1)
    args = ap.parse_args()
    if not EXAMPLES.is_dir():
        sys.exit(f"{EXAMPLES} is absent")
    rows = [("spineboy-pro.json", run(EXAMPLES / "spineboy/spineboy-pro.json", args.jobs)),
            ("spineboy-pro.skel", run(EXAMPLES / "spineboy/spineboy-pro.skel", args.jobs))]
    for project in sorted(p for p in EXAMPLES.iterdir() if p.is_dir()):
        rows.append((project.name + "/", run(project, args.jobs)))
    print(f"jobs={args.jobs}")
    print(f"{'project':24} {'meshed':>6} {'wall s':>7} {'read s':>7} {'mesh s':>7} {'write s':>7} {'peak MB':>8}")
    for name, r in rows:
        peak = max(r["peak_mb"], r["children_peak_mb"])
        print(f"{name:24} {r['meshed']:6d} {r['wall']:7.2f} {r['read']:7.2f} {r['mesh']:7.2f} {r['write']:7.2f} {peak:8.0f}")
    every = rows[2:]
    total = {k: sum(r[k] for _, r in every) for k in ("wall", "read", "mesh", "write", "meshed")}
    print(f"{'all 4.2 examples':24} {total['meshed']:6d} {total['wall']:7.2f} {total['read']:7.2f} "
          f"{total['mesh']:7.2f} {total['write']:7.2f} {max(max(r['peak_mb'], r['children_peak_mb']) for _, r in every):8.0f}")
    print(f"share of wall time: read {total['read'] / total['wall']:.0%}, mesh {total['mesh'] / total['wall']:.0%}, "
          f"write {total['write'] / total['wall']:.0%}")


if __name__ == "__main__":
    main()
