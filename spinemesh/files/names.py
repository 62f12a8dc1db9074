"""File and folder names: the one file a name is on every common disk, names made from text,
names kept apart, and paths named from a project folder's own name in what a run writes.
"""

from __future__ import annotations

import os
import re
import unicodedata
from pathlib import Path

from ..errors import OutputError
from .inside import as_written


def portable_name(relative: str | Path) -> str:
    """The one file ``relative`` names on every common disk, as a key to compare names by.

    macOS and Windows disks ignore case and (macOS) Unicode normalisation form, Windows drops a
    name's trailing dots and spaces and reads a backslash as a folder: ``Hero.png``, ``hero.png``,
    ``héro`` in NFC or NFD, ``arm.`` and ``arm`` are each one file there, two on Linux.
    """
    parts = as_written(str(relative)).split("/")
    return "/".join(unicodedata.normalize("NFC", part).rstrip(" .").casefold() for part in parts)


def safe_name(text: str, limit: int = 80) -> str:
    """A file name made of ``text``: letters, digits, ``-_.`` kept, anything else ``_``.

    Examples
    --------
    >>> safe_name("hero/walk cycle.json")
    'hero_walk_cycle.json'
    """
    name = re.sub(r"[^A-Za-z0-9._-]", "_", text).strip(".")[:limit]
    return name or "_"


def name_apart(name: str, taken: set[str]) -> str:
    """``name``, with ``_`` appended until it is no file of ``taken`` on any disk
    (:func:`portable_name`); its portable name is added to ``taken``.

    Examples
    --------
    >>> taken = set()
    >>> [name_apart(n, taken) for n in ("hero", "Hero", "hero_", "arm")]
    ['hero', 'Hero_', 'hero__', 'arm']
    """
    while portable_name(name) in taken:
        name += "_"
    taken.add(portable_name(name))
    return name


class OneFilePerName:
    """Names of files written into one folder, refusing a second writer of the same file.

    A folder copied to (or written on) a disk that ignores case or Unicode form would otherwise
    hold one of two outputs, the other overwritten without a word (:func:`portable_name`).
    """

    def __init__(self) -> None:
        #: portable name -> (name as written, what it was written for)
        self.taken: dict[str, tuple[str, str]] = {}

    def claim(self, relative: str | Path, owner: str | Path, what: str = "file",
              source: str | Path | None = None) -> None:
        """Take ``relative`` for ``owner`` (what it is written for), or raise naming ``source`` (else ``owner``).

        Raises
        ------
        OutputError
            Naming ``owner``, when another owner took the same file: the same name, or one that
            is the same file on a disk that ignores case, Unicode form or trailing dots and
            spaces (macOS, Windows).
        """
        name, owner = str(relative), str(owner)
        other, other_owner = self.taken.setdefault(portable_name(name), (name, owner))
        if other_owner == owner:
            return
        if other == name:
            raise OutputError(f"{what} {name!r} was written for {other_owner!r} already", source or owner)
        form = (" (the same letters in another Unicode form)"
                if unicodedata.normalize("NFC", other) == unicodedata.normalize("NFC", name) else "")
        raise OutputError(f"{what} {name!r} would be the same file as {other!r}{form}, written for "
                          f"{other_owner!r}, on macOS and Windows disks (case, Unicode form, trailing dots "
                          "and spaces ignored)", source or owner)


def name_as_text(name: str) -> str:
    """A file name read from a disk as text a UTF-8 file can hold: bytes of it that are not UTF-8
    (which Python keeps as lone surrogates) become U+FFFD, each.

    Examples
    --------
    >>> name_as_text(b"hero\\xff.png".decode("utf-8", "surrogateescape"))
    'hero\ufffd.png'
    """
    return name.encode("utf-8", "surrogateescape").decode("utf-8", "replace")


def named_within(value, folder: str | Path | None):
    """``value`` (text, or a JSON-able object of texts) with every path into ``folder`` named from
    the folder's own name: ``/home/ci/build/game/hero/hero.png`` and ``../hero/hero.png``, for a
    ``folder`` given as ``../hero``, both become ``hero/hero.png``. A report or a page names the
    project's files so, not by the path that differs from one folder or machine to the next (its
    bytes then are the same there); the console keeps the whole paths, to open.

    ``folder`` None changes nothing. A project named ``.`` would have its files named without a
    folder: a command gives it to its run absolute (:func:`.inputs.named_project`).
    """
    if folder is None:
        return value
    really = os.path.realpath(folder)
    given = os.path.normpath(os.fspath(folder))
    prefixes = sorted({p for p in (really, os.path.abspath(folder), given) if p not in ("", ".", os.sep)},
                      key=len, reverse=True)
    if not prefixes:
        return value
    # a prefix counts where a path begins: not inside another name (``hero/`` in ``superhero/``)
    pattern = re.compile(r"(?<![\w.\-/])(?:" + "|".join(re.escape(p) for p in prefixes) + r")(?=/)")
    name = folder_name(folder)

    def named(v):
        if isinstance(v, str):
            return pattern.sub(lambda _: name, v)
        if isinstance(v, dict):
            return {named(k): named(x) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [named(x) for x in v]
        return v

    return named(value)


def folder_name(folder: str | Path) -> str:
    """The name a report gives ``folder`` itself: its real folder's own name (``hero`` for
    ``../hero``, ``/home/ci/hero`` or ``.`` inside it); the paths into it are named from it
    (:func:`named_within`)."""
    return os.path.basename(os.path.realpath(folder))


def named_from(path: str | Path, folder: str | Path) -> str:
    """``path`` as a report names it: ``folder`` itself by :func:`folder_name`, a path into it
    from that name (:func:`named_within`), any other path as given."""
    if os.path.realpath(path) == os.path.realpath(folder):
        return folder_name(folder)
    return named_within(os.fspath(path), folder)
