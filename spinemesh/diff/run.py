"""Walking a project: every artist mesh, re-meshed by our presets and the baselines, measured.

One :class:`DiffRow` per ``"type": "mesh"`` attachment. ``linkedmesh`` attachments are
skipped (counted in :attr:`DiffResult.skipped`): they reuse their parent's vertices and
triangles, so they would count the parent's mesh again. A sequence mesh is compared on its
first frame. When a folder holds a skeleton both as ``.json`` and ``.skel`` of the same name
(the examples do: the same state), only the ``.json`` is read, so no mesh counts twice.

Images: by default the editor's original images (an ``images/`` folder, or the skeleton's
``images`` path, holding every image the skeleton's meshes draw), since the artist meshed
those and every pixel length of the paper (sec. 3) refers to them; atlases are often packed
at scale 0.5. Otherwise, or with ``originals=False``, the atlas regions at atlas resolution.
UVs are relative to the image, so the artist's mesh fits either.

Meshes generated for an image are made once and reused for every attachment that draws it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from ..errors import SpineMeshError
from ..files.inputs import project_folder
from ..files.inside import real
from ..files.names import name_as_text
from ..images.sources import FolderImages
from ..mesher import Mesh, mesh_image
from ..metrics import mesh_metrics, significant_edges
from ..project import Project, find_project, image_source_for, skeletons_to_read
from ..skeleton import checked_attachments, image_paths, iter_attachments, load_skeleton
from .baselines import BASELINES, baseline_mesh
from .compare import artist_mesh, compare

#: Our presets first, then the paper's baselines in the order of its table.
PRESET_METHODS = ("default", "paper")
METHODS = PRESET_METHODS + BASELINES


@dataclass
class DiffRow:
    """One artist mesh attachment and every mesh it is compared with.

    Attributes
    ----------
    project, skeleton : str
        Project folder name and skeleton file name.
    skin, slot, attachment, image : str
        Where the attachment lives and the image path it draws.
    width, height : int
        Size of the image (px, original size).
    rgba : ndarray, shape (H, W, 4), uint8
        The image (kept for the HTML report; not written to JSON).
    source : str
        The file its pixels came from (an original image or an atlas page).
    meshes : dict
        ``"artist"`` and each method name -> :class:`Mesh` (absent when meshing failed).
    metrics : dict
        ``"artist"`` and each method name -> measures (see :func:`spinemesh.diff.compare.compare`),
        or ``{"error": message}``.
    """

    project: str
    skeleton: str
    skin: str
    slot: str
    attachment: str
    image: str
    width: int
    height: int
    rgba: np.ndarray = field(repr=False)
    source: str = ""
    meshes: dict = field(default_factory=dict, repr=False)
    metrics: dict = field(default_factory=dict)

    def to_json(self) -> dict:
        """The row as written to ``report.json`` (no pixels, no meshes)."""
        return {"project": self.project, "skeleton": self.skeleton, "skin": self.skin, "slot": self.slot,
                "attachment": self.attachment, "image": self.image, "width": self.width,
                "height": self.height, "source": self.source, "metrics": self.metrics}


@dataclass
class DiffResult:
    """All rows of a run, the methods compared, and what was skipped and why."""

    rows: list[DiffRow]
    methods: tuple[str, ...]
    skipped: list[dict]
    #: the project folders (or skeletons) given: the report names its files from their names
    #: (:func:`~spinemesh.files.names.named_within`), not by a path of this machine
    given: tuple[Path, ...] = ()


def make_mesh(rgba: np.ndarray, method: str) -> Mesh:
    """The mesh of one method (a preset of :data:`PRESET_METHODS` or a baseline)."""
    if method in PRESET_METHODS:
        return mesh_image(rgba, preset=method)
    return baseline_mesh(rgba, method)


def original_images(doc: dict, skeleton: Path, project: Project) -> FolderImages | None:
    """The editor's images folder when it holds every image the skeleton's meshes draw."""
    names = {image_paths(r)[0] for r in iter_attachments(doc) if r.type == "mesh" and image_paths(r)}
    hint = doc.get("skeleton", {}).get("images") if isinstance(doc.get("skeleton"), dict) else None
    folders = ([(skeleton.parent / hint).resolve()] if isinstance(hint, str) and hint else []) + project.image_folders
    root = project.root.resolve()
    for folder in folders:
        # a hint may point anywhere; only folders inside the project are read
        if folder.is_dir() and folder.resolve().is_relative_to(root):
            source = FolderImages(folder)
            if names and all(n in source for n in names):
                return source
    return None


def collect(paths: list[Path], images: Path | None = None, originals: bool = True) -> tuple[list[tuple], list[dict]]:
    """Every artist mesh of the projects, before any meshing.

    ``originals``: prefer the editor's images folder to the atlases (see the module docstring).

    Returns
    -------
    tasks : list of tuple
        ``(project name, skeleton path, AttachmentRef, image source, image path)``.
    skipped : list of dict
        ``{"project", "skeleton", "slot", "attachment", "reason"}``.
    """
    tasks, skipped = [], []
    seen: set[Path] = set()  # one project given twice (p p, p p/hero.json) is compared once
    for path in paths:
        project = find_project(path)
        for skel in skeletons_to_read(project.skeletons):
            if real(skel) in seen:
                continue
            seen.add(real(skel))
            doc = load_skeleton(skel)
            source = None
            for ref, problem in checked_attachments(doc):
                # names from the disk as text a report can hold (bytes not UTF-8 refused report.md)
                where = {"project": name_as_text(project.root.name), "skeleton": name_as_text(skel.name),
                         "slot": ref.slot, "attachment": ref.name}
                if problem:  # a mesh of broken numbers (a vertex of 1e308, uvs cut short) is said, not lost
                    if ref.attachment.get("type") in ("mesh", "linkedmesh"):
                        skipped.append({**where, "reason": problem})
                    continue
                if ref.type == "linkedmesh":
                    skipped.append({**where, "reason": "linkedmesh (reuses its parent's mesh)"})
                    continue
                if ref.type != "mesh":
                    continue
                if source is None and images is None and originals:
                    source = original_images(doc, skel, project)
                if source is None:
                    source = image_source_for(doc, skel, project, images)
                if source is None:
                    skipped.append({**where, "reason": "no atlas or images folder holds its image"})
                    continue
                names = image_paths(ref)
                if not names:
                    skipped.append({**where, "reason": "draws no image"})
                    continue
                tasks.append((where["project"], skel, ref, source, names[0]))
    return tasks, skipped


def run_diff(paths: list[str | Path], methods: tuple[str, ...] = METHODS, images: str | Path | None = None,
             limit: int | None = None, originals: bool = True,
             progress: Callable[[int, int, str], None] | None = None) -> DiffResult:
    """Compare every artist mesh of the projects with the generated ones.

    Parameters
    ----------
    paths : list of path
        Project folders (or skeleton files); each is its own project for image lookup.
    methods : tuple of str
        Subset of :data:`METHODS`.
    images : path, optional
        An images folder to take the images from instead of the atlases.
    limit : int, optional
        Stop after this many attachments (quick looks at big projects).
    originals : bool
        Prefer the editor's original images to the atlas regions (True).
    progress : callable, optional
        ``progress(done, total, label)`` after each attachment.

    Raises
    ------
    SpineMeshError
        For a missing project or an unreadable skeleton or atlas.
    """
    unknown = [m for m in methods if m not in METHODS]
    if unknown:
        raise ValueError(f"unknown method(s) {', '.join(unknown)}; choose from {', '.join(METHODS)}")
    tasks, skipped = collect([Path(p) for p in paths], Path(images) if images else None, originals)
    if limit is not None:
        tasks = tasks[:limit]
    cache: dict = {}  # (id(source), image) -> (file, rgba, edge pixels, {method: (mesh, metrics)})
    rows = []
    for done, (project, skel, ref, source, name) in enumerate(tasks, 1):
        where = {"project": project, "skeleton": name_as_text(skel.name), "slot": ref.slot, "attachment": ref.name}
        try:
            key = (id(source), name)
            if key not in cache:
                region = source.get(name)
                cache[key] = (region.source,) + _generate(region.rgba, methods)
            pixels, rgba, edges, generated = cache[key]
            h, w = rgba.shape[:2]
            artist = artist_mesh(ref.attachment, w, h)
        except (SpineMeshError, ValueError) as e:
            skipped.append({**where, "reason": name_as_text(str(e))})  # it may name a file
            if progress:
                progress(done, len(tasks), f"{project}/{ref.name}")
            continue
        row = DiffRow(project, where["skeleton"], ref.skin, ref.slot, ref.name, name, w, h, rgba,
                      name_as_text(str(pixels)))
        row.meshes["artist"] = artist
        row.metrics["artist"] = mesh_metrics(artist, rgba, edge_pixels=edges)
        for m in methods:
            mesh, own = generated[m]
            if mesh is None:
                row.metrics[m] = own
                continue
            row.meshes[m] = mesh
            row.metrics[m] = compare(artist, mesh, rgba, own=own)
        rows.append(row)
        if progress:
            progress(done, len(tasks), f"{project}/{ref.name}")
    return DiffResult(rows, tuple(methods), skipped, tuple(project_folder(p).absolute() for p in paths))


def _generate(rgba: np.ndarray, methods: tuple[str, ...]):
    """Meshes and own measures of every method for one image (``(None, {"error"})`` on failure)."""
    edges = significant_edges(rgba)
    out = {}
    for m in methods:
        try:
            mesh = make_mesh(rgba, m)
        except SpineMeshError as e:
            out[m] = (None, {"error": e.message})
            continue
        if len(mesh.triangles) == 0:
            # the paper preset returns an empty mesh for some thin sprites instead of raising
            out[m] = (None, {"error": "empty mesh (no triangle)"})
            continue
        out[m] = (mesh, mesh_metrics(mesh, rgba, edge_pixels=edges))
    return rgba, edges, out
