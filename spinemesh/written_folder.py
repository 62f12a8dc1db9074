"""Folders spinemesh writes into again, and what a later run may remove there: one mechanism.

A folder spinemesh writes holds a marker, a small JSON file naming what wrote it and listing the
files that run wrote there, each with its SHA-256 (:func:`write_marker`, :func:`read_marker`,
:func:`marker_listing`, :func:`listed_files`)::

    {"spinemesh": "output folder", "written": ["hero.json", ...], "sha256": {"hero.json": "9f2c..."}}

What a later run may remove is that list, each file only while it holds the bytes its run left
(:func:`remove_listed_files`), and the atomic writer's temporary files that a run killed outright
left behind (:func:`temporary_files`); never another file (a user's, a game engine's ``.meta``, a
``.gitignore``). A folder that holds files but no marker is a user's and is refused
(:func:`refuse_users_folder`); one that holds nothing but a killed run's temporary files is empty.

The mechanism has two uses, which differ only in when the earlier run's files go:

- a run's output folder OUT (``upgrade``, ``pack``, ``weights``; :data:`OUTPUT_MARKER`,
  :func:`spinemesh.output.output_folder`): ``--overwrite`` removes the earlier run's files BEFORE
  the run, under a lock; the marker lists what the run found while it lasts, what it wrote once
  it ends;
- a folder of pictures or pages written again (``--preview``, ``--images``, ``weights --preview``,
  ``mesh DIR``, ``diff --out``, ``dataset-stats --plots``; :data:`WRITTEN_MARKER`,
  :func:`rewriting_folder`): AFTER the run, the earlier run's files it did not write again are
  removed, so a run refused half-way leaves the earlier pictures in place.
"""

from __future__ import annotations

import contextlib
import json
import os
from collections.abc import Callable, Iterable
from pathlib import Path

from .errors import OutputError, SpineMeshError
from .files.atomic import atomic_write_text, folders_made, is_temporary_name, make_folder
from .files.disk import file_digest, file_stamp
from .files.strict_json import strict_json
from .files.walk import walk_folder

#: The marker of a run's output folder (``upgrade``, ``pack``, ``weights``): ``overwrite`` removes
#: only the files it lists (a mistyped ``--out ~/Documents --overwrite`` must not delete a user's
#: files, nor a rerun the files a game engine or the user added beside the run's: Unity's
#: ``.meta`` files, a ``.gitignore``).
OUTPUT_MARKER = ".spinemesh-output"

#: The marker of a folder of pictures or pages spinemesh writes beside nothing else of its own
#: (``upgrade --images``, ``weights --preview``, ...): the folder is its own, written into again.
WRITTEN_MARKER = ".spinemesh-written"

#: Largest list of written files read back from a marker (a few hundred bytes per thousand files).
MAX_MARKER_BYTES = 64 * 1024 * 1024


def read_marker(path: str | Path):
    """A marker's JSON; None for a marker of a line of text (an older spinemesh's, or
    :func:`mark_written_folder`'s), or one that cannot be read."""
    try:
        with open(path, "rb") as f:
            data = f.read(MAX_MARKER_BYTES + 1)
        return json.loads(data.decode("utf-8")) if len(data) <= MAX_MARKER_BYTES else None
    except (OSError, ValueError):
        return None


def write_marker(folder: str | Path, marker: str, kind: str, what: dict) -> None:
    """Write ``folder``'s ``marker`` (:data:`OUTPUT_MARKER`, :data:`WRITTEN_MARKER`) atomically:
    ``{"spinemesh": kind, **what}``, ``what`` most often a :func:`marker_listing`."""
    atomic_write_text(Path(folder) / marker, strict_json({"spinemesh": kind, **what}, 1) + "\n")


def listed_files(marker: object) -> dict[str, str | None]:
    """The files a marker (:func:`read_marker`'s JSON) lists as its run's, by POSIX path, each with
    the :func:`~spinemesh.files.disk.file_digest` it had when the run ended (None where it gives none)."""
    names = marker.get("written") if isinstance(marker, dict) else None
    digests = marker.get("sha256") if isinstance(marker, dict) else None
    digests = digests if isinstance(digests, dict) else {}
    return {name: digest if isinstance(digest := digests.get(name), str) else None
            for name in (names if isinstance(names, list) else ()) if isinstance(name, str)}


def marker_listing(folder: str | Path, listed: dict[str, str | None], written: Iterable[str] = ()) -> dict:
    """A marker's ``written`` and ``sha256`` (:func:`listed_files` reads them back): the files
    ``listed`` with the digests given (an earlier marker's, None for none), and the files this run
    ``written`` under ``folder``, digested now. A digest, unlike an inode, is the same wherever
    the folder is: the marker is the same bytes for the same files."""
    digests = {**listed, **{rel: file_digest(Path(folder) / rel) for rel in written}}
    return {"written": sorted(digests), "sha256": {rel: digests[rel] for rel in sorted(digests) if digests[rel]}}


def folder_stamps(folder: str | Path, marker: str) -> dict[str, tuple | None]:
    """Every file under ``folder`` (hidden ones too, its ``marker`` aside) by its POSIX path under
    it, with its :func:`~spinemesh.files.disk.file_stamp`: a file written anew or replaced has another."""
    folder = Path(folder)
    if not folder.is_dir():
        return {}
    return {rel: file_stamp(f) for _, _, files in walk_folder(folder, hidden=True) for f in files
            if (rel := f.relative_to(folder).as_posix()) != marker}


def temporary_files(folder: str | Path) -> dict[str, str | None]:
    """The regular files under ``folder`` (not symlinks) whose names the atomic writer makes
    (:func:`~spinemesh.files.atomic.is_temporary_name`), by POSIX path under it, with their digests: a
    run killed outright (SIGKILL, a power cut) mid-write leaves them, and no marker lists them."""
    folder = Path(folder)
    if not folder.is_dir():
        return {}
    found = {}
    for _, _, files in walk_folder(folder, hidden=True):
        for f in files:
            if is_temporary_name(f.name) and not f.is_symlink() and (digest := file_digest(f)):
                found[f.relative_to(folder).as_posix()] = digest
    return found


def holds_files(folder: str | Path) -> bool:
    """Whether ``folder`` holds anything but (empty folders and) the atomic writer's temporary files,
    regular ones, that a killed run left: a folder holding only those is as good as empty. Stops at
    the first other thing found (a user's folder of thousands is not walked)."""
    for here, dirs, names in os.walk(folder, followlinks=False):
        for name in names:
            path = os.path.join(here, name)
            if not is_temporary_name(name) or os.path.islink(path) or not os.path.isfile(path):
                return True
        if any(os.path.islink(os.path.join(here, d)) for d in dirs):
            return True
    return False


def refuse_users_folder(folder: str | Path, marker: str, refusal: str, what: str = "output folder",
                        older_sign: Callable[[Path], bool] | None = None) -> None:
    """The one guard of a folder spinemesh writes into again: refuse (``refusal``, one line naming
    ``folder``) a folder that holds files (:func:`holds_files`) but no ``marker``, nor the
    ``older_sign`` of what an older spinemesh wrote there: ours would replace a user's files of the
    same names (a mistyped ``--preview ~/Documents``). A folder of ours is refused when it holds a
    symlink to a folder (:func:`refuse_linked_folders`).

    Raises
    ------
    OutputError
        Naming the folder.
    """
    folder = Path(folder)
    if not folder.is_dir() or not holds_files(folder):
        return
    if not (folder / marker).is_file() and not (older_sign is not None and older_sign(folder)):
        raise OutputError(refusal, folder)
    refuse_linked_folders(folder, what)


def refuse_linked_folders(folder: str | Path, what: str = "output folder") -> None:
    """Refuse a folder spinemesh writes into again that holds a symlink to a folder, at any depth:
    a file written below the link (``img/``, ``images/``) would land in the folder it points to,
    outside, over a file of the same name there. Files that are symlinks do no harm: a file is
    replaced whole by a rename, the link with it.

    Raises
    ------
    OutputError
        Naming the link.
    """
    for here, dirs, _ in os.walk(folder, followlinks=False):
        for name in sorted(dirs):
            link = Path(here) / name
            if link.is_symlink():
                raise OutputError(f"{what} holds a symlink to a folder ({link.relative_to(folder).as_posix()} -> "
                                  f"{os.readlink(link)}): what is written there would land outside it; remove "
                                  "the link", folder)


def remove_listed_files(folder: str | Path, files: dict[str, str | None]) -> None:
    """Remove each file of ``files`` under ``folder`` (POSIX paths, as a marker lists them, with the
    :func:`~spinemesh.files.disk.file_digest` the run left it with) that still holds those bytes, and
    the folders it leaves empty: the one removal of the earlier run's files, in both uses. A
    marker is a file anyone could have written or copied: a name that is absolute, climbs out,
    names the folder or a marker, passes through a symlinked folder or is no path (a NUL), names
    a symlink (a run writes none) or is listed without a digest removes nothing, nor does one
    whose file was edited or replaced since (a user's now). On a case-insensitive disk a name
    removes only a file stored under that very name: ``Hero.png`` listed is not the ``hero.png``
    a later run wrote, even of the same bytes."""
    folder = Path(folder)
    root = os.path.realpath(folder)
    names_in: dict[Path, set[str]] = {}
    for rel in sorted(files):
        parts = Path(rel).parts
        if not files[rel] or not rel or os.path.isabs(rel) or ".." in parts or rel in (".", WRITTEN_MARKER,
                                                                                     OUTPUT_MARKER):
            continue
        path = folder.joinpath(*parts)
        try:
            if os.path.realpath(path.parent) != os.path.join(root, *parts[:-1]).rstrip(os.sep):
                continue
            if path.parent not in names_in:
                names_in[path.parent] = set(os.listdir(path.parent))
            if path.name not in names_in[path.parent]:  # the name as stored, not another case of it
                continue
            if path.is_symlink() or file_digest(path) != files[rel]:
                continue
            path.unlink()
        except (OSError, ValueError):  # a NUL, a name the disk cannot hold, a file gone meanwhile
            continue
        for parent in path.parents:
            if parent == folder:
                break
            try:
                parent.rmdir()  # only when empty
            except OSError:
                break


def remove_made_folders_left_empty() -> None:
    """Remove the folders this process made (:func:`~spinemesh.files.atomic.folders_made`) that hold
    nothing but a marker, innermost first: what a run that did not succeed calls as it ends. A run
    refused by a umask of 777, a full disk or Ctrl-C before it wrote anything left its output
    folder behind, empty, or holding the marker it had just written. A folder holding anything
    else is kept, as is one another run holds (its marker lists the files it found, or is being
    written)."""
    for folder in reversed(folders_made()):
        try:
            os.rmdir(folder)  # an empty folder, also one this run may not list (umask 777)
            continue
        except OSError:
            pass
        with contextlib.suppress(OSError):
            names = os.listdir(folder)
            if names and set(names) <= {OUTPUT_MARKER, WRITTEN_MARKER} and not any(
                    listed_files(marker := read_marker(folder / name)) or _found(marker) for name in names):
                for name in names:
                    os.unlink(folder / name)
                os.rmdir(folder)


def _found(marker: object) -> bool:
    """Whether an output folder's marker says a run holds the folder (``running``: another run into the
    same OUT, which took it over as this one ended) or found files there (``kept``)."""
    return isinstance(marker, dict) and (marker.get("running") is True or bool(marker.get("kept")))


# -- the second use: a folder of pictures or pages, its earlier files removed after the run --


def check_written_folder(folder: str | Path | None, what: str = "preview folder", holds: str = "preview") -> None:
    """Refuse a folder a command writes files into (a ``--preview``, ``--images``) that holds files
    but none spinemesh wrote (:func:`refuse_users_folder`). A folder spinemesh wrote before
    (:data:`WRITTEN_MARKER`, or the ``index.html`` of an ``upgrade`` or ``pack`` preview of a
    spinemesh that wrote no marker) is written over, as before.

    Parameters
    ----------
    what, holds : str
        The folder and what spinemesh writes there, as the error says them.

    Raises
    ------
    OutputError
        Naming the folder.
    """
    if folder is not None:
        refuse_users_folder(folder, WRITTEN_MARKER, f"{what} is not empty and holds no spinemesh {holds} (its "
                            "files would replace yours); choose an empty folder", what, _older_preview)


def _older_preview(folder: Path) -> bool:
    """Whether ``folder`` holds the ``index.html`` of a spinemesh preview (one written before markers)."""
    try:
        with open(folder / "index.html", "rb") as f:
            return b"<title>spinemesh " in f.read(512)
    except OSError:
        return False


def mark_written_folder(folder: str | Path) -> None:
    """Make ``folder`` and mark it as spinemesh's (:data:`WRITTEN_MARKER`), before its files are written:
    :func:`check_written_folder` lets a later run write into it again. A marker that lists an
    earlier run's files is kept: the run removes them once it ends (:func:`rewriting_folder`)."""
    make_folder(Path(folder))
    if not isinstance(read_marker(Path(folder) / WRITTEN_MARKER), dict):
        atomic_write_text(Path(folder) / WRITTEN_MARKER, "written by spinemesh; a later run writes its files here again\n")


@contextlib.contextmanager
def rewriting_folder(folder: str | Path | None):
    """While a run writes its files into ``folder`` (``upgrade --images``, ``weights --preview``):
    once it ends, the earlier run's files (its marker's list) that this one did not write again
    are removed, never a file spinemesh did not write, and the marker lists this run's files
    (:func:`mark_written_files`). A run that does not end, or writes nothing there (refused, or
    nothing to write), removes nothing of the earlier run's: its marker lists the earlier run's
    files and its own; a run that ends removes a killed run's temporary files in any case.
    ``None`` does nothing.
    """
    if folder is None:
        yield
        return
    folder = Path(folder)
    earlier = written_files(folder)
    before = folder_stamps(folder, WRITTEN_MARKER)
    done = False
    try:
        yield
        done = True
    finally:
        if folder.is_dir():
            written = [rel for rel, stamp in folder_stamps(folder, WRITTEN_MARKER).items() if before.get(rel) != stamp]
            if done:  # a killed run's temporary files go, whatever this run wrote
                remove_listed_files(folder, _temporary(earlier))
            with contextlib.suppress(SpineMeshError):  # the earlier marker stays: nothing lost
                mark_written_files(folder, written, earlier, ended=done and bool(written))


def written_files(folder: str | Path) -> dict[str, str | None]:
    """The files spinemesh wrote in ``folder``, with their digests: those its :data:`WRITTEN_MARKER`
    lists (:func:`mark_written_files`, :func:`listed_files`), and the temporary files a run
    killed outright left at any depth (:func:`temporary_files`). A run that ends removes them
    with the earlier run's files (:func:`remove_listed_files`, only while they hold the bytes
    read here: one that another run is still writing changes, and is kept)."""
    folder = Path(folder)
    return {**temporary_files(folder), **listed_files(read_marker(folder / WRITTEN_MARKER))}


def mark_written_files(folder: str | Path, written: Iterable[str], earlier: dict[str, str | None] | None = None,
                       ended: bool = True) -> None:
    """Mark ``folder`` as spinemesh's, listing ``written`` (POSIX paths under it) with their digests
    as they are now. With ``ended``, the files an earlier run wrote there (``earlier``, as
    :func:`written_files` read them before this run) that this one did not write again are removed
    first (:func:`remove_listed_files`): a preview written again leaves no stale page or picture of
    the earlier one. Otherwise they stay listed with the digests the earlier run gave them, so
    that a file replaced since is not taken for spinemesh's."""
    folder = Path(folder)
    written = set(written)
    left = {rel: digest for rel, digest in (earlier or {}).items() if rel not in written}
    if ended:
        remove_listed_files(folder, left)
        left = {}
    for rel in _temporary(left):  # a killed run's temporary files are found anew, never listed
        del left[rel]
    write_marker(folder, WRITTEN_MARKER, "written", marker_listing(folder, left, written))


def _temporary(files: dict[str, str | None]) -> dict[str, str | None]:
    """The files of ``files`` whose names the atomic writer gives its temporary files."""
    return {rel: digest for rel, digest in files.items() if is_temporary_name(rel.rpartition("/")[2])}
