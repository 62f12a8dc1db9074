"""File-system rules that every command follows.

- Paths named inside project files never leave the project folder (:func:`resolve_inside`),
  compared as real paths (symlinks resolved), never as string prefixes.
- Nothing is written inside an input project, onto an input file, or through a symlink
  (:class:`OutputGuard`; every command checks each path it writes).
- Output is written atomically (:func:`atomic_write_bytes`): a crash leaves either the old
  file or the new one, never half of one; the temporary file has a unique name in the target
  folder (two runs into one folder do not collide) and is removed on any error or interruption.
- No NaN or Infinity is ever written as JSON (:func:`atomic_write_json`).
"""

from __future__ import annotations

import errno
import hashlib
import json
import math
import os
import re
import secrets
import shutil
import stat
import unicodedata
from collections.abc import Iterable
from pathlib import Path

from .errors import OutputError, SpineMeshError, UnsafePathError


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


#: Files of one input folder compared with a file written in place that has several names
#: (:meth:`OutputGuard.check_in_place`): far above a project's hundreds.
MAX_LINK_SEARCH = 100_000


class OutputGuard:
    """The one check made before writing any file.

    Parameters
    ----------
    inputs : iterable of path
        Input files and folders (projects, images folders, source files). Nothing is written
        onto an input file or anywhere inside an input folder.
    root : path, optional
        The output folder, when a command writes a tree of files. No path below it may pass
        through a symlink (a symlink planted in the output folder would redirect the write)
        or climb out of it.

    Notes
    -----
    Paths are compared after resolving symlinks (``os.path.realpath``), never as strings,
    so ``p-evil/`` is not mistaken for being inside ``p/`` and ``out/link -> p/`` is caught.
    """

    def __init__(self, inputs: Iterable[str | Path | None], root: str | Path | None = None):
        self.inputs = [(Path(p), real(p)) for p in inputs if p is not None]
        self.root = Path(root) if root is not None else None

    def check_folder(self, folder: str | Path, what: str = "output folder", may_hold_inputs: bool = True) -> Path:
        """Refuse an output folder that is an existing file, an input, or inside an input.

        ``may_hold_inputs=False`` also refuses a folder that holds an input (for an output
        folder that may be emptied as a whole, like ``upgrade --overwrite`` does).
        """
        folder = Path(folder)
        check_name_lengths(folder, what=what)
        if folder.is_symlink():
            raise OutputError(f"{what} is a symlink; give the real folder", folder)
        if folder.exists() and not folder.is_dir():
            raise OutputError(f"{what} exists and is not a folder", folder)
        self._refuse_inputs(folder, what)
        if not may_hold_inputs:
            target = real(folder)
            for given, inp in self.inputs:
                if target in inp.parents:
                    raise OutputError(f"{what} holds the input {given}; choose a folder beside it", folder)
        return folder

    def check(self, path: str | Path, what: str = "output file") -> Path:
        """Return ``path`` if it may be written; raise :class:`OutputError` otherwise."""
        path = Path(path)
        check_name_lengths(path, what=what)
        if path.is_symlink():
            raise OutputError(f"{what} is a symlink; refusing to write through it", path)
        if path.is_dir():
            raise OutputError(f"{what} is a folder", path)
        if path.exists() and not path.is_file():
            # written whole and renamed into place, an output replaces what is there: as root, /dev/null itself
            raise OutputError(f"{what} is {special_kind(os.stat(path).st_mode)}, not a regular file; an output "
                              "replaces its file whole, so name a regular file", path)
        if self.root is not None:
            lexical = Path(os.path.abspath(path))
            root = Path(os.path.abspath(self.root))
            try:
                rel = lexical.relative_to(root)
            except ValueError:
                raise OutputError(f"{what} would lie outside the output folder {self.root}", path) from None
            if ".." in rel.parts:
                raise OutputError(f"{what} would lie outside the output folder {self.root}", path)
            if real(path) != real(root) / rel:
                raise OutputError(f"{what} passes through a symlink inside the output folder", path)
        self._refuse_inputs(path, what)
        return path

    def check_in_place(self, path: str | Path, what: str) -> Path:
        """:meth:`check` of a file written in place, not replaced by a rename (standard output
        redirected to it by a shell): also refused when it is an input file, or a file inside an
        input folder, under another name (a hard link), since writing it writes that input. A
        rename breaks such a link, so files written atomically need no such check.

        Only a file of several names is looked for, among at most :data:`MAX_LINK_SEARCH` files
        of each input folder (a project has hundreds).
        """
        path = self.check(path, what)
        try:
            st = os.stat(path)
        except OSError:
            return path
        if st.st_nlink < 2:
            return path
        for given, inp in self.inputs:
            files = [inp] if not inp.is_dir() else (f for _, _, fs in walk_folder(inp, hidden=True) for f in fs)
            for n, f in enumerate(files):
                if n >= MAX_LINK_SEARCH:
                    break
                try:
                    same = os.path.samestat(os.stat(f), st)
                except OSError:
                    continue
                if same:
                    shown = given if f == inp else f
                    raise OutputError(f"{what} is the input {shown} under another name (a hard link); the input "
                                      "is never overwritten", path)
        return path

    def _refuse_inputs(self, path: Path, what: str) -> None:
        target = real(path)
        for given, inp in self.inputs:
            if target == inp:
                raise OutputError(f"{what} is the input {given}; the input is never overwritten", path)
            if inp.is_dir() and inp in target.parents:
                # "the input ." says little: the folder a skeleton lies in is its project, the current one here
                shown = f"folder {inp}" if str(given) in ("", ".") else str(given)
                raise OutputError(f"{what} lies inside the input {shown}; nothing is written there: give a path "
                                  "outside it", path)


def project_folder(path: str | Path) -> Path:
    """The folder an input stands for: itself for a folder, its folder for a file (a skeleton's
    project is the folder it lies in).

    Raises
    ------
    SpineMeshError
        ``PATH: no such file or folder``: a missing project is said as such before its outputs
        are checked against it (its folder would be the one it was named from).
    """
    path = existing(path)
    return path if path.is_dir() else path.parent


def named_project(path: str | Path) -> Path:
    """``path`` (a command's project: a folder, or a skeleton file) as a run names it: one whose
    folder is the current one (``.``, ``hero.json`` given from inside the project) absolute, any
    other (and one not there, refused as given later) as given. A file of the project is then
    named by a path that holds the project folder (``/home/me/hero/hero.atlas``, not
    ``hero.atlas``), which :func:`named_within` names from the folder's name (``hero/hero.atlas``):
    a report is the same bytes from inside the project as from elsewhere. A path the console
    shows stays one to open."""
    path = Path(path)
    folder = path if path.is_dir() else path.parent
    return Path(os.path.abspath(path)) if path.exists() and os.path.normpath(folder) == "." else path


def existing(path: str | Path) -> Path:
    """``path`` if something is there; refused as ``PATH: no such file or folder`` otherwise (the
    one line every command gives for a missing input, before anything else is checked)."""
    path = Path(path)
    if not path.exists():
        from .errors import SpineMeshError

        raise SpineMeshError("no such file or folder", path)
    return path


def named_within(value, folder: str | Path | None):
    """``value`` (text, or a JSON-able object of texts) with every path into ``folder`` named from
    the folder's own name: ``/home/ci/build/game/hero/hero.png`` and ``../hero/hero.png``, for a
    ``folder`` given as ``../hero``, both become ``hero/hero.png``. A report or a page names the
    project's files so, not by the path that differs from one folder or machine to the next (its
    bytes then are the same there); the console keeps the whole paths, to open.

    ``folder`` None changes nothing. A project named ``.`` would have its files named without a
    folder: a command gives it to its run absolute (:func:`named_project`).
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


def refuse_report_over_output(report: Path, out: Path) -> None:
    """Refuse a ``--report`` that would replace a file in OUT: one the run wrote (an atlas, a
    skeleton) or one it kept there, not its own (an earlier run's report was removed with its files)."""
    if is_within(report, out) and report.exists():
        raise OutputError("--report would replace a file in the output folder (this run's, or one it keeps "
                          "there); name it apart", report)


def refuse_overlapping_outputs(out: Path, others: dict) -> None:
    """Refuse an output folder given as OUT, inside OUT or holding OUT: a file of one would
    silently replace a file of the other (an editor image named like a page)."""
    for option, path in others.items():
        if path is not None and (is_within(path, out) or is_within(out, path)):
            raise OutputError(f"{option} {path} overlaps the output folder {out}; give a folder or file "
                              "beside it", path)


def refuse_one_output_twice(paths: Iterable[str | Path | None]) -> None:
    """Refuse two outputs (files, or folders writing the same names) that are one: on this disk,
    or on a macOS or Windows one (:func:`portable_name`); the second would replace the first.

    Raises
    ------
    OutputError
        Naming both.
    """
    given: dict[str, str | Path] = {}
    for path in paths:
        if path is None:
            continue
        other = given.setdefault(portable_name(real(path)), path)
        if other is not path:
            where = "" if real(other) == real(path) else " on a macOS or Windows disk"
            raise OutputError(f"{other} and {path} are the same path{where}: give each output its own name", path)


def check_outputs(inputs: Iterable[str | Path | None], files: Iterable[str | Path | None] = (),
                  folders: Iterable[str | Path | None] = ()) -> None:
    """Check, before any work, every output a command was given (``None`` entries are ignored).
    A folder written into again is checked by :func:`spinemesh.written_folder.check_written_folder` too.

    Raises
    ------
    OutputError
        For the first output that :class:`OutputGuard` refuses, naming it.
    """
    guard = OutputGuard(inputs)
    for folder in folders:
        if folder is not None:
            guard.check_folder(folder)
    for file in files:
        if file is not None:
            guard.check(file)
    refuse_one_output_twice(files)


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


def _write_error(e: OSError, path: Path) -> OutputError:
    if e.errno == errno.ENOSPC:
        reason = "disk full"
    elif e.errno in (errno.EACCES, errno.EPERM, errno.EROFS):
        reason = "permission denied (read-only?)"
    else:
        reason = e.strerror or str(e)
    return OutputError(f"cannot write: {reason}", path)


def make_folder(folder: str | Path) -> Path:
    """``mkdir -p`` that reports a failure as :class:`OutputError` naming the folder."""
    folder = Path(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        raise OutputError("cannot create folder: a file of that name exists", folder) from None
    except OSError as e:
        raise _write_error(e, folder) from None
    return folder


def _temporary_name(name: str, token: str) -> str:
    """``.<name>.<token>.tmp``, the name cut so that the whole stays within :data:`NAME_MAX` bytes:
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
                raise _write_error(e, path) from None
        except OSError as e:
            raise _write_error(e, path) from None
    try:
        with os.fdopen(fd, "wb") as f:
            fill(f)
            f.flush()
            os.fsync(f.fileno())
    except OSError as e:
        raise _write_error(e, path) from None


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
                raise _write_error(e, path) from None
            staged.pop(0)
    finally:
        for tmp, _ in staged:
            Path(tmp).unlink(missing_ok=True)


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
    """Copy the file ``source`` to ``path`` atomically (see :func:`atomic_write_bytes`)."""
    def fill(f):
        with open(source, "rb") as src:
            shutil.copyfileobj(src, f, 1 << 20)

    _atomic(Path(path), fill)


def atomic_write_text(path: str | Path, text: str) -> None:
    """Atomic :func:`atomic_write_bytes` for UTF-8 text."""
    atomic_write_bytes(path, utf8(text, path))


def name_as_text(name: str) -> str:
    """A file name read from a disk as text a UTF-8 file can hold: bytes of it that are not UTF-8
    (which Python keeps as lone surrogates) become U+FFFD, each.

    Examples
    --------
    >>> name_as_text(b"hero\\xff.png".decode("utf-8", "surrogateescape"))
    'hero\ufffd.png'
    """
    return name.encode("utf-8", "surrogateescape").decode("utf-8", "replace")


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


def strict_json(obj, indent=None, path: str | Path | None = None, compact: bool = False) -> str:
    """JSON text that never holds NaN or Infinity (strict parsers and the runtimes reject them).

    ``compact``: no space after ``,`` and ``:`` (a model of thousands of trees), for ``indent`` None.

    Raises
    ------
    SpineMeshError
        If ``obj`` holds a non-finite number (naming ``path``, the file it was meant for).
    """
    try:
        return json.dumps(obj, indent=indent, ensure_ascii=False, allow_nan=False,
                          separators=(",", ":") if compact else None)
    except ValueError as e:
        raise SpineMeshError(f"not written: it would hold a non-finite number ({e})", path) from None


def finite(obj):
    """``obj`` with every NaN or infinite float (Python's or NumPy's) replaced by None, in dicts,
    lists and tuples at any depth: strict JSON for figures that may be undefined (a score of no
    sample, a loss that diverged), where :func:`strict_json` would refuse them."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [finite(v) for v in obj]
    return obj


def atomic_write_json(path: str | Path, obj, indent: int | None = 2) -> None:
    """Atomically write ``obj`` as strict JSON (UTF-8, non-ASCII kept, no NaN or Infinity)."""
    atomic_write_text(path, strict_json(obj, indent, path) + "\n")


def strict_json_pieces(head: dict, key: str, items: Iterable, path: str | Path | None = None):
    """The text of ``strict_json({**head, key: list(items)}, None, path)``, in pieces: the
    object up to the list's ``[``, then each item's text as the item is taken from ``items``
    (an iterator may make them one at a time), then ``]}``. So a list too large to hold
    whole is written as one item at a time, to the same characters.

    Parameters
    ----------
    head : dict
        The object's members before the list; ``key`` must not be one of them.
    key : str
        The name of the list, the object's last member.
    items : iterable
        The list's items, each turned to text (and checked) when it is taken.

    Yields
    ------
    str
        Pieces of the text, in order.

    Raises
    ------
    SpineMeshError
        When an item holds a non-finite number, as :func:`strict_json` does, when that item is
        reached: what came before it is already given out.
    """
    if key in head:
        raise ValueError(f"{key!r} is one of the head's members: the list must be the last one")
    empty = strict_json({**head, key: []}, None, path)
    yield empty[:-len("[]}")] + "["    # the list, last, closes the text
    for i, item in enumerate(items):
        yield (", " if i else "") + strict_json(item, None, path)
    yield "]}"


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


def atomic_write_png(path: str | Path, image) -> None:
    """Atomically write an RGBA/RGB/gray uint8 array as PNG."""
    import io

    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(image).save(buf, format="PNG")
    atomic_write_bytes(path, buf.getvalue())


def walk_folder(root: str | Path, problems: list[str] | None = None, hidden: bool = False):
    """Walk ``root`` top-down: yield ``(folder, subfolders, files)``, each list sorted.

    The one folder walk of every command (projects, libraries, data sets, ``mesh DIR``, images
    folders), so that each keeps the same rules:

    - symlinked folders are never entered (their real folder, when it lies inside ``root``, is
      walked under its own name anyway), so a walk cannot leave ``root`` or loop (``ln -s .``);
      no real folder is entered twice;
    - ``files`` are regular files only (no FIFO, socket or device, which would block or never
      end when read); a symlinked file is kept only when its real path lies inside ``root``;
    - names starting with ``.`` are left out unless ``hidden``.

    Like ``os.walk``, the caller may prune the walk by removing names from ``subfolders``.

    Parameters
    ----------
    root : path
        The folder walked.
    problems : list of str, optional
        Gets one line per symlink left out because it leads outside ``root``.
    hidden : bool
        Whether hidden files and folders are walked too.
    """
    root = Path(root)
    top = real(root)
    seen: set[Path] = set()
    for here, dirs, names in os.walk(root, followlinks=False):
        here_path = Path(here)
        here_real = real(here_path)
        if here_real in seen or not (here_real == top or top in here_real.parents):
            dirs[:] = []
            continue
        seen.add(here_real)
        # a symlinked folder is never entered (noted when it leads out); a symlinked file
        # counts only when it stays inside, and only regular files count (is_file)
        subfolders = [here_path / d for d in sorted(dirs) if hidden or not d.startswith(".")]
        subfolders = [p for p in subfolders if not _noted_link(p, root, problems, "folder") and not p.is_symlink()]
        files = [here_path / n for n in sorted(names) if hidden or not n.startswith(".")]
        files = [p for p in files if not _noted_link(p, root, problems, "file") and p.is_file()]
        yield here_path, subfolders, files
        dirs[:] = [p.name for p in subfolders]


def _noted_link(path: Path, root: Path, problems: list[str] | None, kind: str) -> bool:
    """Whether ``path`` is a symlink leading outside ``root``; noted in ``problems`` if so."""
    if not path.is_symlink() or is_within(path, root):
        return False
    if problems is not None:
        problems.append(f"{path}: symlink to a {kind} outside the project; skipped")
    return True


def walk_files(root: str | Path, problems: list[str] | None = None) -> list[Path]:
    """Every regular, non-hidden file under ``root``, sorted, by the rules of :func:`walk_folder`."""
    return sorted(p for _, _, files in walk_folder(root, problems) for p in files)


def regular_file(path: str | Path, what: str = "file") -> Path:
    """``path`` if it names a regular file (through symlinks); refused otherwise.

    A FIFO or device given as an input would block for ever or never end when read.

    Raises
    ------
    SpineMeshError
        Naming the file and what it is instead.
    """
    import stat

    path = Path(path)
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        raise SpineMeshError(f"no such {what}", path) from None
    except OSError as e:
        raise SpineMeshError(f"cannot read {what}: {e.strerror}", path) from None
    if stat.S_ISDIR(mode):
        raise SpineMeshError(f"{what} is a folder", path)
    if not stat.S_ISREG(mode):
        raise SpineMeshError(f"{what} is {special_kind(mode)}, not a regular file; only regular files are read", path)
    return path


def special_kind(mode: int) -> str:
    """What a file that is neither a regular file nor a folder is, in words, by its ``st_mode``."""
    import stat

    return "a FIFO" if stat.S_ISFIFO(mode) else "a socket" if stat.S_ISSOCK(mode) else "a device"
