"""File-system rules that every command follows.

- Paths named inside project files never leave the project folder (:func:`resolve_inside`).
- Output is written atomically (:func:`atomic_write_bytes`): a crash leaves either the old
  file or the new one, never half of one.
"""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path

from .errors import UnsafePathError


def resolve_inside(root: str | Path, relative: str, source: str | Path | None = None) -> Path:
    """Join ``relative`` to ``root`` and refuse any result outside ``root``.

    Parameters
    ----------
    root : path
        The folder that may not be left (the project folder).
    relative : str
        A path as written in a project file (atlas page name, image path).
    source : path, optional
        The file that named ``relative``, for the error message.

    Raises
    ------
    UnsafePathError
        If ``relative`` is absolute or climbs out of ``root`` (``../``), also through symlinks.
    """
    root = Path(root).resolve()
    rel = relative.replace("\\", "/")
    if os.path.isabs(rel) or (len(rel) > 1 and rel[1] == ":"):
        raise UnsafePathError(f"absolute path {relative!r} is not allowed", source or root)
    candidate = (root / rel).resolve()
    if candidate != root and root not in candidate.parents:
        raise UnsafePathError(f"path {relative!r} leads outside the project folder", source or root)
    return candidate


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def atomic_write_bytes(path: str | Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same folder and a rename.

    The file gets the permissions an ordinary ``open()`` would give it (0666 less the umask),
    not the owner-only ones of the temporary file.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        os.fchmod(fd, 0o666 & ~_umask())
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise


def atomic_write_text(path: str | Path, text: str) -> None:
    """Atomic :func:`atomic_write_bytes` for UTF-8 text."""
    atomic_write_bytes(path, text.encode("utf-8"))


def atomic_write_json(path: str | Path, obj, indent: int | None = 2) -> None:
    """Atomically write ``obj`` as JSON (UTF-8, non-ASCII kept)."""
    atomic_write_text(path, json.dumps(obj, indent=indent, ensure_ascii=False) + "\n")


def atomic_write_png(path: str | Path, image) -> None:
    """Atomically write an RGBA/RGB/gray uint8 array as PNG."""
    import io

    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(image).save(buf, format="PNG")
    atomic_write_bytes(path, buf.getvalue())
