"""Atomic writes: a crash leaves either the old file or the new one, never half of one.

Each file is written to a temporary file of a unique name beside it (two runs into one folder
do not collide), flushed to disk and renamed onto it (:func:`atomic_write_bytes`); the temporary
file is removed on any error or interruption. Several files that only make sense together are
all staged before any is renamed (:func:`atomic_write_files`).
"""

from __future__ import annotations

import contextlib
import errno
import os
import re
import secrets
import shutil
from collections.abc import Iterable
from pathlib import Path

from ..errors import OutputError, OutputStopped, SpineMeshError
from .inside import NAME_MAX
from .strict_json import strict_json


def write_refused(e: OSError, path: str | Path) -> OutputError:
    """What the system refused writing ``path`` (making it, or a folder for it), said in one line
    naming it: a full disk, a read-only folder, a umask that leaves its owner no right to write in
    the folders it makes (``umask 777``)."""
    if e.errno == errno.ENOSPC:
        reason = "disk full"
    elif e.errno in (errno.EACCES, errno.EPERM) and (umask := _umask()) is not None and umask & 0o300:
        reason = f"permission denied: the umask ({umask:04o}) leaves a new folder's owner no right to write in it"
    elif e.errno in (errno.EACCES, errno.EPERM, errno.EROFS):
        reason = "permission denied (read-only?)"
    else:
        reason = e.strerror or str(e)
    refused = OutputError(f"cannot write: {reason}", path)
    refused.errno = e.errno
    return refused


#: What a file system refuses every write for once it refuses one: full, past the file size limit,
#: read-only, past the user's quota.
EVERY_WRITE_REFUSED = frozenset({errno.ENOSPC, errno.EFBIG, errno.EROFS, errno.EDQUOT})


def stop_if_every_write_refused(error: SpineMeshError) -> None:
    """Raise :class:`~spinemesh.errors.OutputStopped` where ``error`` is a write the output's file
    system would refuse every later write for (:data:`EVERY_WRITE_REFUSED`): called by each handler
    that says one file's failure and goes on, so a full disk is said once and the run ends there,
    not one line per file left."""
    if isinstance(error, OutputError) and error.errno in EVERY_WRITE_REFUSED:
        raise OutputStopped(error) from None


def _umask() -> int | None:
    """This process's umask as Linux says it (``/proc/self/status``); None where it does not say it
    (``os.umask`` reads it only by setting it, under the feet of other threads making files)."""
    try:
        with open("/proc/self/status", encoding="ascii", errors="replace") as status:
            for line in status:
                if line.startswith("Umask:"):
                    return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    return None


#: The folders :func:`make_folder` made in this process (absolute paths, outermost first): a run
#: that does not succeed removes those it left empty (:func:`~spinemesh.written_folder.remove_made_folders_left_empty`).
_MADE_FOLDERS: list[str] = []


def make_folder(folder: str | Path) -> Path:
    """``mkdir -p`` that reports a failure as :class:`OutputError` naming the folder, and notes the
    folders it made (:func:`folders_made`)."""
    folder = Path(folder)
    missing = []
    for path in (folder, *folder.parents):
        if os.path.lexists(path):
            break
        missing.append(os.path.abspath(path))
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        raise OutputError("cannot create folder: a file of that name exists", folder) from None
    except NotADirectoryError:  # a file where a folder above it should be: said of that file, as above
        blocking = next((path for path in folder.parents if os.path.lexists(path)), folder)
        raise OutputError("cannot create folder: a file of that name exists", blocking) from None
    except OSError as e:
        raise write_refused(e, folder) from None
    finally:  # also those made before a deeper one was refused
        _MADE_FOLDERS.extend(path for path in reversed(missing) if os.path.isdir(path))
    return folder


def folders_made() -> list[Path]:
    """The folders :func:`make_folder` made in this process, outermost first."""
    return [Path(folder) for folder in _MADE_FOLDERS]


def _temporary_name(name: str, token: str) -> str:
    """``.<name>.<token>.tmp``, the name cut so that the whole stays within :data:`.inside.NAME_MAX` bytes:
    a file whose own name is within the limit (241 to 255 bytes) is written like any other."""
    tail = f".{token}.tmp"
    room = NAME_MAX - 1 - len(tail.encode())
    return "." + os.fsdecode(os.fsencode(name)[:room]) + tail


#: The names :func:`_temporary_name` makes: ``.``, a name, ``.``, 8 hexadecimal digits, ``.tmp``.
_TEMPORARY_NAME = re.compile(r"\..+\.[0-9a-f]{8}\.tmp", re.DOTALL)


def is_temporary_name(name: str) -> bool:
    """Whether ``name`` is one the atomic writer gives its temporary files (:func:`_temporary_name`)."""
    return _TEMPORARY_NAME.fullmatch(name) is not None


def _stage(path: Path, fill, staged: list[tuple[str, Path]]) -> None:
    """Write a unique temporary file beside ``path`` by ``fill(file)``, flushed to disk, and
    list it in ``staged`` as ``(its name, path)``. It is listed before it is made: whatever
    ends the run, at any instruction (Ctrl-C just after the file was created), the caller
    holds its name and removes it (:func:`_rename_staged`).

    Raises
    ------
    OutputError
        When the file system refuses.
    """
    make_folder(path.parent)
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_BINARY", 0)
    for tries in range(100, 0, -1):
        tmp = os.path.join(path.parent, _temporary_name(path.name, secrets.token_hex(4)))
        staged.append((tmp, path))
        try:
            fd = os.open(tmp, flags, 0o666)  # less the umask, as an ordinary open() makes a file
            break
        except FileExistsError as e:  # another file's name (never ours to remove): another name
            staged.pop()
            if tries == 1:  # a folder that says every name exists
                raise write_refused(e, path) from None
        except OSError as e:
            raise write_refused(e, path) from None
    try:
        with os.fdopen(fd, "wb") as f:
            fill(f)
            f.flush()
            os.fsync(f.fileno())
    except OSError as e:
        raise write_refused(e, path) from None


def _rename_staged(stage) -> None:
    """Call ``stage(staged)``, which stages temporary files (:func:`_stage`) into the list it
    is given, then rename each onto its path, in order. Those not renamed are removed, whatever
    ends it (also KeyboardInterrupt and the SystemExit that SIGTERM becomes, at any instruction:
    one try covers the staging and the renames)."""
    staged: list[tuple[str, Path]] = []
    try:
        stage(staged)
        while staged:
            tmp, path = staged[0]
            try:
                os.replace(tmp, path)
            except OSError as e:
                raise write_refused(e, path) from None
            staged.pop(0)
    finally:
        for tmp, _ in staged:
            # never in place of the error that ends the write: a temporary file the folder refused
            # to create (umask 777, read-only) cannot be removed either, raising EACCES, not ENOENT
            with contextlib.suppress(OSError):
                os.unlink(tmp)


def _atomic(path: Path, fill) -> None:
    """Create a unique temporary file beside ``path``, let ``fill(file)`` write it, then rename."""
    _rename_staged(lambda staged: _stage(path, fill, staged))


def atomic_write_files(files: dict[Path, bytes]) -> None:
    """Write several files that only make sense together (an atlas and its pages): each one staged
    beside its path first, then all renamed, so that when one cannot be written (disk full,
    read-only) none is, and every path keeps what it held.

    Raises
    ------
    OutputError
        When the file system refuses one of them.
    """
    def stage(staged: list) -> None:
        for path, data in files.items():
            _stage(Path(path), lambda f, d=data: f.write(d), staged)

    _rename_staged(stage)


def atomic_write_stream(path: str | Path, write) -> None:
    """Atomically write the file that ``write(f)`` writes into ``f``, an open binary file (a
    library's own saver: ``np.savez``, ``torch.save``), without holding it whole: a temporary
    file beside ``path``, renamed onto it once ``write`` returned; removed when it raises.

    Raises
    ------
    OutputError
        When the file system refuses. What ``write`` raises passes through.
    """
    _atomic(Path(path), write)


def atomic_write_bytes(path: str | Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same folder and a rename.

    The file gets the permissions an ordinary ``open()`` would give it (0666 less the umask),
    not the owner-only ones of the temporary file.

    Raises
    ------
    OutputError
        When the file system refuses (read-only, disk full, a file where a folder should be).
    """
    _atomic(Path(path), lambda f: f.write(data))


def atomic_copy(source: str | Path, path: str | Path) -> None:
    """Copy the file ``source`` to ``path`` atomically (see :func:`atomic_write_bytes`).

    A source that cannot be opened (permission denied) is said of the source, before anything
    is staged: it was said of ``path`` as ``cannot write: permission denied (read-only?)``, sending
    the user to a writable output folder.
    """
    try:
        src = open(source, "rb")
    except OSError as e:
        raise SpineMeshError(f"cannot read: {e.strerror or e}", source) from None
    with src:
        _atomic(Path(path), lambda f: shutil.copyfileobj(src, f, 1 << 20))


def atomic_write_text(path: str | Path, text: str) -> None:
    """Atomic :func:`atomic_write_bytes` for UTF-8 text."""
    atomic_write_bytes(path, utf8(text, path))


def utf8(text: str, path: str | Path) -> bytes:
    """``text`` as the UTF-8 bytes of the file ``path``.

    Raises
    ------
    SpineMeshError
        When ``text`` holds a character UTF-8 cannot store (a lone surrogate), naming ``path``.
    """
    try:
        return text.encode("utf-8")
    except UnicodeEncodeError as e:
        raise SpineMeshError(f"not written: text holds an invalid character at {e.start}", path) from None


def atomic_write_json(path: str | Path, obj, indent: int | None = 2) -> None:
    """Atomically write ``obj`` as strict JSON (UTF-8, non-ASCII kept, no NaN or Infinity)."""
    atomic_write_text(path, strict_json(obj, indent, path) + "\n")


def atomic_write_pieces(path: str | Path, pieces: Iterable[str]) -> None:
    """Atomically write text given in pieces (UTF-8), each written to the file as it comes, so
    that only one piece is held at a time: a temporary file beside ``path``, renamed onto it
    when the last piece is written. When taking a piece raises (a refused value, Ctrl-C) or
    the file system refuses, the temporary file is removed and ``path`` keeps what it held.

    Raises
    ------
    OutputError
        When the file system refuses (read-only, disk full). What ``pieces`` raises passes through.
    """
    def fill(f):
        for piece in pieces:
            f.write(utf8(piece, path))

    _atomic(Path(path), fill)


def atomic_write_png(path: str | Path, image) -> None:
    """Atomically write an RGBA/RGB/gray uint8 array as PNG."""
    import io

    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(image).save(buf, format="PNG")
    atomic_write_bytes(path, buf.getvalue())
