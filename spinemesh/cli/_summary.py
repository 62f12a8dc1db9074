"""What the project commands (``upgrade``, ``weights``) print once a run is done.

Both keep one row per attachment (``skeleton``, ``skin``, ``slot``, ``name``, ``status``,
``reason``): a table per skeleton, one line per attachment that failed (on stderr), a count
per reason for those left alone on purpose, and the run's errors. Names and reasons come
from the project: they are never read as rich markup, and their control characters are printed
as escapes (:func:`~spinemesh.errors.escaped`: a newline in a name cannot forge a line). rich
is imported on first use.
"""

from __future__ import annotations

from typing import Callable, Sequence

from ..errors import escaped
from ._app import console, err_console


def skeleton_table(title: str, columns: Sequence[str], rows: Sequence, cells: Callable[[list], Sequence[str]]):
    """A rich table with a line per skeleton: its name, then ``cells(its rows)`` under ``columns``."""
    from rich.markup import escape
    from rich.table import Table

    table = Table(title=title)
    for col in ("skeleton", *columns):
        table.add_column(col, justify="right" if col != "skeleton" else "left")
    by_skel: dict[str, list] = {}
    for row in rows:
        by_skel.setdefault(row.skeleton, []).append(row)
    for name, group in by_skel.items():
        table.add_row(escape(escaped(name)), *cells(group))
    return table


def print_left_alone(rows: Sequence, errors: Sequence[str], skipped: str, skipped_label: str, failed_label: str,
                     reason: Callable[[object], str] = lambda row: row.reason) -> None:
    """Every failed row on stderr, a count per ``reason(row)`` of the rows whose status is ``skipped``, the errors.

    ``skipped_label`` and ``failed_label`` begin the lines (``kept as region``, ``left a region``).
    """
    from rich.markup import escape

    reasons: dict[str, int] = {}
    for row in rows:
        if row.status == skipped:
            reasons[reason(row)] = reasons.get(reason(row), 0) + 1
        elif row.status == "failed":
            err_console.print(f"[yellow]{failed_label}:[/] " + escape(escaped(
                f"{row.skeleton} skin {row.skin!r} slot {row.slot!r} attachment {row.name!r}: {row.reason}")),
                highlight=False)
    for why, n in sorted(reasons.items()):
        console.print(f"{skipped_label}: {n} ({why})", highlight=False, markup=False)
    for e in errors:
        err_console.print(f"[red]error:[/] {escape(escaped(e))}", highlight=False)
