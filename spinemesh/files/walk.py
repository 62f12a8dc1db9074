"""The one folder walk of every command (projects, libraries, data sets, ``mesh DIR``, images
folders): symlinks never lead out of the folder walked, only regular files are listed.
"""

from __future__ import annotations

import os
from pathlib import Path

from .inside import is_within, real


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
        Gets one line per symlink left out because it leads outside ``root``, and one per
        folder that could not be listed (permission denied).
    hidden : bool
        Whether hidden files and folders are walked too.
    """
    root = Path(root)
    top = real(root)
    seen: set[Path] = set()

    def unreadable(error: OSError) -> None:
        # a folder the user may not list (mode 000, another account's) was left out without a
        # word, the skeletons in it not upgraded, exit 0
        if problems is not None:
            problems.append(f"{error.filename}: folder not read ({error.strerror}); the files in it were left out")

    for here, dirs, names in os.walk(root, onerror=unreadable, followlinks=False):
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
