"""The one family of errors that spinemesh raises for bad input.

Every error names the file and, where it is known, the line or byte offset, so that the
CLI can print one clear sentence instead of a traceback.
"""

from __future__ import annotations

import re
from pathlib import Path

#: Characters that could split or forge a printed line, or drive the terminal: C0 and C1
#: controls, DEL, and the Unicode line and paragraph separators; and lone surrogates, which
#: stand for a file name's bytes that are not UTF-8 (printed as they are, they made the output
#: no UTF-8 either).
_UNPRINTABLE = re.compile("[\x00-\x1f\x7f-\x9f\u2028\u2029\ud800-\udfff]")


def _escape_one(match: re.Match) -> str:
    return repr(match.group())[1:-1]


def escaped(text: str) -> str:
    """``text`` with control characters written as Python escapes (``\\n``, ``\\x1b``).

    Every message that names a file or a name from a project goes through this before it is
    printed: a file name holding a newline cannot split one error line into two (the second
    reading like a forged ``error:`` line), nor an escape sequence drive the terminal.

    Examples
    --------
    >>> print(escaped("a\\nerror: b"))
    a\\nerror: b
    """
    return _UNPRINTABLE.sub(_escape_one, text)


class SpineMeshError(Exception):
    """Bad input or a failed operation that a user can act on.

    Parameters
    ----------
    message : str
        What is wrong, in words a user understands.
    path : str or Path, optional
        The file the problem is in.
    line : int, optional
        1-based line number in a text file.
    offset : int, optional
        Byte offset in a binary file.
    """

    def __init__(self, message: str, path: str | Path | None = None,
                 line: int | None = None, offset: int | None = None):
        self.message = message
        self.path = str(path) if path is not None else None
        self.line = line
        self.offset = offset
        super().__init__(str(self))

    def __str__(self) -> str:
        where = self.path or ""
        if self.line is not None:
            where += f":{self.line}"
        if self.offset is not None:
            where += f" (byte {self.offset})"
        return escaped(f"{where}: {self.message}" if where else self.message)


class AtlasError(SpineMeshError):
    """A texture atlas that cannot be read."""


class SkeletonError(SpineMeshError):
    """A skeleton document (JSON) that cannot be read."""


class SkelFormatError(SpineMeshError):
    """A binary ``.skel`` file that is truncated, corrupted or of an unsupported version.

    ``offset`` is the byte offset where reading failed and ``message`` says what was expected.
    """


class ImageError(SpineMeshError):
    """A page or region image that is missing or cannot be decoded."""


class ImageMemoryError(ImageError):
    """An image whose work needs more memory than this process can get: that image fails, alone
    (:func:`spinemesh.memory.image_memory`)."""


class UnsafePathError(SpineMeshError):
    """A path in a project file that would reach outside the project folder."""


class LimitError(SpineMeshError):
    """Input that exceeds one of the resource limits of :mod:`spinemesh.limits`."""


class OutputError(SpineMeshError):
    """An output path that may not be written (inside the input, onto an input file, through a
    symlink) or that the file system refused (read-only, full disk)."""

    #: The system's error number where the file system refused the write (``errno.ENOSPC``), else None.
    errno: int | None = None


class OutputStopped(Exception):
    """A write the output's file system refused for a reason that holds for every later write too
    (a full disk, a file size limit, a read-only file system, a quota): the run stops at once with
    one line, rather than one per file left. Not a :class:`SpineMeshError`, so that no per-file
    handler takes it for one file's failure.

    Parameters
    ----------
    refused : OutputError
        The write refused (:func:`~spinemesh.files.atomic.write_refused`), naming its file.
    """

    def __init__(self, refused: OutputError):
        self.refused = refused
        super().__init__(str(self))

    def __str__(self) -> str:
        return (f"{self.refused}: every later write to the output would be refused too, so the run "
                "stopped; the files it wrote are whole")
