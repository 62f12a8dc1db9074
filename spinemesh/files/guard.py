"""The output guard: nothing is written inside an input project, onto an input file, or through
a symlink (:class:`OutputGuard`; every command checks each path it writes before any work,
:func:`check_outputs`), and no two outputs are one file.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Iterable
from pathlib import Path

from ..errors import OutputError
from .disk import file_behind
from .inputs import backslash_hint, special_kind
from .inside import check_name_lengths, is_within, real
from .names import portable_name
from .walk import walk_folder

#: What a command whose files are what it makes says, once, where standard output is closed (``>&-``,
#: a daemon): it runs whole (:meth:`OutputGuard.check_standard_output`).
STANDARD_OUTPUT_CLOSED = "standard output is closed: this command's table is not written (its files are)"

#: Files of one input folder compared with a file written in place that has several names
#: (:meth:`OutputGuard.check_in_place`): far above a project's hundreds.
MAX_LINK_SEARCH = 100_000


class OutputGuard:
    """The one check made before writing any file.

    Parameters
    ----------
    inputs : iterable of path
        Input files and folders (projects, images folders, source files). Nothing is written
        onto an input file or anywhere inside an input folder.
    root : path, optional
        The output folder, when a command writes a tree of files. No path below it may pass
        through a symlink (a symlink planted in the output folder would redirect the write)
        or climb out of it.

    Notes
    -----
    Paths are compared after resolving symlinks (``os.path.realpath``), never as strings,
    so ``p-evil/`` is not mistaken for being inside ``p/`` and ``out/link -> p/`` is caught.
    """

    def __init__(self, inputs: Iterable[str | Path | None], root: str | Path | None = None):
        self.inputs = [(Path(p), real(p)) for p in inputs if p is not None]
        self.root = Path(root) if root is not None else None

    def check_folder(self, folder: str | Path, what: str = "output folder", may_hold_inputs: bool = True) -> Path:
        """Refuse an output folder that is an existing file, an input, or inside an input.

        ``may_hold_inputs=False`` also refuses a folder that holds an input (for an output
        folder that may be emptied as a whole, like ``upgrade --overwrite`` does).
        """
        folder = Path(folder)
        check_name_lengths(folder, what=what)
        refuse_windows_path(folder, what)
        if folder.is_symlink():
            raise OutputError(f"{what} is a symlink; give the real folder", folder)
        if folder.exists() and not folder.is_dir():
            raise OutputError(f"{what} exists and is not a folder", folder)
        self._refuse_inputs(folder, what)
        if not may_hold_inputs:
            target = real(folder)
            for given, inp in self.inputs:
                if target in inp.parents:
                    raise OutputError(f"{what} holds the input {given}; choose a folder beside it", folder)
        return folder

    def check(self, path: str | Path, what: str = "output file") -> Path:
        """Return ``path`` if it may be written; raise :class:`OutputError` otherwise."""
        path = Path(path)
        check_name_lengths(path, what=what)
        if self.root is None:  # a path the user gave (below the root: a project's file names)
            refuse_windows_path(path, what)
        if path.is_symlink():
            raise OutputError(f"{what} is a symlink; refusing to write through it", path)
        if path.is_dir():
            raise OutputError(f"{what} is a folder", path)
        if path.exists() and not path.is_file():
            # written whole and renamed into place, an output replaces what is there: as root, /dev/null itself
            raise OutputError(f"{what} is {special_kind(os.stat(path).st_mode)}, not a regular file; an output "
                              "replaces its file whole, so name a regular file", path)
        if self.root is not None:
            lexical = Path(os.path.abspath(path))
            root = Path(os.path.abspath(self.root))
            try:
                rel = lexical.relative_to(root)
            except ValueError:
                raise OutputError(f"{what} would lie outside the output folder {self.root}", path) from None
            if ".." in rel.parts:
                raise OutputError(f"{what} would lie outside the output folder {self.root}", path)
            if real(path) != real(root) / rel:
                raise OutputError(f"{what} passes through a symlink inside the output folder", path)
        self._refuse_inputs(path, what)
        return path

    def check_in_place(self, path: str | Path, what: str) -> Path:
        """:meth:`check` of a file written in place, not replaced by a rename (standard output
        redirected to it by a shell): also refused when it is an input file, or a file inside an
        input folder, under another name (a hard link), since writing it writes that input. A
        rename breaks such a link, so files written atomically need no such check.

        Only a file of several names is looked for, among at most :data:`MAX_LINK_SEARCH` files
        of each input folder (a project has hundreds).
        """
        path = self.check(path, what)
        try:
            st = os.stat(path)
        except OSError:
            return path
        if st.st_nlink < 2:
            return path
        for given, inp in self.inputs:
            files = [inp] if not inp.is_dir() else (f for _, _, fs in walk_folder(inp, hidden=True) for f in fs)
            for n, f in enumerate(files):
                if n >= MAX_LINK_SEARCH:
                    break
                try:
                    same = os.path.samestat(os.stat(f), st)
                except OSError:
                    continue
                if same:
                    shown = given if f == inp else f
                    raise OutputError(f"{what} is the input {shown} under another name (a hard link); the input "
                                      "is never overwritten", path)
        return path

    def check_standard_output(self, product: str | None = None) -> None:
        """:meth:`check_in_place` of the file behind standard output, where a shell redirected it
        to one and the system names it (Linux): a command's table or document goes there.
        Redirected into an input (``spinemesh upgrade hero/ --out out/ >> hero/hero.json``, or
        ``> hero/log.txt``), every command but ``pose`` wrote its table there, appending it to the
        skeleton; it is refused as such an output file is.

        ``product`` names what a command writes there as all it makes (``"the poses"``, ``info``'s
        ``"the table"``): a closed standard output (``>&-``) is refused for it, as an output that
        cannot be written; such a run wrote nothing and exited 0. A command whose files are what it
        makes (its table a summary) runs whole, its table dropped with one warning
        (:data:`STANDARD_OUTPUT_CLOSED`, said by ``cli._app`` and ``convert``)."""
        if product is not None and sys.stdout is None:
            raise OutputError(f"standard output is closed: {product} would go nowhere; give it a file (> FILE)")
        path = file_behind(sys.stdout)
        if path is not None:
            self.check_in_place(path, "standard output")

    def _refuse_inputs(self, path: Path, what: str) -> None:
        target = real(path)
        for given, inp in self.inputs:
            if target == inp:
                raise OutputError(f"{what} is the input {given}; the input is never overwritten", path)
            if inp.is_dir() and inp in target.parents:
                # "the input ." says little: the folder a skeleton lies in is its project, the current one here
                shown = f"folder {inp}" if str(given) in ("", ".") else str(given)
                # standard output is no path the user gave: they redirected it (> FILE)
                where = "redirect it outside it" if what == "standard output" else "give a path outside it"
                raise OutputError(f"{what} lies inside the input {shown}; nothing is written there: {where}", path)


def refuse_windows_path(path: Path, what: str) -> None:
    r"""Refuse an output given with backslashes that is not there yet (``--out 'C:\out'``), with the
    hint a missing input gets (:func:`.inputs.backslash_hint`): here a backslash is a letter of a
    name, so the run made one folder named ``C:\out`` in the current one, and said nothing. One
    there already (a folder of that very name) is written to as given."""
    if os.path.lexists(path):
        return
    hint = backslash_hint(path, lambda slashed: os.path.isdir(os.path.dirname(slashed.rstrip("/")) or "."))
    if hint:
        raise OutputError(f"{what} not made{hint}", path)


def refuse_report_over_output(report: Path, out: Path) -> None:
    """Refuse a ``--report`` that would replace a file in OUT: one the run wrote (an atlas, a
    skeleton) or one it kept there, not its own (an earlier run's report was removed with its files)."""
    if is_within(report, out) and report.exists():
        raise OutputError("--report would replace a file in the output folder (this run's, or one it keeps "
                          "there); name it apart", report)


def refuse_overlapping_outputs(out: Path, others: dict, report: Path | None = None) -> None:
    """Refuse an output folder given as OUT, inside OUT or holding OUT: a file of one would
    silently replace a file of the other (an editor image named like a page); and a ``report``
    file that is OUT or a folder above it (inside OUT it is a file of its own), which the run
    made a folder and then refused once its work was done (exit 3)."""
    for option, path in others.items():
        if path is not None and (is_within(path, out) or is_within(out, path)):
            raise OutputError(f"{option} {path} overlaps the output folder {out}; give a folder or file "
                              "beside it", path)
    if report is not None and is_within(out, report):
        raise OutputError(f"--report names the output folder (--out {out}) or one above it; give the report a "
                          f"file's name, beside the folder or in it ({out / 'report.json'})", report)


def refuse_one_output_twice(paths: Iterable[str | Path | None]) -> None:
    """Refuse two outputs (files, or folders writing the same names) that are one: on this disk,
    or on a macOS or Windows one (:func:`.names.portable_name`); the second would replace the first.

    Raises
    ------
    OutputError
        Naming both.
    """
    given: dict[str, str | Path] = {}
    for path in paths:
        if path is None:
            continue
        other = given.setdefault(portable_name(real(path)), path)
        if other is not path:
            where = "" if real(other) == real(path) else " on a macOS or Windows disk"
            raise OutputError(f"{other} and {path} are the same path{where}: give each output its own name", path)


def check_outputs(inputs: Iterable[str | Path | None], files: Iterable[str | Path | None] = (),
                  folders: Iterable[str | Path | None] = (), product: str | None = None) -> None:
    """Check, before any work, every output a command was given (``None`` entries are ignored).
    A folder written into again is checked by :func:`spinemesh.written_folder.check_written_folder` too.

    Standard output is one of them (:meth:`OutputGuard.check_standard_output`); ``product``
    names what the command writes there as all it makes (a closed standard output refused).

    Raises
    ------
    OutputError
        For the first output that :class:`OutputGuard` refuses, naming it.
    """
    guard = OutputGuard(inputs)
    guard.check_standard_output(product)
    for folder in folders:
        if folder is not None:
            guard.check_folder(folder)
    for file in files:
        if file is not None:
            guard.check(file)
    refuse_one_output_twice(files)
