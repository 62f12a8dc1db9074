"""What the project commands (``upgrade``, ``weights``, ``pack``) print once a run is done.

Both keep one row per attachment (``skeleton``, ``skin``, ``slot``, ``name``, ``status``,
``reason``): a table per skeleton, one line per attachment that failed (on stderr), a count
per reason for those left alone on purpose, and the run's errors. Names and reasons come
from the project: they are never read as rich markup, and their control characters are printed
as escapes (:func:`~spinemesh.errors.escaped`: a newline in a name cannot forge a line). rich
is imported on first use.
"""

from __future__ import annotations

import re
from typing import Callable, Sequence

from ..errors import escaped
from ..words import counted
from ._app import console, console_text, err_console


def skeleton_table(title: str, columns: Sequence[str], rows: Sequence, cells: Callable[[list], Sequence[str]],
                   skeletons: Sequence[str] = (), width: int | None = None):
    """A rich table with a line per skeleton: its name, then ``cells(its rows)`` under ``columns``.

    ``skeletons`` are listed too when no row names them (``cells([])``). Names are shortened
    (:func:`spinemesh.runs.short_names`) so that the table fits ``width`` columns (default:
    the console's) and every line still names its own skeleton.
    """
    from rich.table import Table

    from ..runs import short_names

    by_skel: dict[str, list] = {}
    for row in rows:
        by_skel.setdefault(row.skeleton, []).append(row)
    for name in skeletons:
        by_skel.setdefault(name, [])
    # a cell is its text plus a space each side and a border: 3 characters more
    room = (width or console.width) - sum(len(col) + 3 for col in columns) - 4
    shown = short_names(list(by_skel), max(room, len("skeleton")))
    table = Table(title=title)
    table.add_column("skeleton", justify="left", no_wrap=True)
    for col in columns:
        table.add_column(col, justify="right", no_wrap=True)
    for name, group in by_skel.items():
        table.add_row(console_text(shown[name]), *cells(group))
    return table


def print_left_alone(rows: Sequence, errors: Sequence[str], skipped: str, skipped_label: str, failed_label: str,
                     reason: Callable[[object], str] = lambda row: row.reason) -> None:
    """The failed rows on stderr, one line per reason (the first row named, and how many more:
    a broken page fails every attachment it holds, hundreds of lines that say one thing), a count
    per ``reason(row)`` of the rows whose status is ``skipped``, the errors.

    ``skipped_label`` and ``failed_label`` begin the lines (``kept as region``, ``left a region``).
    """

    from ..runs import reason_groups

    failed: dict[str, list] = {}
    for row in rows:
        if row.status == "failed":
            failed.setdefault(row.reason, []).append(row)
    for why, group in failed.items():
        row = group[0]
        more = f" and {len(group) - 1} more" if len(group) > 1 else ""
        err_console.print(f"[yellow]{failed_label}:[/] " + console_text(
            f"{row.skeleton} skin {row.skin!r} slot {row.slot!r} attachment {row.name!r}{more}: {why}"),
            highlight=False)
    for why, n, others in reason_groups([reason(row) for row in rows if row.status == skipped]):
        more = f"; {others:,} of them with other figures" if others else ""
        console.print(f"{skipped_label}: {n} ({escaped(why)}{more})", highlight=False, markup=False)
    print_errors(errors)


def say_preview(where, detail: str = "", what: str = "preview") -> None:
    """The line that says where a run's ``--preview`` is (the page to open, or the pictures' folder),
    with ``detail`` in brackets: ``pack`` and ``weights`` wrote theirs without a word of it.
    ``what``: the output named, ``images`` for ``upgrade --images``' folder."""
    console.print(escaped(f"{what}: {where}" + (f" ({detail})" if detail else "")), highlight=False, markup=False)


def say_files_outside(library, projects: Sequence | None) -> None:
    """The one line on the files of a library that lie in no project, which a library run
    (``upgrade``, ``pack``) does not copy: how many, and the first; a ``NOTES.txt`` beside the
    projects was left out without a word. ``projects`` None: one project, copied whole, nothing said."""
    from pathlib import Path

    from ..upgrade.library import files_outside_projects

    outside = files_outside_projects(library, projects) if projects is not None else []
    if outside:
        first = outside[0].relative_to(Path(library)).as_posix()
        more = f" and {len(outside) - 1:,} more" if len(outside) > 1 else ""
        console.print(escaped(f"not copied: {counted(len(outside), 'file')} in no project ({first}{more})"),
                      highlight=False, markup=False)


def print_warnings(warnings: Sequence[str]) -> None:
    """Each of a run's warnings on stderr as one line, ``warning: ...`` (each names its file)."""
    for warning in warnings:
        err_console.print(f"[yellow]warning:[/] {console_text(warning)}", highlight=False)


def print_errors(errors: Sequence[str]) -> None:
    """Each of a run's errors on stderr as one line, ``error: ...`` (each names its file)."""

    for e in errors:
        err_console.print(f"[red]error:[/] {console_text(e)}", highlight=False, soft_wrap=True)


#: Why a mesh the bone choice gives one bone follows it alone (``auto``, ``rule``, ``learned``):
#: not "no bone crosses their art": bones over the art are left out too when unlikely (another part).
ONE_BONE_CHOSEN = "no other bone is likely to bend their art"


def bending_said(bones: Sequence[int], one_bone: str = ONE_BONE_CHOSEN) -> str:
    """How many weighted meshes bend (two bones or more) and over how many bones, and how many
    follow one bone, to follow a count of weighted meshes; ``""`` for none. ``bones``: each
    weighted mesh's number of bones; ``one_bone``: why, when every mesh follows one bone.

    Examples
    --------
    >>> bending_said([1, 3, 3, 2])
    ': 3 bend over 2-3 bones (median 3), 1 follow one bone'
    >>> bending_said([1, 1])
    ', each to one bone (no other bone is likely to bend their art)'
    """
    import statistics

    bending = [n for n in bones if n > 1]
    if bending:
        spread = f"{min(bending)}-{max(bending)}" if min(bending) < max(bending) else f"{min(bending)}"
        return (f": {len(bending)} bend over {spread} bones (median {statistics.median(bending):g}), "
                f"{len(bones) - len(bending)} follow one bone")
    return f", each to one bone ({one_bone})" if bones else ""


def weights_lines(targets: Sequence) -> list[str]:
    """What ``upgrade --weights auto`` did, in a few lines (none when weights were not asked for).

    Counts the new meshes bound to bones, how many bones they follow (those over two or more
    bend), the regions meshed only because they bend, those put back as regions because their
    mesh got one bone, and the meshes left unweighted, by reason.
    """
    from ..runs import reason_groups

    asked = [t for t in targets if t.weights is not None]
    if not asked:
        return []
    meshed = [t for t in asked if t.status == "meshed"]
    weighted = [t for t in meshed if t.weights.get("status") == "weighted"]
    line = (f"bones: {len(weighted)} of {len(meshed)} new meshes weighted"
            f"{bending_said([len(t.weights.get('bones') or {}) for t in weighted])}")
    to_bend = sum(bool(t.weights.get("meshed_to_bend")) for t in meshed)
    back = sum(t.status == "kept" and t.weights.get("meshed_to_bend") is False for t in asked)
    if to_bend:
        line += (f"; {to_bend} of those that bend meshed only to bend (without --weights auto they would "
                 "stay regions, not worth meshing)")
    lines = [line]
    if back:
        lines.append(f"bones: {back} regions that might bend stayed regions (their mesh follows one bone)")
    done = {id(t) for t in weighted}
    unweighted = [t.weights.get("reason") or t.weights.get("status", "") for t in meshed if id(t) not in done]
    # one line per reason, the bones and constraints it names aside: a 3.5 skeleton's IK legs and
    # head said "1 meshes not weighted (... bone 'r_heel' ... 'R_HEEL_IK' ...)" a dozen times over
    by_words: dict[str, list[str]] = {}
    for why in unweighted:
        by_words.setdefault(_QUOTED.sub("'…'", why), []).append(why)
    for whys in sorted(by_words.values(), key=len, reverse=True):
        why = reason_groups(whys)[0][0]
        others = len(whys) - whys.count(why)
        more = f"; {others:,} of them with other names" if others else ""
        lines.append(f"bones: {counted(len(whys), 'mesh', 'meshes')} not weighted ({why}{more})")
    return lines


#: A name a reason quotes (a bone's, a constraint's): reasons that differ only there are one kind.
_QUOTED = re.compile(r"'[^']*'")
