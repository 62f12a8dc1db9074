"""Finding the parts of a Spine project on disk and matching skeletons to their images.

A project as exported for game runtimes is a folder (often nested) holding skeletons
(``.json``, ``.skel``, Unity's ``.json.txt`` / ``.skel.bytes``), atlases (``.atlas``,
``.atlas.txt``) with their page images, or an ``images/`` folder as the editor uses.
No file says which atlas belongs to which skeleton, so :func:`image_source_for` picks the
atlases that hold the skeleton's images.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from .atlas import Atlas, read_atlas
from .errors import SpineMeshError
from .images import AtlasImages, FolderImages
from .skeleton import image_paths, iter_attachments

SKELETON_SUFFIXES = (".json", ".skel", ".json.txt", ".skel.bytes")
ATLAS_SUFFIXES = (".atlas", ".atlas.txt")


def _has_suffix(path: Path, suffixes) -> bool:
    return path.name.lower().endswith(suffixes)


def is_skeleton_file(path: Path) -> bool:
    """Whether ``path`` looks like a skeleton: binary by name, or JSON with skeleton keys."""
    name = path.name.lower()
    if not path.is_file() or not _has_suffix(path, SKELETON_SUFFIXES) or name.endswith(".source.json"):
        return False
    if name.endswith((".skel", ".skel.bytes")):
        return True
    with open(path, "rb") as f:
        head = f.read(4096)
    stripped = head.lstrip(b"\xef\xbb\xbf \t\r\n")
    if not stripped.startswith(b"{"):
        # Binary skeletons shipped under a .json name: version string in the header.
        return b"\x00" in head[:16] or b"4." in head[:40] or b"3." in head[:40]
    return b'"skeleton"' in head or b'"bones"' in head


@dataclass
class Project:
    """The skeletons, atlases and image folders found under ``root``."""

    root: Path
    skeletons: list[Path] = field(default_factory=list)
    atlases: list[Path] = field(default_factory=list)
    image_folders: list[Path] = field(default_factory=list)


def find_project(path: str | Path) -> Project:
    """Collect a project from a folder (searched recursively) or from one skeleton file.

    For a skeleton file, the project root is its folder and only that skeleton is taken.
    """
    path = Path(path)
    if not path.exists():
        raise SpineMeshError("no such file or folder", path)
    root = path.parent if path.is_file() else path
    files = sorted(p for p in root.rglob("*") if p.is_file() and not any(part.startswith(".") for part in p.relative_to(root).parts))
    project = Project(root=root)
    if path.is_file():
        if not is_skeleton_file(path):
            raise SpineMeshError("not a Spine skeleton (.json or .skel)", path)
        project.skeletons = [path]
    else:
        project.skeletons = [p for p in files if is_skeleton_file(p)]
    project.atlases = [p for p in files if _has_suffix(p, ATLAS_SUFFIXES)]
    project.image_folders = sorted({p.parent for p in files if p.parent.name == "images"} |
                                   {d for d in root.rglob("images") if d.is_dir()})
    return project


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
    """Every image path the skeleton's attachments draw."""
    return {p for ref in iter_attachments(doc) for p in image_paths(ref)}


def image_source_for(doc: dict, skeleton: Path, project: Project, images: Path | None = None,
                     atlases: dict[Path, Atlas] | None = None):
    """The image source that serves a skeleton best.

    Parameters
    ----------
    images : path, optional
        An images folder given by the user; it wins when set.
    atlases : dict, optional
        Already parsed atlases by path, reused across skeletons.

    Returns
    -------
    AtlasImages or FolderImages or None
        Atlases are chosen greedily: the one that holds the most of the skeleton's images
        (preferring scale 1 and straight alpha, since meshes are best built at full
        resolution), then others for whatever is still missing. Without atlases, an images
        folder (``skeleton.images`` or an ``images/`` folder) is used.
    """
    if images is not None:
        return FolderImages(images)
    needed = needed_images(doc)
    parsed = atlases if atlases is not None else {}
    for p in project.atlases:
        if p not in parsed:
            parsed[p] = read_atlas(p)
    candidates = list(parsed.values())
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
        return AtlasImages(chosen, root=project.root)
    folders = []
    hint = doc.get("skeleton", {}).get("images") if isinstance(doc.get("skeleton"), dict) else None
    if hint:
        folders.append((skeleton.parent / hint).resolve())
    folders += project.image_folders
    for folder in folders:
        if folder.is_dir() and str(folder).startswith(str(project.root.resolve())):
            return FolderImages(folder)
    return None
