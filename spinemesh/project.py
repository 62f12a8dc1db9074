"""Finding the parts of a Spine project on disk and matching skeletons to their images.

A project as exported for game runtimes is a folder (often nested) holding skeletons
(``.json``, ``.skel``, Unity's ``.json.txt`` / ``.skel.bytes``), atlases (``.atlas``,
``.atlas.txt``) with their page images, or an ``images/`` folder as the editor uses.
No file says which atlas belongs to which skeleton, so :func:`image_source_for` picks the
atlases that hold the skeleton's images.

Safety rules, in one place for every command:

- only regular files whose real path lies inside the project are taken; a symlink leading
  outside is skipped with a note in ``Project.problems``, and symlinked folders are not
  entered (:func:`~spinemesh.files.walk.walk_folder`, the one walk of every command);
- :func:`project_atlases` is the one way atlases are read: a broken atlas is reported in
  ``Project.problems`` and left out, and the rest of the project goes on;
- image folders (the ``skeleton.images`` hint, ``images/`` folders) are used only when their
  real path lies inside the project.
"""

from __future__ import annotations

import os
import re
import shlex
from dataclasses import dataclass, field
from pathlib import Path

from .atlas import Atlas, page_mismatches, read_atlas
from .errors import SpineMeshError, UnsafePathError
from .files.inputs import existing, regular_file
from .files.inside import is_within, page_not_found_said, real, resolve_inside
from .files.walk import walk_folder
from .images.decode import image_size
from .images.pages import PageStore
from .images.sources import AtlasImages, FolderImages
from .skeleton import SKELETON_SUFFIXES, image_paths, iter_attachments, load_skeleton

ATLAS_SUFFIXES = (".atlas", ".atlas.txt")


def _has_suffix(path: Path, suffixes) -> bool:
    return path.name.lower().endswith(suffixes)


_SKELETON_OBJECT = re.compile(rb'"skeleton"\s*:\s*\{')


def is_skeleton_file(path: Path) -> bool:
    """Whether ``path`` is a skeleton: binary by name, or JSON with a ``"skeleton"`` object."""
    name = path.name.lower()
    if not path.is_file() or not _has_suffix(path, SKELETON_SUFFIXES) or name.endswith(".source.json"):
        return False
    if name.endswith((".skel", ".skel.bytes")):
        return True
    try:
        with open(path, "rb") as f:
            head = f.read(4096)
    except OSError:
        # a file of a skeleton's name it may not read (permission denied) may be one: reading it
        # says why, as that skeleton's line; it ended every command on the project in one error
        return True
    stripped = head.lstrip(b"\xef\xbb\xbf \t\r\n")
    if not stripped.startswith(b"{"):
        # Binary skeletons shipped under a .json name: version string in the header.
        return b"\x00" in head[:16] or b"4." in head[:40] or b"3." in head[:40]
    # A top-level "skeleton" object, which every editor export has (first key, so within the
    # head); a report or any other JSON that only names a skeleton does not count.
    return _SKELETON_OBJECT.search(head) is not None


@dataclass
class Project:
    """The skeletons, atlases and image folders found under ``root``.

    Attributes
    ----------
    files : list of Path
        Every regular, non-hidden file of the project whose real path lies inside ``root``
        (what ``upgrade`` copies).
    problems : list of str
        One line per thing left out: symlinks leading outside, broken atlases, missing pages.
    warnings : list of str
        One line per atlas page that runtimes draw differently (used all the same).
    """

    root: Path
    skeletons: list[Path] = field(default_factory=list)
    atlases: list[Path] = field(default_factory=list)
    image_folders: list[Path] = field(default_factory=list)
    files: list[Path] = field(default_factory=list)
    problems: list[str] = field(default_factory=list)
    #: One line per atlas page that runtimes draw differently from one another (its size line
    #: against its image, see :func:`spinemesh.atlas.page_mismatches`): used all the same.
    warnings: list[str] = field(default_factory=list)
    #: Each atlas file left out by :func:`project_atlases`, with the reader's own error (one line).
    broken_atlases: dict[Path, str] = field(default_factory=dict)
    parsed_atlases: dict[Path, Atlas] | None = field(default=None, repr=False)
    page_store: PageStore | None = field(default=None, repr=False)


def _walk(root: Path, problems: list[str]) -> tuple[list[Path], list[Path]]:
    """Non-hidden regular files and folders under ``root``, sorted (:func:`~spinemesh.files.walk.walk_folder`)."""
    files, folders = [], []
    for _, subfolders, found in walk_folder(root, problems):
        folders += subfolders
        files += found
    return sorted(files), sorted(folders)


def find_project(path: str | Path, folder_taken: bool = True) -> Project:
    """Collect a project from a folder (searched recursively) or from one skeleton file.

    For a skeleton file, the project root is its folder and only that skeleton is taken.
    Nothing outside the project's real folder is taken (see the module notes).

    Parameters
    ----------
    path : path
        A project folder, or one skeleton file in it.
    folder_taken : bool
        Whether the command takes a project's folder, which a file that is no skeleton is told
        to give instead (``pose`` takes a skeleton only).

    Returns
    -------
    Project
        Its skeletons (``.json`` and ``.skel``, sorted), atlases, ``images`` folders and
        every other file; what was left out is in ``problems``.

    Examples
    --------
    >>> from spinemesh.demo import make_demo_project
    >>> proj = find_project(make_demo_project("demo"))
    >>> [p.name for p in proj.skeletons], [p.name for p in proj.atlases], [p.name for p in proj.image_folders]
    (['demo-binary.skel', 'demo.json'], ['demo.atlas'], ['images'])
    """
    path = existing(path)
    if not path.is_dir():
        regular_file(path, "skeleton")  # a FIFO or device would block or never end
    root = path.parent if path.is_file() else path
    project = Project(root=root)
    files, folders = _walk(root, project.problems)
    project.files = files
    if path.is_file():
        if not is_skeleton_file(path):
            raise SpineMeshError(not_a_skeleton_said(path, [p for p in files if is_skeleton_file(p)], folder_taken),
                                 path)
        project.skeletons = [path]
    else:
        project.skeletons = [p for p in files if is_skeleton_file(p)]
    project.atlases = [p for p in files if _has_suffix(p, ATLAS_SUFFIXES)]
    project.image_folders = [d for d in folders if d.name == "images"]
    return project


def no_skeleton_said(at_any_depth: bool = False) -> str:
    """Why a folder given for a project (or a library) is refused when it holds no skeleton, and
    what to give instead; the caller names the folder before it, ``FOLDER: ...``, as every error
    names its file. ``at_any_depth``: the folders below it were searched too (a library).

    One line for every command: ``upgrade``, ``weights``, ``info``, ``diff`` and ``dataset`` each
    had their own words for it.

    Examples
    --------
    >>> print(no_skeleton_said())
    no Spine skeleton found (a .skel file, or a .json with a "skeleton" object); give the folder the editor exported to
    >>> print(no_skeleton_said(at_any_depth=True).split("; ")[1])
    give the folder that holds the exported projects
    """
    depth, folder = (" at any depth", "that holds the exported projects") if at_any_depth else ("", "the editor exported to")
    return f"no Spine skeleton found{depth} (a .skel file, or a .json with a \"skeleton\" object); give the folder {folder}"


def not_a_skeleton_said(path: Path, skeletons: list[Path], folder_taken: bool = True) -> str:
    """Why a file given for a project is refused when it is no skeleton (its atlas, a page image),
    and what to give instead: one of ``skeletons`` (those found in its folder), or with
    ``folder_taken`` the folder itself.

    A user who drops the atlas or the page onto the command was told only ``not a Spine
    skeleton``; the folder is written as a shell takes it (quoted when it holds a space).

    Examples
    --------
    >>> not_a_skeleton_said(Path("my hero/hero.atlas"), [Path("my hero/hero.json")])
    "not a Spine skeleton (.json or .skel): give the project's folder, 'my hero', or a skeleton in it (hero.json)"
    >>> not_a_skeleton_said(Path("my hero/hero.atlas"), [Path("my hero/hero.json")], folder_taken=False)
    'not a Spine skeleton (.json or .skel): give a skeleton of its folder (hero.json)'
    """
    folder = shlex.quote(str(path.parent))
    if not skeletons:
        return (f"not a Spine skeleton (.json or .skel), and its folder {folder} holds none: give "
                f"{'the folder' if folder_taken else 'a skeleton'} of the project as exported from the Spine "
                "editor")
    names = [p.relative_to(path.parent).as_posix() for p in skeletons[:3]]
    listed = f"({', '.join(names)}{f' and {len(skeletons) - 3} more' if len(skeletons) > 3 else ''})"
    if not folder_taken:
        return f"not a Spine skeleton (.json or .skel): give a skeleton of its folder {listed}"
    return f"not a Spine skeleton (.json or .skel): give the project's folder, {folder}, or a skeleton in it {listed}"


def project_atlases(project: Project) -> dict[Path, Atlas]:
    """Every usable atlas of the project, read once; the one policy for broken atlases.

    An atlas that cannot be read or parsed, or one of whose page images is missing or lies
    outside the project, is reported once in ``project.problems`` and left out, so that another
    atlas or an images folder can serve its skeletons and the rest of the project goes on.
    A region with malformed numbers leaves only the attachments that draw it failing.

    Returns
    -------
    dict
        Atlas path to parsed :class:`~spinemesh.atlas.Atlas`, in ``project.atlases`` order.
    """
    if project.parsed_atlases is not None:
        return project.parsed_atlases
    usable: dict[Path, Atlas] = {}
    for p in project.atlases:
        try:
            atlas = read_atlas(p, strict=False)
            for page in atlas.pages:
                page_file = AtlasImages.page_path(atlas, page.name, project.root)
                if not page_file.is_file():
                    raise SpineMeshError(page_not_found_said(page.name, p.parent), p, line=page.line)
        except SpineMeshError as e:
            project.broken_atlases[p] = str(e)
            project.problems.append(f"{e}; atlas not used")
            continue
        atlas.image_sizes = [image_size(AtlasImages.page_path(atlas, page.name, project.root)) for page in atlas.pages]
        atlas.mismatches = page_mismatches(atlas, atlas.image_sizes)
        project.warnings += [f"{p}: {m.message}" for m in atlas.mismatches if m.runtimes_disagree]
        for problem in atlas.problems:
            project.problems.append(f"{problem}; attachments drawing this region are left as they are")
        usable[p] = atlas
    project.parsed_atlases = usable
    return usable


def _atlas_rank(atlas: Atlas, skeleton: Path, covered: int) -> tuple:
    """Sort key: most images found, then scale 1, then straight alpha, then name likeness."""
    scale_one = all(p.scale == 1 for p in atlas.pages)
    straight = not any(p.pma for p in atlas.pages)
    stem = skeleton.name.split(".")[0]
    name = atlas.path.name.split(".")[0] if atlas.path else ""
    common = len(_common_prefix(stem, name))
    return (covered, scale_one, straight, common, -len(name))


def _common_prefix(a: str, b: str) -> str:
    n = 0
    while n < min(len(a), len(b)) and a[n] == b[n]:
        n += 1
    return a[:n]


def needed_images(doc: dict) -> set[str]:
    """Every image path the skeleton's attachments draw.

    An attachment whose sequence is malformed is passed over here; whoever processes that
    attachment reports it (it fails alone, not the skeleton).
    """
    needed: set[str] = set()
    for ref in iter_attachments(doc):
        try:
            needed.update(image_paths(ref))
        except SpineMeshError:
            continue
    return needed


def project_pages(project: Project) -> PageStore:
    """The project's one store of decoded atlas pages, shared by every skeleton's image source.

    Every :class:`~spinemesh.images.sources.AtlasImages` that :func:`image_source_for` makes for the
    project decodes through it, so a page that several skeletons, skins or sequences use is
    decoded once. Call ``project_pages(project).release()`` once the regions are cut.
    """
    if project.page_store is None:
        project.page_store = PageStore()
    return project.page_store


def image_source_for(doc: dict, skeleton: Path, project: Project, images: Path | None = None):
    """The image source that serves a skeleton best.

    Parameters
    ----------
    images : path, optional
        An images folder given by the user; it wins when set.

    Returns
    -------
    AtlasImages or FolderImages or None
        Atlases (read once per project by :func:`project_atlases`) are chosen greedily: the one that holds the most of the skeleton's images
        (preferring scale 1 and straight alpha, since meshes are best built at full
        resolution), then others for whatever is still missing. Without atlases, an images
        folder (``skeleton.images`` or an ``images/`` folder) inside the project is used.
    """
    if images is not None:
        return FolderImages(images)
    needed = needed_images(doc)
    candidates = list(project_atlases(project).values())
    chosen: list[Atlas] = []
    missing = set(needed)
    while missing and candidates:
        scored = [(_atlas_rank(a, skeleton, sum(1 for n in missing if a.find(n))), a) for a in candidates]
        scored.sort(key=lambda t: t[0], reverse=True)
        best_rank, best = scored[0]
        if best_rank[0] == 0:
            break
        chosen.append(best)
        candidates.remove(best)
        missing = {n for n in missing if not best.find(n)}
    if chosen:
        return AtlasImages(chosen, root=project.root, pages=project_pages(project))
    folder = images_folder_for(doc, skeleton, project)
    return FolderImages(folder) if folder is not None else None


def images_folder_for(doc: dict, skeleton: Path, project: Project) -> Path | None:
    """The images folder of a skeleton: its ``skeleton.images`` hint, else an ``images/`` folder.

    Only folders whose real path lies inside the project count. The hint is often an
    absolute path on the artist's machine, so one that cannot be used is passed over quietly,
    but one that climbs out of the project (``../``) is noted in ``project.problems``.
    """
    skel = doc.get("skeleton")
    hint = skel.get("images") if isinstance(skel, dict) else None
    folders = []
    if isinstance(hint, str) and hint.strip():
        rel_dir = real(skeleton.parent).relative_to(real(project.root)).as_posix()
        try:
            folders.append(resolve_inside(project.root, f"{rel_dir}/{hint}", skeleton))
        except UnsafePathError as e:
            if not os.path.isabs(hint.replace("\\", "/")) and not hint[1:2] == ":":
                project.problems.append(f"{e}; skeleton.images hint not used")
    folders += project.image_folders
    for folder in folders:
        if folder.is_dir() and is_within(folder, project.root):
            return folder
    return None


#: A file that marks a folder as one project even when its files lie in subfolders (where a
#: project came from: ``{"repo": ...}``).
SOURCE_FILE = ".source.json"

#: Skeleton names that are JSON text (the rest are binary).
_JSON_SUFFIXES = (".json", ".json.txt", ".spine-json")


def find_projects(folder: str | Path) -> list[Path]:
    """Project folders under ``folder``, sorted; hidden folders skipped.

    A project is the first folder, walking down, that directly holds a skeleton, an atlas
    or a :data:`SOURCE_FILE`; nothing below it is searched for further projects. Folders of
    which some hold only skeletons and the others only atlases (``spine/`` and ``art/``) are one
    project, the nearest folder above them all, where the skeletons draw from those atlases
    (:func:`_joined_halves`).
    """
    folder = existing(folder)
    if not folder.is_dir():  # a project's skeleton or atlas: its folder is what is read
        raise SpineMeshError(f"not a folder: give the folder that holds it, {shlex.quote(str(folder.parent))}", folder)
    out: list[Path] = []
    # walk_folder: symlinked folders are not entered (a link to outside, or ``ln -s . loop``)
    for here, subfolders, files in walk_folder(folder, hidden=True):  # SOURCE_FILE is hidden
        subfolders[:] = [p for p in subfolders if not p.name.startswith(".")]
        if any(p.name == SOURCE_FILE or _has_suffix(p, ATLAS_SUFFIXES) or is_skeleton_file(p) for p in files):
            out.append(here)
            subfolders[:] = []
    return _joined_halves(out, folder)


def _holds(folder: Path) -> tuple[bool, bool]:
    """Whether ``folder``, searched as :func:`find_project` searches it, holds a skeleton; an atlas."""
    files, _ = _walk(folder, [])
    return any(is_skeleton_file(p) for p in files), any(_has_suffix(p, ATLAS_SUFFIXES) for p in files)


def _drawn_shares(folders: list[Path]) -> list[float]:
    """For each readable skeleton in ``folders`` that draws images, the share of its images that
    are regions of the atlases in ``folders`` (searched as :func:`find_project` searches them)."""
    files = [p for folder in folders for p in _walk(folder, [])[0]]
    regions: set[str] = set()
    for p in files:
        if _has_suffix(p, ATLAS_SUFFIXES):
            try:
                regions.update(r.name for r in read_atlas(p, strict=False).regions)
            except (SpineMeshError, OSError):
                continue  # whoever reads the project says why
    shares = []
    for p in files:
        if is_skeleton_file(p):
            try:
                needed = needed_images(load_skeleton(p))
            except (SpineMeshError, OSError):
                continue
            if needed:
                shares.append(len(needed & regions) / len(needed))
    return shares


def _draw_from_each_other(halves: list[Path]) -> bool:
    """Whether the skeletons of ``halves`` draw from their atlases: each readable one finds at
    least half of its images among the atlases' regions.

    Folders of two games (one's atlases, the other's skeletons) were joined by their kinds alone,
    and ``pack`` then packed one game's regions by the other's meshes of the same name
    (``head``, ``torso``), cutting art its own skeletons draw.
    """
    shares = _drawn_shares(halves)
    return bool(shares) and min(shares) >= 0.5


def _joined_halves(found: list[Path], root: Path) -> list[Path]:
    """``found`` (:func:`find_projects` under ``root``) with the halves of one project joined: the
    folders under one folder of ``root`` (itself included) that each hold skeletons only or
    atlases only, both kinds there, and no folder under it holding both, are one project: that
    folder, the nearest such. A game keeps its atlases in ``art/`` (or ``art/characters/`` and
    ``art/ui/``) and its skeletons in ``spine/``: taken apart, the skeletons found no atlas and
    ``pack`` no skeleton drawing the atlases' regions (every region kept its rectangle). Halves
    beside a whole project stay projects of their own: which skeletons load which atlas is not
    known there; so do halves whose skeletons do not draw from their atlases
    (:func:`_draw_from_each_other`)."""
    under: dict[Path, list[Path]] = {}
    for folder in found:
        for above in folder.parents:
            if above != root and root not in above.parents:
                break
            under.setdefault(above, []).append(folder)
    kinds: dict[Path, tuple[bool, bool]] = {}
    joined = set(found)
    for above in sorted(under, key=lambda p: len(p.parts), reverse=True):  # the nearest first
        halves = under[above]
        seen = set()
        for folder in halves:
            if folder not in kinds:
                kinds[folder] = _holds(folder)
            seen.add(kinds[folder])
            if not (seen <= {(True, False), (False, True)}):
                break  # a whole project (or a folder of neither) under it: never joined, nor above
        if len(halves) > 1 and seen == {(True, False), (False, True)} and _draw_from_each_other(halves):
            joined = (joined - set(halves)) | {above}
            kinds.update((folder, (True, True)) for folder in halves)  # whole now, for the folders above
    return sorted(joined)


def _stem(path: Path) -> tuple[Path, str]:
    """``(folder, name without its skeleton suffix)``: what a ``.json`` and its ``.skel`` twin share."""
    name = path.name
    for suffix in sorted(SKELETON_SUFFIXES, key=len, reverse=True):
        if name.lower().endswith(suffix):
            return path.parent, name[: -len(suffix)]
    return path.parent, name


def skeletons_to_read(skeletons: list[Path]) -> list[Path]:
    """The skeletons without binary twins: a ``.skel`` beside a ``.json`` of the same name is left out.

    The editor exports both from one project state, so reading both finds the same
    attachments twice.
    """
    have_json = {_stem(p) for p in skeletons if p.name.lower().endswith(_JSON_SUFFIXES)}
    return [p for p in skeletons if p.name.lower().endswith(_JSON_SUFFIXES) or _stem(p) not in have_json]
