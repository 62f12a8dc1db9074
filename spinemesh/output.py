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
from pathlib import Path

try:
    import fcntl  # POSIX: a run holds its output folder
except ImportError:  # Windows: no lock
    fcntl = None

from .errors import OutputError, SpineMeshError
from .files.atomic import (atomic_copy, atomic_write_bytes, atomic_write_text, make_folder, stop_if_every_write_refused,
                           write_refused)
from .files.disk import file_digest
from .files.guard import OutputGuard, refuse_report_over_output
from .project import Project
from .skeleton import dumps_skeleton, is_binary_skeleton
from .written_folder import (
    OUTPUT_MARKER,
    folder_stamps,
    holds_files,
    listed_files,
    marker_listing,
    read_marker,
    refuse_users_folder,
    remove_listed_files,
    temporary_files,
    write_marker,
)

#: The one line an older spinemesh wrote in :data:`OUTPUT_MARKER`, listing nothing. ``overwrite``
#: then removes every file such a run could have written (:func:`_older_runs_files`), and keeps
#: the files no upgrade writes: hidden ones (``.gitignore``) and a game engine's ``.meta``. Any
#: other marker that is not a list of the run's files (edited by hand, emptied, cut) is refused:
#: nothing of it says what to remove.
OLDER_OUTPUT_MARKER = "written by spinemesh upgrade; --overwrite may replace this folder"


def check_output_folder(project_root: Path, out: Path, images_in: Path | None = None) -> None:
    """Refuse an output folder that is an input, lies inside one or holds one (see :class:`OutputGuard`)."""
    OutputGuard([project_root, images_in]).check_folder(out, may_hold_inputs=False)


@contextlib.contextmanager
def output_folder(out: Path, overwrite: bool):
    """Hold ``out`` for one run: an empty folder marked as ours, or one an earlier run wrote.

    The first use of :mod:`spinemesh.written_folder`'s marker: an existing ``out`` that holds
    files is refused unless ``overwrite``, and then unless an earlier run wrote it
    (:data:`OUTPUT_MARKER`); the files that run wrote are removed BEFORE this one, so that no
    stale page or skeleton stays beside the new ones (a runtime loading the folder could pick
    it up), and every other file is kept. A killed run's temporary files go in any case (a
    folder holding only those is empty). The marker lists the files this run writes: while
    it lasts, the files it found (kept, whatever ends the run); once it ends, those it wrote.
    The folder itself is kept and locked (``flock``) while the run lasts: a second run into
    the same folder waits for the first to end instead of deleting or overwriting its files
    half-way.
    """
    if out.exists() and not out.is_dir():
        raise SpineMeshError("output folder exists and is not a folder", out)
    fd = _locked_folder(out)
    try:
        if holds_files(out):
            if not overwrite:
                raise SpineMeshError("output folder is not empty; pass --overwrite to write it again", out)
            # before anything is removed: a page written below a symlinked folder would leave OUT
            refuse_users_folder(out, OUTPUT_MARKER, "output folder is not empty and was not written by spinemesh "
                                "(no .spinemesh-output); nothing is written there: choose another --out")
            _remove_earlier_run(out)
        remove_listed_files(out, temporary_files(out))  # a killed run's, the folder held: no other run's
        found = _files_under(out)
        _write_marker(out, {"running": True, "kept": sorted(found), "folder": _identity(out)})
        try:
            yield out
        finally:
            written = [rel for rel, stamp in _files_under(out).items() if found.get(rel) != stamp]
            with contextlib.suppress(SpineMeshError):  # the running marker stays: found files kept still
                _write_marker(out, marker_listing(out, {}, written))
    finally:
        os.close(fd)  # releases the lock


def _locked_folder(out: Path) -> int:
    """A descriptor of the folder ``out``, made where missing, locked (``flock``) for this run. Taken
    again when the folder was removed while this run waited for the lock: a run that fails removes
    the folder it made and left empty, and this one would have held the lock of a folder gone, while
    its files went into a new one of the same name that a third run could enter."""
    for _ in range(100):
        make_folder(out)
        try:
            fd = os.open(out, os.O_RDONLY)
        except OSError as e:  # a folder made under umask 777: it was said as a bare "Permission denied"
            raise write_refused(e, out) from None
        try:
            if fcntl is None:
                return fd
            fcntl.flock(fd, fcntl.LOCK_EX)
            with contextlib.suppress(OSError):
                if os.path.samestat(os.fstat(fd), os.stat(out)):
                    return fd
        except BaseException:
            os.close(fd)
            raise
        os.close(fd)
    raise OutputError("the output folder was removed again and again while this run waited for it", out)


def write_run_report(report: Path, out: Path, write) -> None:
    """A run's ``--report``, written by ``write(report)`` once the run holding ``out`` ended: refused
    over a file of ``out`` (:func:`~spinemesh.files.guard.refuse_report_over_output`), and when inside
    it, listed among the run's files (:func:`note_written`)."""
    refuse_report_over_output(report, out)
    write(report)
    note_written(out, report)


def run_report_error(report: Path | None, out: Path, write, written: str) -> str:
    """:func:`write_run_report` for a run whose output is written: ``""``, or, when the report cannot
    be written (its folder a file, a full disk), the one error line saying so and what the run wrote
    (``written``: ``"the 2 skeletons listed above"``), for the command to say last and end done in
    part (exit 3): raised, the error would end it refused (exit 2), the status of a run that wrote
    nothing, before it said what it wrote. With ``written`` empty, raised as it is."""
    if report is None:
        return ""
    try:
        write_run_report(report, out, write)
    except SpineMeshError as e:
        if not written:
            raise
        return f"{e}; --report not written (written in {out}: {written})"
    return ""


def note_written(out: Path, path: Path) -> None:
    """List ``path``, a file written in ``out`` once the run holding it ended (a ``--report``), among
    the run's files in its marker, so that the next ``overwrite`` removes it too."""
    marker = read_marker(out / OUTPUT_MARKER)
    if not isinstance(marker, dict) or not isinstance(marker.get("written"), list):
        return
    try:
        rel = Path(os.path.abspath(path)).relative_to(os.path.abspath(out)).as_posix()
    except ValueError:
        return
    _write_marker(out, marker_listing(out, listed_files(marker), [rel]))


def _files_under(out: Path) -> dict[str, tuple | None]:
    """Every file under ``out`` but the marker, with its stamp (:func:`~spinemesh.written_folder.folder_stamps`)."""
    return folder_stamps(out, OUTPUT_MARKER)


def _write_marker(out: Path, what: dict) -> None:
    write_marker(out, OUTPUT_MARKER, "output folder", what)


def _remove_earlier_run(out: Path) -> None:
    """Remove from ``out`` the files an earlier run wrote there, as its marker lists them (each
    only while it is the file the run left, :func:`~spinemesh.written_folder.remove_listed_files`),
    and the folders they leave empty; any other file stays. A run that did not end (its marker
    lists what it found, and names this very folder) wrote every file but those; an older
    spinemesh's marker lists none: the files such a run could have written go
    (:func:`_older_runs_files`). Any other marker is refused, every file kept."""
    marker = read_marker(out / OUTPUT_MARKER)
    if not isinstance(marker, dict) or marker.get("spinemesh") != "output folder":
        if not _older_marker(out / OUTPUT_MARKER):
            raise _unknown_marker(out)
        ours = _older_runs_files(out)
    elif isinstance(marker.get("written"), list):
        ours = listed_files(marker)
    elif (marker.get("running") is True and isinstance(marker.get("kept"), list)
          and marker.get("folder") == _identity(out)):
        kept = set(marker["kept"])
        ours = {rel: file_digest(out / rel) for rel in _files_under(out) if rel not in kept}
    else:
        raise _unknown_marker(out)
    remove_listed_files(out, ours)


def _older_runs_files(out: Path) -> dict[str, str | None]:
    """The files under ``out`` that an older spinemesh's run, whose marker listed none, could have
    written, with their digests: every file but hidden ones (a name or folder beginning with ``.``:
    a project's hidden files are never read, so never copied; a ``.gitignore``, ``.git/``) and a
    game engine's ``.meta`` files (Unity makes one beside each file it imports, holding the id every
    reference to the file uses). That spinemesh emptied the folder as a whole, a studio's files
    put there since too."""
    return {rel: file_digest(out / rel) for rel in _files_under(out)
            if not any(part.startswith(".") for part in rel.split("/")) and not rel.lower().endswith(".meta")}


def _identity(out: Path) -> list[int]:
    """The folder itself (device, inode): a running run's marker copied into another folder, or
    edited, names another, and says nothing of what was written there. Only a marker of a run
    that did not end holds it (a finished run's marker is the same bytes anywhere)."""
    st = os.stat(out)
    return [st.st_dev, st.st_ino]


def _older_marker(path: Path) -> bool:
    """Whether ``path`` holds :data:`OLDER_OUTPUT_MARKER` (read within a few bytes more than it)."""
    try:
        with open(path, "rb") as f:
            return f.read(len(OLDER_OUTPUT_MARKER) + 8).strip() == OLDER_OUTPUT_MARKER.encode()
    except OSError:
        return False


def _unknown_marker(out: Path) -> OutputError:
    return OutputError(f"the folder's {OUTPUT_MARKER} is not one spinemesh wrote there (edited or copied?): nothing "
                       "says which files an earlier run wrote; refusing to delete any, choose another --out", out)


def write_skeleton(doc: dict, path: Path, dest: Path) -> None:
    """Write ``doc`` to ``dest`` in the format ``path`` came in (binary ``.skel`` or JSON).

    JSON keeps the text of ``path`` wherever ``doc`` did not change, in its formatting, so
    that a version-control diff shows only the upgraded attachments.
    """
    if is_binary_skeleton(path):
        from .skeleton_binary import encode_skel

        atomic_write_bytes(dest, encode_skel(doc, dest))
    else:
        original = path.read_bytes().decode("utf-8")  # a byte-order mark stays (splice keeps it)
        atomic_write_text(dest, dumps_skeleton(doc, dest, like=original))


def copy_other_files(proj: Project, out: Path, written: set[Path], needed: set[Path] | None = None) -> list[str]:
    """Copy every file of the project that is not a skeleton (atlases, pages, anything else).

    Each atlas is copied after its pages, and not when one of them could not be copied
    (:func:`check_pages_copied`); a file that cannot be copied does not stop the others.
    Returns one ``"not copied: ..."`` line per file not copied.
    """
    return copy_atlases_last(files_to_copy(proj, out, written, needed), atlas_pages(proj))


def copy_atlases_last(pairs: list[tuple[Path, Path]], pages_of: dict[Path, set[Path]], copy=atomic_copy,
                      failed: set[Path] | None = None) -> list[str]:
    """Copy each ``(source, destination)`` of ``pairs`` with ``copy``, the atlases (``pages_of``,
    :func:`atlas_pages`) last, each only when its pages were copied (:func:`check_pages_copied`);
    a file that cannot be copied does not stop the others. ``failed``: the real paths of files
    not copied before (pages copied apart). Returns one ``"not copied: ..."`` line per file not
    copied."""
    failed = set() if failed is None else failed
    errors = []
    for source, dest, real in sorted(((s, d, s.resolve()) for s, d in pairs), key=lambda row: row[2] in pages_of):
        try:
            check_pages_copied(pages_of.get(real, set()), failed, dest)
            copy(source, dest)
        except SpineMeshError as e:
            stop_if_every_write_refused(e)
            failed.add(real)
            errors.append(f"not copied: {e}")
    return errors


def files_to_copy(proj: Project, out: Path, written: set[Path], needed: set[Path] | None = None
                  ) -> list[tuple[Path, Path]]:
    """``(source, destination)`` of every file of the project that is copied as it is.

    Every file but the skeletons (atlases, pages, anything else).

    With ``needed`` (real paths), skeletons, atlases and images are copied only if listed: one
    skeleton asked for does not bring its twins (``hero.json`` beside ``hero.skel``) or other
    skeletons' atlases along; other files (a licence, audio) still come.
    """
    from .images.decode import IMAGE_EXTENSIONS
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


def atlas_pages(proj: Project) -> dict[Path, set[Path]]:
    """The page files (real paths) of each usable atlas of the project, by the atlas's real path.

    A copy of the project copies an atlas after its pages, and not when one of them could not be
    copied (a full disk): a runtime would read the atlas and miss its page.
    """
    from .images.sources import AtlasImages
    from .project import project_atlases

    return {path.resolve(): {AtlasImages.page_path(atlas, page.name, proj.root).resolve() for page in atlas.pages}
            for path, atlas in project_atlases(proj).items()}


def check_pages_copied(pages: set[Path], failed: set[Path], dest: Path) -> None:
    """Refuse to copy an atlas to ``dest`` when one of its ``pages`` (:func:`atlas_pages`) is among
    the ``failed`` copies: a runtime would read the atlas and miss its page."""
    if pages & failed:
        raise SpineMeshError("a page it names was not copied (without it, the atlas would not load)", dest)


def files_needed(doc: dict, source) -> set[Path]:
    """The files a skeleton needs beside it (real paths): its atlases and their pages, or its images."""
    from .images.sources import AtlasImages, FolderImages
    from .project import needed_images

    if isinstance(source, AtlasImages):
        return {Path(a.path).resolve() for a in source.atlases} | {
            source.page_file(a, i).resolve() for a in source.atlases for i in range(len(a.pages))}
    if isinstance(source, FolderImages):
        return {p.resolve() for p in map(source.path_of, sorted(needed_images(doc))) if p is not None}
    return set()
