"""Start-up of the ``spinemesh`` command line, side by side with SkelToJson's CLI.

Each command runs as a user runs it (a fresh process through the venv's console scripts),
``--repeat`` times, the commands taking turns within each round so that the load of a
shared machine hits them alike. Reported per command: best and median wall time, and best and
median CPU time of the child process (user + system, from ``wait4``), which load changes least.
The ratio row compares ``spinemesh convert`` with ``skel-to-json`` (PyPI ``skeltojson``, MIT, in
the dev extra) on the same ``.skel``, both writing JSON: issue 19's CLI-to-CLI goal (>= 1.5x).
This is the one script for that comparison; ``bench_skel_read.py`` compares the readers in
process.

Usage::

    .venv/bin/python benchmarks/bench_startup.py [--repeat 15] [--skel path/to/file.skel]
"""

from __future__ import annotations

import argparse
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
DEFAULT_SKEL = REPO.parent / "shared" / "spine-examples" / "4.2" / "mix-and-match" / "mix-and-match-pro.skel"


def script(name: str) -> str:
    """A console script of this interpreter's environment (``.venv/bin/NAME``)."""
    path = Path(sys.executable).parent / name
    if not path.exists():
        found = shutil.which(name)
        if not found:
            sys.exit(f"{name} is not installed: pip install -e '.[dev]'")
        return found
    return str(path)


#: The children run as a user's shell runs them: with bytecode caching on even where this shell
#: turned it off (PYTHONDONTWRITEBYTECODE), since `pip install` compiles an installed package's
#: .pyc files and the warm-up run writes them for a source checkout.
CHILD_ENV = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}


def run_once(cmd: list[str]) -> tuple[float, float]:
    """Wall and CPU (user + system, from ``wait4``'s resource usage, to the microsecond) seconds
    of one run of ``cmd`` in a child process."""
    start = time.perf_counter()
    child = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=CHILD_ENV)
    stderr = child.stderr.read()
    _, status, usage = os.wait4(child.pid, 0)
    wall = time.perf_counter() - start
    child.returncode = os.waitstatus_to_exitcode(status)
    child.stderr.close()
    if child.returncode != 0:
        sys.exit(f"{' '.join(cmd)} failed: {stderr.decode()[-500:]}")
    return wall, usage.ru_utime + usage.ru_stime


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=15)
    ap.add_argument("--skel", type=Path, default=DEFAULT_SKEL)
    args = ap.parse_args()
    if not args.skel.is_file():
        sys.exit(f"{args.skel} not found; give --skel")
    tmp = Path(tempfile.mkdtemp(prefix="bench-startup-"))
    ours, theirs = script("spinemesh"), script("skel-to-json")
    commands = {
        "python -c pass (interpreter alone)": [sys.executable, "-c", "pass"],
        "spinemesh --help": [ours, "--help"],
        "spinemesh --version": [ours, "--version"],
        "spinemesh upgrade --help": [ours, "upgrade", "--help"],
        f"spinemesh convert {args.skel.name} out.json": [ours, "convert", str(args.skel), str(tmp / "ours.json")],
        f"skel-to-json {args.skel.name} -o out.json": [theirs, str(args.skel), "-o", str(tmp / "theirs.json")],
    }
    for cmd in commands.values():  # warm the file cache and the .pyc files
        run_once(cmd)
    walls: dict[str, list[float]] = {k: [] for k in commands}
    cpus: dict[str, list[float]] = {k: [] for k in commands}
    for _ in range(args.repeat):
        for name, cmd in commands.items():
            wall, cpu = run_once(cmd)
            walls[name].append(wall)
            cpus[name].append(cpu)
    shutil.rmtree(tmp)

    print(f"{args.repeat} runs each, taking turns; {os.cpu_count()} CPUs, load average "
          f"{os.getloadavg()[0]:.1f}\n")
    print(f"| {'command':<52} | best wall ms | median wall ms | best CPU ms | median CPU ms |")
    print(f"|{'-' * 54}|-------------:|---------------:|------------:|--------------:|")
    for name in commands:
        print(f"| {name:<52} | {1000 * min(walls[name]):12.0f} | {1000 * statistics.median(walls[name]):14.0f} "
              f"| {1000 * min(cpus[name]):11.0f} | {1000 * statistics.median(cpus[name]):13.0f} |")
    conv, ref = list(commands)[-2], list(commands)[-1]
    print(f"\nconvert CLI-to-CLI, skel-to-json time / spinemesh time: best wall "
          f"{min(walls[ref]) / min(walls[conv]):.2f}x, median wall "
          f"{statistics.median(walls[ref]) / statistics.median(walls[conv]):.2f}x, best CPU "
          f"{min(cpus[ref]) / min(cpus[conv]):.2f}x, median CPU "
          f"{statistics.median(cpus[ref]) / statistics.median(cpus[conv]):.2f}x")


if __name__ == "__main__":
    main()
