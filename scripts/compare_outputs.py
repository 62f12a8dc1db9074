"""Run ``spinemesh upgrade`` on a fixed set of real projects, or compare two such runs.

For a change of shape (code moved, same behaviour): run this on the old code, then on the
new, and compare. Every file written must be the same byte for byte; in reports, the
timing fields (``seconds``) are left out of the comparison, and the run's own folder, which
the preview page names, is read as ``<run>``; everything else must match.

Cases: the 4.2 examples folder as a library (with a report), a 3.8 binary skeleton with
a preview, a 4.2 binary skeleton with ``--weights auto`` and a report, a 3.8 JSON skeleton
with editor images, a 3.8 binary skeleton as a dry run with a report, one skeleton file
of a project (only the files it uses are copied), and ``spinemesh weights`` on a 3.8
project. What the commands print is compared too, but for the timing lines.

Usage::

    PYTHONPATH=$PWD nice -n 10 .venv/bin/python scripts/compare_outputs.py run /tmp/before
    # ... change the code ...
    PYTHONPATH=$PWD nice -n 10 .venv/bin/python scripts/compare_outputs.py run /tmp/after
    .venv/bin/python scripts/compare_outputs.py compare /tmp/before /tmp/after

Needs the examples and corpus folders (``SPINE_EXAMPLES``, ``SPINE_CORPUS``, defaults
below); exits 1 when the runs differ.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

EXAMPLES = Path(os.environ.get("SPINE_EXAMPLES", "/work/shared/spine-examples"))
CORPUS = Path(os.environ.get("SPINE_CORPUS", "/work/shared/spine-corpus"))

#: name -> (command, input, extra arguments); outputs go to ``<run>/<name>/out`` and beside it,
#: what the command printed to ``stdout.txt`` and ``stderr.txt``.
CASES = {
    "examples-4.2": ("upgrade", EXAMPLES / "4.2", ["--report", "{dir}/r.json", "--jobs", "2"]),
    "tga-hero": ("upgrade", CORPUS / "tga-hero", ["--preview", "{dir}/preview", "--jobs", "2"]),
    "halloween-weights": ("upgrade", CORPUS / "halloween-creature",
                          ["--weights", "auto", "--report", "{dir}/r.json", "--jobs", "2"]),
    "cat-game-images": ("upgrade", CORPUS / "cat-game", ["--images", "{dir}/images", "--report", "{dir}/r.json"]),
    "bmyq-dry-run": ("upgrade", CORPUS / "bmyq-bigwin", ["--dry-run", "--report", "{dir}/r.json"]),
    "spineboy-one-file": ("upgrade", EXAMPLES / "4.2/spineboy/spineboy-pro.skel", ["--report", "{dir}/r.json"]),
    "isk-slime-weights-command": ("weights", CORPUS / "isk-slime", []),
}

#: Printed lines that hold timings: left out of the comparison.
TIMINGS = re.compile(r"^(read [0-9.]+ s, mesh [0-9.]+ s, write [0-9.]+ s|[0-9.]+ s)$", re.M)


def run(folder: Path) -> None:
    """Upgrade every case into ``folder``; exit statuses go to ``folder/exit-codes.json``."""
    folder.mkdir(parents=True, exist_ok=False)
    spinemesh = Path(sys.executable).with_name("spinemesh")
    codes = {}
    for name, (command, source, extra) in CASES.items():
        case = folder / name
        case.mkdir()
        args = [a.format(dir=case) for a in extra]
        done = subprocess.run([str(spinemesh), command, str(source), "--out", str(case / "out"), *args],
                              capture_output=True, text=True, env={**os.environ, "COLUMNS": "120"})
        codes[name] = done.returncode
        (case / "stdout.txt").write_text(TIMINGS.sub("<timing>", done.stdout))
        (case / "stderr.txt").write_text(TIMINGS.sub("<timing>", done.stderr))
        print(f"{name}: exit {done.returncode}", flush=True)
    (folder / "exit-codes.json").write_text(json.dumps(codes, indent=1))


def without_seconds(value):
    """A report with every ``seconds`` field left out (timings differ from run to run)."""
    if isinstance(value, dict):
        return {k: without_seconds(v) for k, v in value.items() if k != "seconds"}
    if isinstance(value, list):
        return [without_seconds(v) for v in value]
    return value


def differences(a: Path, b: Path) -> list[str]:
    """Every file that is in only one of the runs or differs between them (reports: but for timings)."""
    files_a = {p.relative_to(a) for p in a.rglob("*") if p.is_file()}
    files_b = {p.relative_to(b) for p in b.rglob("*") if p.is_file()}
    found = [f"only in {a}: {p}" for p in sorted(files_a - files_b)]
    found += [f"only in {b}: {p}" for p in sorted(files_b - files_a)]
    for rel in sorted(files_a & files_b):
        if rel.name == "r.json":
            same = without_seconds(json.loads((a / rel).read_text())) == without_seconds(json.loads((b / rel).read_text()))
        else:  # the preview page names its output folder: the runs' folders differ
            same = (a / rel).read_bytes().replace(bytes(a), b"<run>") == (b / rel).read_bytes().replace(bytes(b), b"<run>")
        if not same:
            found.append(f"differs: {rel}")
    return found


def main(argv: list[str]) -> int:
    if len(argv) == 2 and argv[0] == "run":
        run(Path(argv[1]))
        return 0
    if len(argv) == 3 and argv[0] == "compare":
        found = differences(Path(argv[1]), Path(argv[2]))
        print("\n".join(found) if found else "same output (reports compared without timings)")
        return 1 if found else 0
    print(__doc__)
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
