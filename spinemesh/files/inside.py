"""Paths named inside a project that stay inside it.

A path a project file names (an atlas page, an image path) is joined to the project folder and
refused when it leaves it (:func:`resolve_inside`), compared as real paths (symlinks resolved),
never as string prefixes; a name or path no file system can hold is refused first
(:func:`check_name_lengths`).
"""

from __future__ import annotations

import os
from pathlib import Path

from ..errors import UnsafePathError


def real(path: str | Path) -> Path:
    """The absolute path with every symlink resolved (the file a path really names)."""
    return Path(os.path.realpath(path))


def is_within(path: str | Path, folder: str | Path) -> bool:
    """Whether ``path`` is ``folder`` or lies inside it, comparing real paths."""
    p, f = real(path), real(folder)
    return p == f or f in p.parents


#: Longest file or folder name (bytes) and whole path most file systems hold (Linux's NAME_MAX and
#: PATH_MAX); a longer one makes every call on it fail with "File name too long".
NAME_MAX = 255


PATH_MAX = 4096


def check_name_lengths(path: str | Path, source: str | Path | None = None, what: str = "path") -> None:
    """Refuse a path that no file system can hold: a name over 255 bytes or a path over 4096.

    Raises
    ------
    UnsafePathError
        Naming the path (escaped, shortened) and ``source``, the file that named it.
    """
    text = os.fsencode(os.fspath(path))
    longest = max((len(part) for part in text.split(b"/")), default=0)
    if longest > NAME_MAX or len(text) > PATH_MAX:
        shown = os.fspath(path)
        shown = shown if len(shown) <= 80 else shown[:60] + "..." + shown[-16:]
        raise UnsafePathError(f"{what} {shown!r} is longer than a file system allows ({longest} bytes in one "
                              f"name, at most {NAME_MAX}; {len(text)} in all, at most {PATH_MAX})",
                              source or None)


def as_written(relative: str) -> str:
    """A path as a project file names it, with a Windows export's backslashes as the folder
    separators they are there: where :func:`resolve_inside` reads it, and where it is written."""
    return relative.replace("\\", "/")


def page_not_found_said(name: str, folder: str | Path) -> str:
    """Why a page image ``name`` (as an atlas in ``folder`` writes it) is not where it is read.

    A name holding a backslash is read as the folders a Windows export means (:func:`as_written`),
    as Windows and browsers read it (spine-ts loads its URL, where ``\\`` is ``/``). libGDX (a
    ``java.io.File``) and spine-c (``fopen``) on Linux, macOS and Android read it as one file's
    name: a project that holds such a file loads on those alone, so it is refused, naming the
    folder to move it to, rather than written as it is."""
    folders = as_written(name)
    if "\\" in name and not Path(folders).is_absolute() and ".." not in folders.split("/") \
            and (Path(folder) / name).is_file():
        return (f"page image {name!r} is a file whose name holds a backslash, which runtimes read apart: "
                f"Windows and browsers read the page as {folders!r} (in folders), libGDX and spine-c on Linux, "
                f"macOS and Android as that one file; move it to {folders!r}, where every runtime finds it")
    other = named_in_other_case(Path(folder) / folders)
    if other is not None:
        # exported on Windows or macOS, whose disks find the page whatever its letters' case
        return (f"page image {name!r} not found: {other!r} is there, its name in other letter case, which Windows "
                "and macOS disks take for it and Linux, Android and web servers do not; rename the file or the "
                "atlas's page line so that they match")
    return f"page image {name!r} not found"


def named_in_other_case(path: Path, most: int = 10_000) -> str | None:
    """The name of a file beside ``path`` that is its name in other letter case (``Hero.png`` for
    ``hero.png``), or None; the first ``most`` entries of its folder are looked at."""
    try:
        with os.scandir(path.parent) as entries:
            for _, entry in zip(range(most), entries):
                if entry.name != path.name and entry.name.lower() == path.name.lower() and entry.is_file():
                    return entry.name
    except OSError:  # no such folder, or one it may not read: nothing to say beyond "not found"
        return None
    return None


def resolve_inside(root: str | Path, relative: str, source: str | Path | None = None,
                   what: str = "project folder") -> Path:
    """Join ``relative`` to ``root`` and refuse any result outside ``root``.

    Parameters
    ----------
    root : path
        The folder that may not be left (the project folder).
    relative : str
        A path as written in a project file (atlas page name, image path).
    source : path, optional
        The file that named ``relative``, for the error message.
    what : str
        What ``root`` is, for the error message.

    Raises
    ------
    UnsafePathError
        If ``relative`` is absolute or climbs out of ``root`` (``../``), also through symlinks.
    """
    root = real(root)
    rel = as_written(relative)
    if "\x00" in rel:
        raise UnsafePathError(f"path {relative!r} holds a NUL character", source or root)
    if os.path.isabs(rel) or (len(rel) > 1 and rel[1] == ":"):
        raise UnsafePathError(f"absolute path {relative!r} is not allowed", source or root)
    check_name_lengths(root / rel, source or root)
    candidate = real(root / rel)
    if candidate != root and root not in candidate.parents:
        raise UnsafePathError(f"path {relative!r} leads outside the {what}", source or root)
    return candidate
