"""The meshing of an upgrade alone: every unique meshing task of the corpus, before and after.

    git worktree add --detach /tmp/main-before main      # the code to compare against
    nice -n 10 .venv/bin/python benchmarks/bench_mesh_tasks.py --before /tmp/main-before
    nice -n 10 .venv/bin/python benchmarks/bench_mesh_tasks.py --list 20      # the slowest tasks
    nice -n 10 .venv/bin/python benchmarks/bench_mesh_tasks.py --profile 30   # cProfile, top 30

The tasks are built as ``upgrade`` builds them (:func:`spinemesh.upgrade.plan.plan_project` of
every project folder of ``../shared/spine-corpus`` and of each Spine version of
``../shared/spine-examples``, default options), kept once per image key and mesher settings, and
cached in ``--tasks`` (a pickle; delete it to build them again). Each side then runs
:func:`spinemesh.upgrade.meshing.mesh_one` over all of them in a fresh process, with the code of
``--before`` or of ``--after`` (default this checkout) on ``PYTHONPATH`` and OpenCV on one
thread, as in an upgrade's worker: the table gives the CPU seconds of the two side by side,
their ratio (before / after, above 1 is faster now), and whether the results are the same (one
digest of every result's vertices, triangles, hull, edges, error, keep reason and measures; the
meshing seconds left out).
"""

from __future__ import annotations

import argparse
import json
import os
import pickle
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"
CORPUS = SHARED / "spine-corpus"
EXAMPLES = SHARED / "spine-examples"
TASKS = Path("/tmp/spinemesh-bench-tasks.pickle")


def project_folders() -> list[Path]:
    """The corpus's project folders, then each example project of every Spine version."""
    corpus = sorted(p for p in CORPUS.iterdir() if p.is_dir()) if CORPUS.is_dir() else []
    examples = sorted(p for v in EXAMPLES.iterdir() if v.is_dir() for p in v.iterdir() if p.is_dir()) \
        if EXAMPLES.is_dir() else []
    return corpus + examples


def collect_tasks(path: Path) -> None:
    """Plan every project (as ``upgrade`` does) and pickle its unique tasks to ``path``."""
    import cv2

    from spinemesh.project import find_project
    from spinemesh.upgrade.options import Options
    from spinemesh.upgrade.plan import plan_project
    from spinemesh.upgrade.report import Result

    cv2.setNumThreads(1)
    tasks: dict = {}
    options = Options()
    for folder in project_folders():
        try:
            plan = plan_project(find_project(folder), options, Result())
        except Exception as e:  # a folder the upgrade refuses is no task; say so and go on
            print(f"  {folder.name}: {type(e).__name__}: {e}", file=sys.stderr)
            continue
        for t in plan.tasks.values():
            tasks.setdefault((t.key, t.settings), t)
    ordered = [tasks[k] for k in sorted(tasks, key=repr)]
    path.write_bytes(pickle.dumps(ordered, protocol=pickle.HIGHEST_PROTOCOL))
    print(f"{len(ordered)} unique tasks from {len(project_folders())} projects -> {path}", file=sys.stderr)


def result_digest(results) -> str:
    """One hash of what the meshes are (every field but the seconds), in task order."""
    import hashlib

    import numpy as np

    h = hashlib.sha256()
    for r in results:
        for name in ("key", "error", "kept", "overruled", "hull", "coverage", "waste"):
            h.update(repr(getattr(r, name)).encode())
        for name in ("vertices", "triangles", "edges"):
            a = getattr(r, name)
            h.update(b"-" if a is None else repr((a.dtype.str, a.shape)).encode() + np.ascontiguousarray(a).tobytes())
    return h.hexdigest()


def time_tasks(path: Path, out: Path) -> None:
    """Child: ``mesh_one`` over every task of ``path``; CPU seconds and digest as JSON into ``out``."""
    import time

    import cv2

    from spinemesh.upgrade.meshing import mesh_one

    cv2.setNumThreads(1)
    tasks = pickle.loads(path.read_bytes())
    mesh_one(tasks[0])  # imports and first-call set-up are not meshing
    results, per_task = [], []
    start = time.process_time()
    for t in tasks:
        t0 = time.process_time()
        results.append(mesh_one(t))
        per_task.append(time.process_time() - t0)
    total = time.process_time() - start
    out.write_text(json.dumps({"cpu": total, "per_task": per_task, "digest": result_digest(results),
                               "keys": [t.key for t in tasks],
                               "sizes": [list(t.rgba.shape[:2]) for t in tasks]}))


def run_side(code: Path, tasks: Path, out: Path) -> dict:
    """``time_tasks`` in a fresh process with ``code`` first on ``PYTHONPATH``."""
    env = dict(os.environ, PYTHONPATH=str(code), OMP_NUM_THREADS="1")
    subprocess.run([sys.executable, str(Path(__file__).resolve()), "--child", str(tasks), str(out)],
                   env=env, check=True, cwd=str(code))
    return json.loads(out.read_text())


def profile(tasks: Path, top: int) -> None:
    """cProfile of ``mesh_one`` over every task, in this process (this checkout's code)."""
    import cProfile
    import pstats

    import cv2

    from spinemesh.upgrade.meshing import mesh_one

    cv2.setNumThreads(1)
    loaded = pickle.loads(tasks.read_bytes())
    prof = cProfile.Profile()
    prof.enable()
    for t in loaded:
        mesh_one(t)
    prof.disable()
    pstats.Stats(prof).sort_stats("cumulative").print_stats(top)
    pstats.Stats(prof).sort_stats("tottime").print_stats(top)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--before", type=Path, help="a checkout of the code to compare against")
    ap.add_argument("--after", type=Path, default=REPO, help="the code measured (default this checkout)")
    ap.add_argument("--tasks", type=Path, default=TASKS, help="the pickled tasks (built when absent)")
    ap.add_argument("--list", type=int, metavar="N", help="the N slowest tasks of --after")
    ap.add_argument("--profile", type=int, metavar="N", help="cProfile of --after's meshing, top N functions")
    ap.add_argument("--child", nargs=2, type=Path, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        time_tasks(*args.child)
        return
    if not args.tasks.exists():
        env = dict(os.environ, PYTHONPATH=str(args.after))
        subprocess.run([sys.executable, "-c", "import sys; sys.path.insert(0, sys.argv[2]); "
                        "import bench_mesh_tasks as b; from pathlib import Path; b.collect_tasks(Path(sys.argv[1]))",
                        str(args.tasks), str(REPO / "benchmarks")], env=env, check=True, cwd=str(args.after))
    if args.profile:
        sys.path.insert(0, str(args.after))
        profile(args.tasks, args.profile)
        return
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        sides = {}
        if args.before:
            sides["before"] = run_side(args.before.resolve(), args.tasks, Path(tmp) / "before.json")
        sides["after"] = run_side(args.after.resolve(), args.tasks, Path(tmp) / "after.json")
    after = sides["after"]
    print(f"tasks: {len(after['per_task'])}  load average: {os.getloadavg()[0]:.2f}")
    print(f"{'':10} {'CPU s':>8}  digest")
    for name, side in sides.items():
        print(f"{name:10} {side['cpu']:8.2f}  {side['digest'][:16]}")
    if "before" in sides:
        before = sides["before"]
        print(f"ratio (before / after): {before['cpu'] / after['cpu']:.2f}x;  same results: "
              f"{'yes' if before['digest'] == after['digest'] else 'NO'}")
    if args.list:
        order = sorted(range(len(after["per_task"])), key=lambda i: -after["per_task"][i])[:args.list]
        print(f"\n{'CPU s':>7} {'before':>7}  {'h x w':>11}  key")
        for i in order:
            b = f"{sides['before']['per_task'][i]:7.3f}" if "before" in sides else f"{'':>7}"
            h, w = after["sizes"][i]
            print(f"{after['per_task'][i]:7.3f} {b}  {h:>5}x{w:<5}  {after['keys'][i]}")


if __name__ == "__main__":
    main()
