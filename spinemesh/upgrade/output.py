"""Where ``upgrade`` may write, and how it holds the places it writes to.

Checked before any work: the output folder is never an input, inside one or holding one
(:func:`check_output_folder`); while a run lasts it holds its output folder
(:func:`output_folder`: empty or written by an earlier run, marked, locked). The editor
images (``--images``) go to a folder of their own, as the planning stage meets them
(:func:`write_editor_image`).
"""

from __future__ import annotations

import contextlib
import os
import shutil
from pathlib import Path

try:
    import fcntl  # POSIX: a run holds its output folder
except ImportError:  # Windows: no lock
    fcntl = None

from ..errors import SpineMeshError
from ..fsutil import OutputGuard, atomic_write_png, atomic_write_text, make_folder, resolve_inside
from ..images import RegionImage

#: A file that marks a folder as written by ``upgrade``: only such a folder is replaced by
#: ``overwrite`` (a mistyped ``--out ~/Documents --overwrite`` must not delete a user's files).
OUTPUT_MARKER = ".spinemesh-output"


def check_output_folder(project_root: Path, out: Path, images_in: Path | None = None) -> None:
    """Refuse an output folder that is an input, lies inside one or holds one (see :class:`OutputGuard`)."""
    OutputGuard([project_root, images_in]).check_folder(out, may_hold_inputs=False)


@contextlib.contextmanager
def output_folder(out: Path, overwrite: bool):
    """Hold ``out`` for one run: an empty folder marked as ours, or refused.

    An existing non-empty ``out`` is refused unless ``overwrite``; then its contents are
    removed (no stale file of an earlier run stays), but only if an earlier ``upgrade`` wrote
    it (:data:`OUTPUT_MARKER`). The folder itself is kept and locked (``flock``) while the
    run lasts: a second run into the same folder waits for the first to end instead of
    deleting or overwriting its files half-way.
    """
    if out.exists() and not out.is_dir():
        raise SpineMeshError("output folder exists and is not a folder", out)
    make_folder(out)
    fd = os.open(out, os.O_RDONLY)
    try:
        if fcntl is not None:
            fcntl.flock(fd, fcntl.LOCK_EX)
        entries = list(out.iterdir())
        if entries:
            if not overwrite:
                raise SpineMeshError("output folder is not empty; pass --overwrite to replace it as a whole", out)
            if not (out / OUTPUT_MARKER).is_file():
                raise SpineMeshError("output folder is not empty and was not written by spinemesh upgrade; "
                                     "refusing to delete it, choose another --out", out)
            for entry in entries:
                if entry.is_dir() and not entry.is_symlink():
                    shutil.rmtree(entry)
                else:
                    entry.unlink()
        atomic_write_text(out / OUTPUT_MARKER, "written by spinemesh upgrade; --overwrite may replace this folder\n")
        yield out
    finally:
        os.close(fd)  # releases the lock


def write_editor_image(frame: RegionImage, folder: Path) -> None:
    """``<folder>/<path>.png``, the original-size image the editor re-imports.

    Atlas images exported at a scale other than 1 are resized back to skeleton size.
    """
    rgba = frame.rgba
    if frame.scale != 1:
        import cv2

        from ..limits import check_image_size

        h, w = rgba.shape[:2]
        size = (max(1, round(w / frame.scale)), max(1, round(h / frame.scale)))
        # the size the page's scale implies, checked before it is allocated
        check_image_size(*size, f"editor image {frame.name!r} at atlas scale {frame.scale:g}", frame.source)
        rgba = cv2.resize(rgba, size, interpolation=cv2.INTER_CUBIC)
    atomic_write_png(resolve_inside(folder, frame.name + ".png", folder, "--images folder"), rgba)
