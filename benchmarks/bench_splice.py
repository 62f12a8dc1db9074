"""Writing a changed skeleton into its original text: all edits in one pass against one edit at a time.

:func:`spinemesh.json_style.splice` rewrites only the values that changed. It used to put each
replacement into the text by rebuilding the whole text (quadratic in the number of edits); it
now joins the unchanged stretches and the replacements once. Both are timed here on the same
edits: a skeleton of N region attachments whose every attachment changes (as ``upgrade``
changes every region into a mesh). CPU time, best of ``--repeat``.

Usage::

    .venv/bin/python benchmarks/bench_splice.py [--counts 2000 20000] [--repeat 3]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from spinemesh.json_style import _WS, _changes, detect_style, splice  # noqa: E402


def one_edit_at_a_time(text: str, new) -> str:
    """The earlier way: every edit rebuilds the whole text."""
    style = detect_style(text)
    offset = _WS.match(text, 0).end()
    edits: list = []
    _changes(text, offset, json.loads(text), new, style, edits)
    for start, end, replacement in sorted(edits, reverse=True):
        text = text[:start] + replacement + text[end:]
    return text


def documents(count: int) -> tuple[str, dict]:
    region = {"x": 1.5, "y": -2, "width": 76, "height": 72}
    old = {"skeleton": {"spine": "4.2.40"}, "bones": [{"name": "root"}],
           "skins": [{"name": "default", "attachments": {"s": {f"a{i}": dict(region) for i in range(count)}}}]}
    text = json.dumps(old, indent="\t")
    new = json.loads(text)
    for att in new["skins"][0]["attachments"]["s"].values():
        att.update(type="mesh", uvs=[0, 0, 1, 0, 1, 1], triangles=[0, 1, 2], vertices=[0, 0, 76, 0, 76, 72])
    return text, new


def best(fn, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.process_time()
        fn()
        times.append(time.process_time() - t0)
    return min(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--counts", type=int, nargs="+", default=[2000, 20000])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    print(f"{'attachments':>11} {'text MB':>8} {'one at a time s':>16} {'one pass s':>11} {'ratio':>8}")
    for n in args.counts:
        text, new = documents(n)
        assert one_edit_at_a_time(text, new) == splice(text, new)
        slow = best(lambda: one_edit_at_a_time(text, new), args.repeat)
        fast = best(lambda: splice(text, new), args.repeat)
        print(f"{n:>11,} {len(text) / 1e6:>8.2f} {slow:>16.3f} {fast:>11.3f} {slow / fast:>7.1f}x")


if __name__ == "__main__":
    main()
