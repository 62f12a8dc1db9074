"""Read speed of our ``.skel`` reader against SkelToJson, on every 4.2 example, same run;
then our read and write of the 4.3 files.

SkelToJson (PyPI ``skeltojson``, MIT) is the only other pure-Python reader of 4.2 binaries;
install it with ``pip install -e .[dev]``. Each file is read ``--repeat`` times by each
reader, taking turns, and the best CPU time is kept (``--wall`` for wall time). Peak
Python memory of one read is measured separately with tracemalloc, which slows reading.

No editor-exported 4.3 ``.skel`` exists in ``../shared``: the 4.3 rows are the 4.3 corpus
projects' JSON written as ``.skel`` by our writer (SkelToJson does not read 4.3; its
column says what it does with them).

Usage::

    .venv/bin/python benchmarks/bench_skel_read.py [--repeat 7] [--wall] [--examples ../shared/spine-examples]
"""

from __future__ import annotations

import argparse
import gc
import statistics
import sys
import time
import tracemalloc
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from spinemesh.skeleton_binary import encode_skel, read_skel  # noqa: E402


def best_times(fns, data: bytes, repeat: int, clock=time.process_time) -> list[float]:
    """Best time of each ``fn(data)`` over ``repeat`` rounds, in seconds.

    The clock is this process's CPU time by default: on a machine shared with other jobs,
    wall time mostly measures waiting for a core. The functions take turns within each
    round, so that what load remains hits them alike.
    """
    best = [float("inf")] * len(fns)
    for _ in range(repeat):
        for i, fn in enumerate(fns):
            gc.collect()
            t = clock()
            fn(data)
            best[i] = min(best[i], clock() - t)
    return best


def peak_memory(fn, data: bytes) -> int:
    """Peak bytes allocated by Python during ``fn(data)``."""
    gc.collect()
    tracemalloc.start()
    fn(data)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return peak


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--examples", type=Path, default=REPO.parent / "shared" / "spine-examples")
    ap.add_argument("--corpus", type=Path, default=REPO.parent / "shared" / "spine-corpus")
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--wall", action="store_true", help="time with the wall clock instead of CPU time")
    args = ap.parse_args()
    clock = time.perf_counter if args.wall else time.process_time
    try:
        from SkelToJson import SkelConverter
    except ImportError:
        sys.exit("SkelToJson is not installed: pip install -e .[dev]")

    def theirs(data: bytes) -> dict:
        return SkelConverter().convert(data)

    files = sorted((args.examples / "4.2").glob("*/*.skel"))
    if not files:
        sys.exit(f"no 4.2 .skel files under {args.examples}")
    print(f"{len(files)} Spine 4.2 .skel files, best of {args.repeat} runs each, "
          f"{'wall' if args.wall else 'CPU'} time\n")
    head = f"{'file':34} {'KiB':>6} {'ours ms':>8} {'SkelToJson ms':>14} {'speed-up':>9} {'ours write ms':>14}"
    print(head)
    print("-" * len(head))
    rows = []
    for path in files:
        data = path.read_bytes()
        doc = read_skel(data)
        ours, other, write = best_times([read_skel, theirs, lambda _d: encode_skel(doc)], data, args.repeat, clock)
        rows.append((path, len(data), ours, other, write))
        print(f"{path.name:34} {len(data) / 1024:6.1f} {ours * 1e3:8.2f} {other * 1e3:14.2f} "
              f"{other / ours:8.1f}x {write * 1e3:14.2f}")
    total_ours = sum(r[2] for r in rows)
    total_other = sum(r[3] for r in rows)
    print("-" * len(head))
    print(f"{'total':34} {sum(r[1] for r in rows) / 1024:6.1f} {total_ours * 1e3:8.2f} "
          f"{total_other * 1e3:14.2f} {total_other / total_ours:8.1f}x {sum(r[4] for r in rows) * 1e3:14.2f}")
    print(f"\nspeed-up: total {total_other / total_ours:.1f}x, "
          f"median per file {statistics.median(r[3] / r[2] for r in rows):.1f}x, "
          f"slowest file {min(r[3] / r[2] for r in rows):.1f}x (goal: at least 3x)")

    biggest = max(rows, key=lambda r: r[1])[0]
    data = biggest.read_bytes()
    mine, other = peak_memory(read_skel, data), peak_memory(theirs, data)
    print(f"peak Python memory reading {biggest.name}: ours {mine / 2**20:.1f} MiB, "
          f"SkelToJson {other / 2**20:.1f} MiB ({other / mine:.1f}x)")
    bench_43(args.corpus, args.repeat, clock, theirs)


def bench_43(corpus: Path, repeat: int, clock, theirs) -> None:
    """Our read and write of every 4.3 skeleton of the corpus, written as ``.skel``."""
    from spinemesh.skeleton import is_binary_skeleton, load_skeleton, spine_version

    docs = []
    for js in sorted(corpus.rglob("*.json")):
        if js.name.endswith(".source.json") or is_binary_skeleton(js):
            continue
        doc = load_skeleton(js)
        if spine_version(doc).startswith("4.3"):
            docs.append((js, doc))
    if not docs:
        print(f"\nno 4.3 skeletons under {corpus}")
        return
    print(f"\n{len(docs)} Spine 4.3 skeletons (corpus JSON written as .skel by us), best of {repeat} runs\n")
    head = f"{'file':34} {'KiB':>6} {'ours read ms':>13} {'ours write ms':>14} {'SkelToJson':>24}"
    print(head)
    print("-" * len(head))
    for js, doc in docs:
        data = encode_skel(doc)
        try:
            theirs(data)
            verdict = "reads it"
        except Exception as e:  # whatever it raises: it is only reported
            verdict = f"fails ({type(e).__name__})"
        read, write = best_times([read_skel, lambda _d: encode_skel(doc)], data, repeat, clock)
        print(f"{js.stem + '.skel':34} {len(data) / 1024:6.1f} {read * 1e3:13.2f} {write * 1e3:14.2f} {verdict:>24}")


if __name__ == "__main__":
    main()
