"""Benchmark ``spinemesh dataset``: samples per second, memory, and projections to 100k / 1M.

Builds fresh data sets (in a temporary folder) from ``../shared/spine-examples`` and from
``../shared/spine-corpus``, with each ``--jobs`` value, then re-runs one (resume: adds
nothing) and reads it back as a training loader would.

Run::

    .venv/bin/python benchmarks/bench_dataset.py                 # jobs 1 and 2
    .venv/bin/python benchmarks/bench_dataset.py --jobs 2        # quicker
    .venv/bin/python benchmarks/bench_dataset.py --compare-png   # PNG writers side by side, jobs 1

Prints one table per run: samples, wall seconds, samples/s (wall), CPU seconds (all
processes) and samples per CPU-second, peak memory (parent process; all processes
together), the parent's memory at each quarter of the projects (flat = does not grow with
the corpus), bytes on disk per sample; then projections to 100,000 and 1,000,000 samples.
The machine is shared: the 1-minute load average is printed with each run, and samples
per CPU-second is the figure that does not depend on it (x 2 cores = the rate on an idle
2-core machine, as the work is spread over whole projects).
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import sys
import tempfile
import threading
import time
from pathlib import Path

import psutil

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from spinemesh.dataset import build_dataset, open_dataset  # noqa: E402

SHARED = REPO.parent / "shared"
CORPORA = {"spine-examples": [SHARED / "spine-examples"], "spine-corpus": [SHARED / "spine-corpus"]}
MB = 1024 * 1024


class MemoryWatch:
    """Polls RSS of this process and of all its children every 50 ms, keeps the peaks."""

    def __init__(self) -> None:
        self.me = psutil.Process()
        self.peak_parent = self.peak_total = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                parent = self.me.memory_info().rss
                total = parent + sum(c.memory_info().rss for c in self.me.children(recursive=True))
            except psutil.Error:
                continue
            self.peak_parent = max(self.peak_parent, parent)
            self.peak_total = max(self.peak_total, total)
            time.sleep(0.05)

    def __enter__(self) -> "MemoryWatch":
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        self._thread.join()


def cpu_seconds() -> float:
    """User + system CPU of this process and of its finished children."""
    me = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return me.ru_utime + me.ru_stime + kids.ru_utime + kids.ru_stime


def folder_bytes(folder: Path) -> int:
    return sum(p.stat().st_size for p in folder.rglob("*") if p.is_file())


def run(name: str, corpora: list[Path], out: Path, jobs: int) -> dict:
    quarters: list[float] = []
    rss = psutil.Process()

    def on_project(project: str, done: int, total: int) -> None:
        if total and done and (done * 4) // total > ((done - 1) * 4) // total:
            quarters.append(rss.memory_info().rss / MB)

    load = os.getloadavg()[0]
    cpu0, t0 = cpu_seconds(), time.perf_counter()
    with MemoryWatch() as mem:
        summary = build_dataset(corpora, out, jobs=jobs, on_project=on_project)
    wall, cpu = time.perf_counter() - t0, cpu_seconds() - cpu0
    return {"name": name, "jobs": jobs, "samples": summary.samples, "projects": summary.projects,
            "wall": wall, "cpu": cpu, "load": load, "peak_parent": mem.peak_parent / MB,
            "peak_total": mem.peak_total / MB, "quarters": quarters,
            "disk": folder_bytes(out), "skipped": dict(summary.skipped)}


def read_back(out: Path) -> tuple[int, float]:
    """Samples per second a loader gets: image + mask (+ mesh) of every row, one process."""
    ds = open_dataset(out)
    t0 = time.perf_counter()
    n = 0
    for row in ds.rows():
        ds.load_image(row)
        ds.load_mask(row)
        ds.load_mesh(row)
        n += 1
    return n, n / (time.perf_counter() - t0)


def pil_png(image) -> bytes:
    """The PNG writer used before (PIL, zlib level 1, adaptive filters), for ``--compare-png``."""
    import io

    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(image).save(buf, format="PNG", compress_level=1)
    return buf.getvalue()


def compare_png() -> None:
    """The corpus built in this process (jobs 1) with the previous PIL writer and the current
    OpenCV one, taking turns, side by side."""
    import spinemesh.dataset.extract as extract

    current = extract.encode_png
    tmp = Path(tempfile.mkdtemp(prefix="bench-dataset-png-"))
    rows = []
    try:
        for writer, fn in (("PIL (before)", pil_png), ("OpenCV (now)", current)):
            extract.encode_png = fn
            try:
                rows.append((writer, run("spine-corpus", CORPORA["spine-corpus"], tmp / writer[:3], 1)))
            finally:
                extract.encode_png = current
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    print(f"\n{'PNG writer':<14} {'load':>5} {'samples':>8} {'wall s':>7} {'samples/s':>9} {'CPU s':>7} "
          f"{'smp/CPU-s':>9} {'peak MB':>8} {'KB/sample':>9}")
    for writer, r in rows:
        print(f"{writer:<14} {r['load']:>5.1f} {r['samples']:>8} {r['wall']:>7.1f} {r['samples'] / r['wall']:>9.0f} "
              f"{r['cpu']:>7.1f} {r['samples'] / r['cpu']:>9.0f} {r['peak_total']:>8.0f} "
              f"{r['disk'] / max(r['samples'], 1) / 1024:>9.1f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--jobs", default="1,2", help="comma-separated worker counts (default 1,2)")
    ap.add_argument("--compare-png", action="store_true", help="only compare the PNG writers (corpus, jobs 1)")
    args = ap.parse_args()
    if args.compare_png:
        compare_png()
        return
    jobs_list = [int(j) for j in args.jobs.split(",")]
    missing = [p for ps in CORPORA.values() for p in ps if not p.is_dir()]
    if missing:
        sys.exit(f"real data absent: {missing[0]}")

    tmp = Path(tempfile.mkdtemp(prefix="bench-dataset-"))
    results = []
    try:
        for jobs in jobs_list:
            for name, corpora in CORPORA.items():
                out = tmp / f"{name}-j{jobs}"
                results.append(run(name, corpora, out, jobs))
        # Resume: the last build again, nothing to add.
        last = results[-1]
        t0 = time.perf_counter()
        again = build_dataset(CORPORA[last["name"]], tmp / f"{last['name']}-j{last['jobs']}", jobs=last["jobs"])
        resume_s = time.perf_counter() - t0
        n_read, read_rate = read_back(tmp / f"{last['name']}-j{last['jobs']}")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)

    print(f"\n{'corpus':<15} {'jobs':>4} {'load':>5} {'samples':>8} {'wall s':>7} {'samples/s':>9} "
          f"{'CPU s':>7} {'smp/CPU-s':>9} {'peak parent MB':>14} {'peak all MB':>11} "
          f"{'parent MB at 25/50/75/100 %':>28} {'KB/sample':>9}")
    for r in results:
        q = "/".join(f"{m:.0f}" for m in r["quarters"])
        print(f"{r['name']:<15} {r['jobs']:>4} {r['load']:>5.1f} {r['samples']:>8} {r['wall']:>7.1f} "
              f"{r['samples'] / r['wall']:>9.0f} {r['cpu']:>7.1f} {r['samples'] / r['cpu']:>9.0f} "
              f"{r['peak_parent']:>14.0f} {r['peak_total']:>11.0f} {q:>28} "
              f"{r['disk'] / max(r['samples'], 1) / 1024:>9.1f}")
    print(f"\nresume of {last['name']} (jobs {last['jobs']}): {again.samples} samples added, "
          f"{again.projects_done_before} projects skipped, {resume_s:.1f} s")
    print(f"read back: {n_read} samples (image + mask + mesh) at {read_rate:.0f} samples/s, one process")

    total_samples = sum(r["samples"] for r in results if r["jobs"] == jobs_list[-1])
    total_cpu = sum(r["cpu"] for r in results if r["jobs"] == jobs_list[-1])
    total_wall = sum(r["wall"] for r in results if r["jobs"] == jobs_list[-1])
    total_disk = sum(r["disk"] for r in results if r["jobs"] == jobs_list[-1])
    per_cpu = total_samples / total_cpu
    print(f"\nboth corpora, jobs {jobs_list[-1]}: {total_samples} samples, {total_samples / total_wall:.0f} "
          f"samples/s wall (shared machine), {per_cpu:.0f} samples per CPU-second "
          f"-> {2 * per_cpu:.0f} samples/s on 2 idle cores (goal: 200)")
    print(f"{'projection':<12} {'wall h (as measured)':>20} {'h on 2 idle cores':>18} {'disk GB':>8} "
          f"{'index hash set MB':>17}")
    for n in (100_000, 1_000_000):
        print(f"{n:<12,} {n / (total_samples / total_wall) / 3600:>20.2f} {n / (2 * per_cpu) / 3600:>18.2f} "
              f"{n * total_disk / total_samples / 1e9:>8.1f} {n * 8 / 1e6:>17.1f}")


if __name__ == "__main__":
    main()
