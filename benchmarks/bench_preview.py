"""Weight of ``upgrade --preview`` and the time headless Chromium needs to open it, against an
older spinemesh.

The projects given (default: six corpus projects, 46 skeletons on 24 atlas pages) are copied
into one project in a temporary folder (a ``.source.json`` at its root makes it one project, as
a game repository holds them), upgraded once (``--weights`` as given), and the preview written
by this tree and, with ``--compare-with DIR``, by the spinemesh in ``DIR`` (a checkout, for
example ``git worktree add /tmp/old <commit>``), each into its own folder from the same
upgrade. Printed side by side: the largest HTML page, all HTML, the largest script (the
player's data for one animation, loaded when chosen), every file of the preview, the seconds
to write it (wall, and CPU: user and system of the writing process and its workers, which a
machine shared with other work disturbs less), and the seconds headless Chromium needs to open the index beyond a blank
page (``--dump-dom`` wall time, median of ``--repeat`` runs, minus that of ``about:blank``).
With ``--jobs N`` (N > 1), this tree's preview is also written over N processes (what
``upgrade --preview --jobs N`` does), in a column of its own, and so is the compared one's. Compared, it then says whether the
player's data (``data/``: every frame of both sides, and the attachment tables) of each other
column is byte for byte the same as the first column's, and else which files differ; each ratio
is the first column's figure over that column's.

Usage::

    .venv/bin/python benchmarks/bench_preview.py [PROJECT ...] [--compare-with DIR] [--jobs N] [--weights auto] [--repeat 5]
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
CORPUS = REPO.parent / "shared" / "spine-corpus"
DEFAULT = ["stake-symbols", "kraken-symbols", "gtl-symbols", "dm-symbols", "wg-symbols", "bubble-fx"]

_WRITE = """
import json, os, pickle, sys, time
from spinemesh.upgrade.preview import write_preview
result = pickle.load(open(sys.argv[1], "rb"))
t0, c0 = time.perf_counter(), sum(os.times()[:4])
write_preview(result, sys.argv[2], sys.argv[3], sys.argv[4], **({"jobs": int(sys.argv[5])} if sys.argv[5] != "1" else {}))
print(json.dumps({"seconds": time.perf_counter() - t0, "cpu": sum(os.times()[:4]) - c0}))
"""


def build_project(projects: list[Path], where: Path) -> Path:
    """The projects copied side by side into one project folder under ``where``."""
    root = where / "project"
    for p in projects:
        shutil.copytree(p, root / p.name, ignore=shutil.ignore_patterns(".source.json"))
    (root / ".source.json").write_text("{}\n")
    return root


def write_with(tree: Path, result_file: Path, project: Path, out: Path, folder: Path, jobs: int = 1) -> dict:
    """Write the preview with the spinemesh of ``tree`` over ``jobs`` processes: its wall
    ``seconds`` and ``cpu`` seconds (user and system, the workers' included once they end)."""
    r = subprocess.run([sys.executable, "-c", _WRITE, str(result_file), str(project), str(out), str(folder), str(jobs)],
                       capture_output=True, text=True, env={**os.environ, "PYTHONPATH": str(tree)}, timeout=3600,
                       cwd=folder.parent)  # not this tree's folder, which python -c would import first
    if r.returncode:
        sys.exit(f"the preview of {tree} failed:\n{r.stderr[-3000:]}")
    return json.loads(r.stdout.strip().splitlines()[-1])


def open_seconds(url: str, where: Path, repeat: int) -> float:
    """Median wall seconds of ``chromium --dump-dom url``."""
    browser = shutil.which("chromium") or shutil.which("chromium-browser")
    if browser is None:
        sys.exit("chromium is not installed (scripts/setup.sh installs it)")
    times = []
    for i in range(repeat):
        t0 = time.perf_counter()
        subprocess.run([browser, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
                        "--disable-background-networking", f"--user-data-dir={where / f'profile{i}'}",
                        "--dump-dom", url], capture_output=True, timeout=300, env={**os.environ, "HOME": str(where)})
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def same_data(a: Path, b: Path) -> str:
    """Whether the player's data (``data/``) of two previews is byte for byte the same: one line."""
    files = {p: sorted(q.relative_to(p / "data") for q in (p / "data").rglob("*") if q.is_file()) for p in (a, b)}
    if files[a] != files[b]:
        return f"player data: the two previews hold other files ({len(files[a])} and {len(files[b])})"
    differ = [str(r) for r in files[a] if (a / "data" / r).read_bytes() != (b / "data" / r).read_bytes()]
    return (f"player data: {len(files[a])} files, byte for byte the same" if not differ else
            f"player data: {len(differ)} of {len(files[a])} files differ, e.g. {', '.join(differ[:3])}")


def weigh(folder: Path) -> dict:
    files = [p for p in folder.rglob("*") if p.is_file()]
    pages = [p for p in files if p.suffix == ".html"]
    scripts = [p.stat().st_size for p in files if p.suffix == ".js"]
    return {"largest page": max(p.stat().st_size for p in pages), "all HTML": sum(p.stat().st_size for p in pages),
            "pages": len(pages), "largest script": max(scripts, default=0), "all files": sum(p.stat().st_size for p in files),
            "files": len(files)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("projects", nargs="*", type=Path)
    ap.add_argument("--compare-with", type=Path, metavar="DIR", help="a spinemesh checkout to compare with")
    ap.add_argument("--jobs", type=int, default=1, help="also write this tree's preview over N processes")
    ap.add_argument("--weights", default="none", choices=["none", "auto"])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    projects = args.projects or [CORPUS / name for name in DEFAULT]
    sys.path.insert(0, str(REPO))
    import pickle

    from spinemesh.project import find_project
    from spinemesh.upgrade import Options, upgrade_project

    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        project = build_project(projects, tmp)
        skeletons = len(find_project(project).skeletons)
        print(f"{len(projects)} projects, {skeletons} skeleton files, upgraded with --weights {args.weights} ...",
              flush=True)
        t0 = time.perf_counter()
        result = upgrade_project(project, tmp / "out", Options(weights=args.weights, jobs=1))
        print(f"upgrade: {time.perf_counter() - t0:.0f} s, {result.counts()}", flush=True)
        result_file = tmp / "result.pickle"
        result_file.write_bytes(pickle.dumps(result))
        trees = ({"this tree": (REPO, 1)} | ({f"--jobs {args.jobs}": (REPO, args.jobs)} if args.jobs > 1 else {})
                 | ({"compared": (args.compare_with.resolve(), 1)} if args.compare_with else {})
                 | ({f"compared -j{args.jobs}": (args.compare_with.resolve(), args.jobs)}
                    if args.compare_with and args.jobs > 1 else {}))
        rows, folders = {}, {}
        blank = open_seconds("about:blank", tmp / "blank", args.repeat)
        for name, (tree, jobs) in trees.items():
            folder = tmp / f"preview-{name.replace(' ', '-')}"
            written = write_with(tree, result_file, project, tmp / "out", folder, jobs)
            folders[name] = folder
            rows[name] = {**weigh(folder), "write s": written["seconds"], "write cpu s": written["cpu"],
                          "open s": open_seconds((folder / "index.html").as_uri(), tmp / name.replace(" ", "-"),
                                                 args.repeat) - blank}
        first = next(iter(folders))
        same = [f"{name} against {first}: {same_data(folders[first], folder)}"
                for name, folder in folders.items() if name != first]
    names = list(rows)
    print(f"\n{'':<14}" + "".join(f"{n:>16}" for n in names) + "".join(f"{'ratio':>8}" for _ in names[1:]))
    for key in rows[names[0]]:
        vals = [rows[n][key] for n in names]
        fmt = (lambda v: f"{v:>16.2f}") if key.endswith(" s") else (lambda v: f"{v:>16,}")
        ratios = "".join(f"{vals[0] / v:>8.3f}" if v else f"{'':>8}" for v in vals[1:])
        print(f"{key:<14}" + "".join(fmt(v) for v in vals) + ratios)
    print(f"(open s: beyond a blank page, {blank:.2f} s; median of {args.repeat})")
    for line in same:
        print(line)


if __name__ == "__main__":
    main()
