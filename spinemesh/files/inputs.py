"""The inputs a command is given: one that is not there, or is not a regular file, refused in
one line; the folder a project input stands for, and how a run names it.
"""

from __future__ import annotations

import os
import shlex
import stat
from pathlib import Path

from ..errors import SpineMeshError


def project_folder(path: str | Path) -> Path:
    """The folder an input stands for: itself for a folder, its folder for a file (a skeleton's
    project is the folder it lies in).

    Raises
    ------
    SpineMeshError
        ``PATH: no such file or folder``: a missing project is said as such before its outputs
        are checked against it (its folder would be the one it was named from).
    """
    path = existing(path)
    return path if path.is_dir() else path.parent


def named_project(path: str | Path) -> Path:
    """``path`` (a command's project: a folder, or a skeleton file) as a run names it: one whose
    folder is the current one (``.``, ``hero.json`` given from inside the project) absolute, any
    other (and one not there, refused as given later) as given. A file of the project is then
    named by a path that holds the project folder (``/home/me/hero/hero.atlas``, not
    ``hero.atlas``), which :func:`.names.named_within` names from the folder's name (``hero/hero.atlas``):
    a report is the same bytes from inside the project as from elsewhere. A path the console
    shows stays one to open."""
    path = Path(path)
    folder = path if path.is_dir() else path.parent
    return Path(os.path.abspath(path)) if path.exists() and os.path.normpath(folder) == "." else path


def existing(path: str | Path) -> Path:
    """``path`` if something is there; refused as ``PATH: no such file or folder`` otherwise (the
    one line every command gives for a missing input, before anything else is checked)."""
    path = Path(path)
    if not path.exists():
        raise SpineMeshError(missing_said(path), path)
    return path


def missing_said(path: str | Path, what: str = "file or folder") -> str:
    r"""``no such WHAT``, and for a path written with backslashes (a Windows path pasted where
    folders are separated by ``/``) what to write instead: it was said ``no such file or folder``
    alone, of a project that was there.

    Examples
    --------
    >>> missing_said("hero")
    'no such file or folder'
    >>> missing_said("C:\\art\\hero", "skeleton")
    "no such skeleton (folders are separated by '/' here, not '\\')"
    """
    return f"no such {what}{backslash_hint(path)}"


def backslash_hint(path: str | Path, worth_naming=os.path.exists) -> str:
    r"""For a path written with backslashes (a Windows path, ``C:\art\hero``), what to write
    instead: `` (folders are separated by '/' here, not '\')``, with ``: did you mean
    'art/hero'?`` where ``worth_naming(the path with slashes)`` (default: it exists); ``""``
    for any other path. Inputs that are not there (:func:`missing_said`) and outputs
    (:mod:`.guard`) say it alike."""
    text = os.fspath(path)
    if "\\" not in text:
        return ""
    slashed = text.replace("\\", "/")
    meant = f": did you mean {shlex.quote(slashed)}?" if worth_naming(slashed) else ""
    return f" (folders are separated by '/' here, not '\\'{meant})"


def regular_file(path: str | Path, what: str = "file") -> Path:
    """``path`` if it names a regular file (through symlinks); refused otherwise.

    A FIFO or device given as an input would block for ever or never end when read.

    Raises
    ------
    SpineMeshError
        Naming the file and what it is instead.
    """
    path = Path(path)
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        raise SpineMeshError(missing_said(path, what), path) from None
    except OSError as e:
        raise SpineMeshError(f"cannot read {what}: {e.strerror}", path) from None
    if stat.S_ISDIR(mode):
        raise SpineMeshError(f"{what} is a folder", path)
    if not stat.S_ISREG(mode):
        raise SpineMeshError(f"{what} is {special_kind(mode)}, not a regular file; only regular files are read", path)
    return path


def special_kind(mode: int) -> str:
    """What a file that is neither a regular file nor a folder is, in words, by its ``st_mode``."""
    return "a FIFO" if stat.S_ISFIFO(mode) else "a socket" if stat.S_ISSOCK(mode) else "a device"
