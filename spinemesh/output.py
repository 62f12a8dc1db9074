"""A run's output folder, shared by ``upgrade``, ``weights`` and ``pack``.

Checked before any work: the output folder is never an input, inside one or holding one
(:func:`check_output_folder`); while a run lasts it holds its output folder
(:func:`output_folder`: empty or written by an earlier run, marked, locked). What goes in
it: each skeleton in the format it came in (:func:`write_skeleton`), every other file of the
project copied as it is (:func:`files_to_copy`, :func:`copy_other_files`).

It sits below the commands that write projects so that none of them imports another's
package to write its output.
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

from .errors import SpineMeshError
from .fsutil import OutputGuard, atomic_copy, atomic_write_bytes, atomic_write_text, make_folder
from .project import Project
from .skeleton import dumps_skeleton, is_binary_skeleton

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
                raise SpineMeshError("output folder is not empty and was not written by spinemesh; "
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


def write_skeleton(doc: dict, path: Path, dest: Path) -> None:
    """Write ``doc`` to ``dest`` in the format ``path`` came in (binary ``.skel`` or JSON).

    JSON keeps the text of ``path`` wherever ``doc`` did not change, in its formatting, so
    that a version-control diff shows only the upgraded attachments.
    """
    if is_binary_skeleton(path):
        from .skeleton_binary import write_skel

        atomic_write_bytes(dest, write_skel(doc, dest))
    else:
        original = path.read_bytes().decode("utf-8")  # a byte-order mark stays (splice keeps it)
        atomic_write_text(dest, dumps_skeleton(doc, dest, like=original))


def copy_other_files(proj: Project, out: Path, written: set[Path], needed: set[Path] | None = None) -> None:
    """Copy every file of the project that is not a skeleton (atlases, pages, anything else)."""
    for source, dest in files_to_copy(proj, out, written, needed):
        atomic_copy(source, dest)


def files_to_copy(proj: Project, out: Path, written: set[Path], needed: set[Path] | None = None
                  ) -> list[tuple[Path, Path]]:
    """``(source, destination)`` of every file of the project that is copied as it is.

    Every file but the skeletons (atlases, pages, anything else).

    With ``needed`` (real paths), skeletons, atlases and images are copied only if listed: one
    skeleton asked for does not bring its twins (``hero.json`` beside ``hero.skel``) or other
    skeletons' atlases along; other files (a licence, audio) still come.
    """
    from .images import IMAGE_EXTENSIONS
    from .project import ATLAS_SUFFIXES, is_skeleton_file

    pairs = []
    for f in proj.files:  # only files inside the project by real path (see find_project)
        if f.resolve() in written:
            continue
        if f in proj.skeletons:
            continue  # a skeleton that could not be upgraded is not copied as if it had been
        if needed is not None and f.resolve() not in needed and (
                f.suffix.lower() in IMAGE_EXTENSIONS or f.name.lower().endswith(ATLAS_SUFFIXES)
                or is_skeleton_file(f)):
            continue
        pairs.append((f, out / f.relative_to(proj.root)))
    return pairs


def files_needed(doc: dict, source) -> set[Path]:
    """The files a skeleton needs beside it (real paths): its atlases and their pages, or its images."""
    from .images import AtlasImages, FolderImages
    from .project import needed_images

    if isinstance(source, AtlasImages):
        return {Path(a.path).resolve() for a in source.atlases} | {
            source.page_file(a, i).resolve() for a in source.atlases for i in range(len(a.pages))}
    if isinstance(source, FolderImages):
        return {p.resolve() for p in map(source.path_of, sorted(needed_images(doc))) if p is not None}
    return set()
