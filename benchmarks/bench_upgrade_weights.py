"""What ``upgrade --weights auto`` costs on a library of many skeletons: both runs and their ratio.

    nice -n 10 .venv/bin/python benchmarks/bench_upgrade_weights.py [--projects A,B,...]
        [--jobs 2] [--repeat 2] [--before DIR]

The library: the corpus projects ``--projects`` (default five slot-game symbol projects, 45
skeletons, two of them nine and eight skeletons on one shared atlas page) copied into a
temporary folder, as a team's library of characters would sit beside each other. Each run is
``spinemesh upgrade LIBRARY --out ... --jobs J`` in a fresh process, plain (``--weights none``)
and with ``--weights auto``, the two taking turns ``--repeat`` times (with ``--before``, its
run and this code's swap places every other turn); the best of each is kept
(``--as-project``: the folder upgraded as one project of 45 skeletons). Printed per run: wall
seconds, CPU seconds of the process and its workers, the weights phase as the report gives it
(its wall seconds), meshes weighted, and the ratio to the plain run. ``--before DIR`` adds the ``--weights auto`` run of another checkout (say, main before
the weights moved to the workers): its output is compared byte for byte with this one's.

The machine may be shared: the load average is printed, and CPU seconds are the fairer figure
for the work done, wall seconds for what a user waits.
"""

from __future__ import annotations

import argparse
import filecmp
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
CORPUS = REPO.parent / "shared" / "spine-corpus"

#: Slot-game symbol projects: many small skeletons, several of them sharing one atlas page.
DEFAULT_PROJECTS = "stake-symbols,kraken-symbols,dq-symbols,wg-symbols,cm-symbols"

RUN = """
import json, resource, sys, time
from spinemesh.upgrade import Options, upgrade_library, upgrade_project
from spinemesh.upgrade.library import is_library
library, out, weights, jobs, whole = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4]), sys.argv[5] == "1"
t = time.perf_counter()
run = upgrade_project if whole or not is_library(library) else upgrade_library
r = run(library, out, Options(jobs=jobs, weights=weights))
wall = time.perf_counter() - t
me, kids = resource.getrusage(resource.RUSAGE_SELF), resource.getrusage(resource.RUSAGE_CHILDREN)
weighted = sum(1 for x in r.targets if (x.weights or {}).get("status") == "weighted")
print(json.dumps({"wall": wall, "cpu": me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime,
                  "weights": r.seconds["weights"], "weighted": weighted}))
"""


def library(projects: list[str], into: Path) -> tuple[int, Path]:
    """The projects copied under ``into/library`` (their provenance file left out); skeletons in all."""
    root = into / "library"
    for name in projects:
        shutil.copytree(CORPUS / name, root / name, ignore=shutil.ignore_patterns(".source.json"))
    skeletons = [p for p in root.rglob("*") if p.suffix in (".json", ".skel")]
    return len(skeletons), root


def run(code: Path, root: Path, out: Path, weights: str, jobs: int, whole: bool = False) -> dict:
    """One upgrade in a fresh process with ``code`` first on the path: its times and meshes
    weighted; ``whole``: the folder upgraded as one project (``upgrade_project``)."""
    shutil.rmtree(out, ignore_errors=True)
    # ``-c`` puts the working folder first on the path, before PYTHONPATH: run inside ``code``, or
    # a run from another checkout measures that checkout's code
    r = subprocess.run([sys.executable, "-c", RUN, str(root), str(out), weights, str(jobs), "1" if whole else "0"],
                       env={**os.environ, "PYTHONPATH": str(code)}, capture_output=True, text=True, cwd=str(code))
    if r.returncode:
        raise SystemExit(f"upgrade failed ({r.returncode}): {r.stderr[-2000:]}")
    return json.loads(r.stdout.strip().splitlines()[-1])


def same_files(a: Path, b: Path) -> bool:
    """Whether two output folders hold the same files, byte for byte."""
    files = sorted(p.relative_to(a) for p in a.rglob("*") if p.is_file())
    if files != sorted(p.relative_to(b) for p in b.rglob("*") if p.is_file()):
        return False
    return all(filecmp.cmp(a / f, b / f, shallow=False) for f in files)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--projects", default=DEFAULT_PROJECTS, help="corpus projects making the library")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=2, help="runs of each kind, taking turns; the best kept")
    ap.add_argument("--before", type=Path, help="another checkout whose --weights auto run is added")
    ap.add_argument("--as-project", action="store_true", help="upgrade the folder as one project of 45 "
                    "skeletons (upgrade_project), not as a library of projects")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        count, root = library(args.projects.split(","), tmp)
        print(f"library: {count} skeletons in {len(args.projects.split(','))} projects"
              f"{', upgraded as one project' if args.as_project else ''}; --jobs {args.jobs}; "
              f"load average {os.getloadavg()[0]:.1f}\n")
        kinds = [("plain (--weights none)", REPO, "none"), ("--weights auto", REPO, "auto")]
        if args.before:
            kinds.append((f"--weights auto, {args.before}", args.before, "auto"))
        best: dict[str, dict] = {}
        for turn in range(args.repeat):
            # the two --weights auto runs swap places every other turn: the run right after the
            # plain one measured several seconds slower on a loaded machine, whichever code it was
            order = list(enumerate(kinds))
            if turn % 2:
                order = order[:1] + order[:0:-1]
            for k, (name, code, weights) in order:
                r = run(code, root, tmp / f"out{k}", weights, args.jobs, args.as_project)
                if name not in best or r["wall"] < best[name]["wall"]:
                    best[name] = r
        plain = best[kinds[0][0]]
        print("| run | wall s | CPU s | weights phase s | meshes weighted | wall / plain | CPU / plain |")
        print("|---|--:|--:|--:|--:|--:|--:|")
        for name, _, _ in kinds:
            r = best[name]
            print(f"| {name} | {r['wall']:.1f} | {r['cpu']:.1f} | {r['weights']:.1f} | {r['weighted']} | "
                  f"{r['wall'] / plain['wall']:.2f} | {r['cpu'] / plain['cpu']:.2f} |")
        if args.before:
            print(f"\noutputs of the two --weights auto runs the same byte for byte: {same_files(tmp / 'out1', tmp / 'out2')}")


if __name__ == "__main__":
    main()
