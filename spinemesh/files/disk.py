"""What the disk says of a file: its digest, its stamp (whether two reads read the same file),
the file behind a redirected stream, the bytes free where a file would be written.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import stat
from pathlib import Path


def file_digest(path: str | Path) -> str | None:
    """SHA-256 of a file's bytes, hexadecimal; None when it is not a regular file or cannot be read."""
    try:
        with open(path, "rb") as f:
            if not stat.S_ISREG(os.fstat(f.fileno()).st_mode):
                return None
            digest = hashlib.sha256()
            while chunk := f.read(1 << 20):
                digest.update(chunk)
            return digest.hexdigest()
    except (OSError, ValueError):
        return None


def file_behind(stream) -> Path | None:
    """The regular file an open ``stream`` writes to (standard output redirected by ``> FILE``
    or ``>> FILE`` in a shell), so that a command writing there can refuse a file it reads, or
    one inside its input, as it refuses such an ``--out``; None for a terminal, a pipe, a
    device, a stream of no file, or where the system cannot name the file (only Linux names
    it, in ``/proc``)."""
    try:
        fd = stream.fileno()
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            return None
        path = Path(os.readlink(f"/proc/self/fd/{fd}"))
        return path if os.path.samestat(os.stat(path), st) else None  # " (deleted)", or another file
    except (OSError, ValueError, AttributeError):
        return None


def file_stamp(path: str | Path) -> tuple[int, int, int, int] | None:
    """What writing or replacing a file changes: ``(device, inode, size, modification time in
    ns)``; None when it cannot be read. Taken before a file is read, and again by another
    process that reads it later, it tells whether both read the same file."""
    try:
        st = os.stat(path)
    except OSError:
        return None
    return st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns


def free_bytes(path: str | Path) -> int | None:
    """Bytes free to this user on the file system that a file at ``path`` would be written to
    (its nearest existing folder); None when that cannot be read."""
    folder = Path(path).absolute().parent
    while not folder.exists() and folder != folder.parent:
        folder = folder.parent
    try:
        return shutil.disk_usage(folder).free
    except OSError:
        return None
