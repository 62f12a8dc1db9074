"""Upgrading whole projects: every region attachment becomes a mesh attachment.

The work is split in three so that each part can be read on its own:

1. :func:`plan_skeleton` walks a skeleton and decides, per region attachment, which image(s)
   it needs or why it is skipped;
2. :func:`mesh_jobs` meshes each unique image once (a process pool with ``jobs > 1``);
3. :func:`upgrade_project` writes skeletons in the format and version they came in, copies
   everything else, and reports.

One bad attachment never aborts a project: it stays a region and the report says why.
"""

from __future__ import annotations

import fnmatch
import hashlib
import os
import shutil
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from ..errors import SpineMeshError
from ..fsutil import atomic_write_bytes, atomic_write_json, atomic_write_png, atomic_write_text
from ..project import find_project, image_source_for
from ..skeleton import (
    dumps_skeleton, image_paths, is_binary_skeleton, iter_skins, load_skeleton, AttachmentRef,
)
from .geometry import mesh_attachment, spine_triangles

#: Exit status of a run in which some attachments could not be upgraded.
EXIT_PARTIAL = 3


@dataclass
class Options:
    """What the user asked for (see ``spinemesh upgrade --help``)."""

    preset: str = "default"
    mask: str = "alpha"
    only: list[str] = field(default_factory=list)
    exclude: list[str] = field(default_factory=list)
    min_size: float = 0.0
    dry_run: bool = False
    jobs: int = 1
    images_out: Path | None = None
    images_in: Path | None = None
    overrides: dict = field(default_factory=dict)


@dataclass
class Target:
    """One region attachment and what became of it."""

    skeleton: str
    skin: str
    slot: str
    name: str
    paths: list[str]
    status: str = "pending"          # meshed | skipped | failed | planned
    reason: str = ""
    key: str = ""                    # content key of its (composited) image
    vertices: int = 0
    triangles: int = 0
    coverage: float | None = None
    waste: float | None = None
    seconds: float = 0.0

    def row(self) -> dict:
        return {k: v for k, v in self.__dict__.items() if k != "key"}


def _matches(patterns: list[str], ref: AttachmentRef, paths: list[str]) -> bool:
    names = [ref.slot, ref.name, *paths]
    return any(fnmatch.fnmatchcase(n, p) for p in patterns for n in names)


def composite_image(images: list[np.ndarray]) -> np.ndarray:
    """One image whose alpha covers every frame of a sequence (max over frames).

    Colours come from the first frame, which is what interior boundaries are found on.
    """
    out = images[0].copy()
    for im in images[1:]:
        out[..., 3] = np.maximum(out[..., 3], im[..., 3])
    return out


def stored_box(boxes: list[tuple[int, int, int, int]]) -> tuple[int, int, int, int] | None:
    """The part of the original image that every frame stores on the atlas page (intersection)."""
    x0, y0 = max(b[0] for b in boxes), max(b[1] for b in boxes)
    x1, y1 = min(b[2] for b in boxes), min(b[3] for b in boxes)
    return (x0, y0, x1, y1) if x1 > x0 and y1 > y0 else None


def _inside(visible: np.ndarray, box: tuple[int, int, int, int]) -> bool:
    x0, y0, x1, y1 = box
    return int(visible.sum()) == int(visible[y0:y1, x0:x1].sum())


def image_key(rgba: np.ndarray) -> str:
    return hashlib.sha1(rgba.tobytes() + str(rgba.shape).encode()).hexdigest()


def plan_skeleton(doc: dict, skeleton: str, source, options: Options,
                  images: dict[str, tuple]) -> list[Target]:
    """Decide for every region attachment of ``doc`` what to do; load the images it needs.

    ``images`` collects each unique composited image, with the box the atlas stores of it,
    by content key.
    """
    targets = []
    for skin, slots in iter_skins(doc):
        for slot, attachments in slots.items():
            if not isinstance(attachments, dict):
                continue
            for name, att in attachments.items():
                if not isinstance(att, dict) or att.get("type", "region") != "region":
                    continue
                ref = AttachmentRef(skin, slot, name, att)
                paths = image_paths(ref)
                t = Target(skeleton, skin, slot, name, paths)
                targets.append(t)
                if options.only and not _matches(options.only, ref, paths):
                    t.status, t.reason = "skipped", "not matched by --only"
                    continue
                if options.exclude and _matches(options.exclude, ref, paths):
                    t.status, t.reason = "skipped", "matched by --exclude"
                    continue
                try:
                    w, h = float(att.get("width", 32)), float(att.get("height", 32))
                except (TypeError, ValueError):
                    t.status, t.reason = "failed", "width/height are not numbers"
                    continue
                if max(w, h) < options.min_size:
                    t.status, t.reason = "skipped", f"smaller than --min-size {options.min_size:g}"
                    continue
                if source is None:
                    t.status, t.reason = "failed", "no atlas or images folder holds its image"
                    continue
                try:
                    loaded = [source.get(p) for p in paths]
                except SpineMeshError as e:
                    t.status, t.reason = "failed", str(e)
                    continue
                if len({f.rgba.shape for f in loaded}) > 1:
                    t.status, t.reason = "failed", "sequence frames differ in size"
                    continue
                rgba = composite_image([f.rgba for f in loaded])
                if not (rgba[..., 3] > 0).any() and options.mask == "alpha":
                    t.status, t.reason = "skipped", "image is fully transparent"
                    continue
                box = stored_box([f.content for f in loaded])
                if box is None or not _inside(rgba[..., 3] > 0, box):
                    t.status, t.reason = ("skipped", "sequence frames were trimmed differently on the atlas page, "
                                          "so one mesh would sample neighbouring regions; re-pack keeping whitespace")
                    continue
                t.key = image_key(rgba) + "-%d-%d-%d-%d" % box
                images.setdefault(t.key, (rgba, box))
                t.status = "planned"
    return targets


def sampling_margin(mask: np.ndarray) -> np.ndarray:
    """Grow the art mask by one texel on every side.

    Runtimes sample textures bilinearly: a screen pixel whose sample point falls within half
    a texel of a visible texel takes some of its colour. A mesh that covers only the visible
    texels cuts those pixels off at its edge; covering one more texel keeps them.
    """
    import cv2

    return cv2.dilate(mask.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)


def _mesh_one(args):
    """Worker: mesh one image; returns (key, mesh json or None, error, seconds, coverage, waste)."""
    key, (full, box), preset, mask_source, overrides = args
    # Meshing the stored part only keeps every vertex where the atlas has this image's texels.
    x0, y0, x1, y1 = box
    rgba = np.ascontiguousarray(full[y0:y1, x0:x1])
    from ..mesher import compute_mask, mesh_image, resolve_params
    from ..metrics import coverage, opaque_mask, waste

    start = time.perf_counter()
    try:
        params = resolve_params(preset, **{**overrides, "mask_source": mask_source})
        mask = sampling_margin(compute_mask(rgba, params.mask_source, params.alpha_threshold))
        mesh = mesh_image(rgba, params, mask=mask)
    except SpineMeshError as e:
        return key, None, str(e), time.perf_counter() - start, None, None
    seconds = time.perf_counter() - start
    art = opaque_mask(rgba)
    cov = coverage(mesh.vertices, mesh.triangles, art) if art.any() else 1.0
    wst = waste(mesh.vertices, mesh.triangles, art)
    doc = mesh.to_json()
    doc["vertices"] = (np.asarray(doc["vertices"], float) + (x0, y0)).tolist()
    return key, doc, "", seconds, cov, wst


def mesh_jobs(images: dict[str, tuple], options: Options,
              progress: Callable[[int], None] | None = None, cache: dict | None = None) -> dict[str, tuple]:
    """Mesh every unique image once; ``progress(1)`` is called after each.

    ``cache``, if given, keeps results across calls (keyed by image and mesher settings), so
    that runs over projects sharing images (the same art exported for several Spine
    versions) mesh each image only once.
    """
    settings = (options.preset, options.mask, tuple(sorted(options.overrides.items())))
    results = {}
    if cache is not None:
        results = {k: cache[(k, settings)] for k in images if (k, settings) in cache}
        if progress and results:
            progress(len(results))
    work = [(k, im, options.preset, options.mask, options.overrides)
            for k, im in sorted(images.items()) if k not in results]
    if options.jobs > 1 and len(work) > 1:
        with ProcessPoolExecutor(max_workers=options.jobs) as pool:
            for res in pool.map(_mesh_one, work, chunksize=1):
                results[res[0]] = res[1:]
                if progress:
                    progress(1)
    else:
        for item in work:
            res = _mesh_one(item)
            results[res[0]] = res[1:]
            if progress:
                progress(1)
    if cache is not None:
        cache.update({(k, settings): v for k, v in results.items()})
    return results


def apply_meshes(doc: dict, targets: list[Target], meshes: dict[str, tuple],
                 images: dict[str, tuple], source_name: str) -> None:
    """Replace each meshed region in ``doc`` by its mesh attachment, in place, keeping key order."""
    by_place = {(t.skin, t.slot, t.name): t for t in targets if t.status == "planned"}
    for skin, slots in iter_skins(doc):
        for slot, attachments in slots.items():
            if not isinstance(attachments, dict):
                continue
            for name in list(attachments):
                t = by_place.get((skin, slot, name))
                if t is None:
                    continue
                mesh_json, error, seconds, cov, wst = meshes[t.key]
                t.seconds = round(seconds, 4)
                if mesh_json is None:
                    t.status, t.reason = "failed", error
                    continue
                h, w = images[t.key][0].shape[:2]
                verts = np.asarray(mesh_json["vertices"], float)
                edges = np.asarray(mesh_json["edges"], int).reshape(-1, 2)
                tris = spine_triangles(verts, mesh_json["hull"], edges)
                if tris is None:
                    t.status, t.reason = "failed", "mesh is not one fully triangulated hull polygon"
                    continue
                try:
                    attachments[name] = mesh_attachment(
                        attachments[name], verts, tris, mesh_json["hull"], edges, w, h, source_name)
                except SpineMeshError as e:
                    t.status, t.reason = "failed", str(e)
                    continue
                t.status = "meshed"
                t.vertices = len(mesh_json["vertices"])
                t.triangles = len(tris)
                t.coverage = None if cov is None else round(cov, 6)
                t.waste = None if wst is None else round(wst, 6)


def check_output_folder(project_root: Path, out: Path) -> None:
    """Refuse an output folder that is the project folder or inside it."""
    root, dest = project_root.resolve(), out.resolve()
    if dest == root or root in dest.parents:
        raise SpineMeshError(f"output folder {out} must not be the project folder or inside it", out)


def _copy_atomic(src: Path, dst: Path) -> None:
    dst.parent.mkdir(parents=True, exist_ok=True)
    tmp = dst.with_name(f".{dst.name}.tmp")
    shutil.copyfile(src, tmp)
    os.replace(tmp, dst)


def write_editor_images(targets: list[Target], source, folder: Path) -> None:
    """Write the original-size images (``<folder>/<path>.png``) the editor re-imports.

    Atlas images exported at a scale other than 1 are resized back to skeleton size.
    """
    import cv2

    done = set()
    for t in targets:
        if t.status != "meshed":
            continue
        for p in t.paths:
            if p in done:
                continue
            done.add(p)
            img = source.get(p)
            rgba = img.rgba
            if img.scale != 1:
                h, w = rgba.shape[:2]
                size = (max(1, round(w / img.scale)), max(1, round(h / img.scale)))
                rgba = cv2.resize(rgba, size, interpolation=cv2.INTER_CUBIC)
            from ..fsutil import resolve_inside

            atomic_write_png(resolve_inside(folder, p + ".png"), rgba)


@dataclass
class Result:
    """What a run did: every target, the skeletons written and the problems met."""

    targets: list[Target] = field(default_factory=list)
    written: list[str] = field(default_factory=list)
    errors: list[str] = field(default_factory=list)
    seconds: dict = field(default_factory=lambda: {"read": 0.0, "mesh": 0.0, "write": 0.0})

    @property
    def partial(self) -> bool:
        return bool(self.errors) or any(t.status == "failed" for t in self.targets)

    def counts(self) -> dict:
        out: dict[str, int] = {}
        for t in self.targets:
            out[t.status] = out.get(t.status, 0) + 1
        return out


def upgrade_project(project: str | Path, out: str | Path, options: Options | None = None,
                    on_start: Callable[[int], None] | None = None,
                    on_progress: Callable[[int], None] | None = None,
                    mesh_cache: dict | None = None) -> Result:
    """Upgrade every skeleton of a project into ``out``.

    Parameters
    ----------
    project : path
        A project folder or one skeleton file.
    out : path
        Output folder; refused if it is the project folder or inside it.
    options : Options
    on_start, on_progress : callable, optional
        Told the number of unique images to mesh, then called once per image meshed.
    mesh_cache : dict, optional
        Meshes kept across calls (see :func:`mesh_jobs`); None meshes afresh.

    Returns
    -------
    Result
        Every region attachment with its status, for the report; ``partial`` is true when
        any attachment or skeleton failed.
    """
    options = options or Options()
    out = Path(out)
    proj = find_project(project)
    check_output_folder(proj.root, out)
    result = Result()
    atlases: dict = {}
    plans = []
    images: dict[str, tuple] = {}

    t0 = time.perf_counter()
    for path in proj.skeletons:
        rel = path.relative_to(proj.root).as_posix()
        try:
            doc = load_skeleton(path)
            source = image_source_for(doc, path, proj, images=options.images_in, atlases=atlases)
        except SpineMeshError as e:
            result.errors.append(str(e))
            continue
        targets = plan_skeleton(doc, rel, source, options, images)
        result.targets += targets
        plans.append((path, rel, doc, targets, source))
    result.seconds["read"] = time.perf_counter() - t0

    if options.dry_run:
        for t in result.targets:
            if t.status == "planned":
                t.status = "would mesh"
        return result

    t0 = time.perf_counter()
    if on_start:
        on_start(len(images))
    meshes = mesh_jobs(images, options, on_progress, mesh_cache)
    result.seconds["mesh"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    written = set()
    for path, rel, doc, targets, source in plans:
        apply_meshes(doc, targets, meshes, images, str(path))
        dest = out / rel
        try:
            if is_binary_skeleton(path):
                from ..skeleton_binary import write_skel

                atomic_write_bytes(dest, write_skel(doc, dest))
            else:
                atomic_write_text(dest, dumps_skeleton(doc))
        except SpineMeshError as e:
            result.errors.append(f"{rel}: not written: {e}")
            continue
        written.add(path.resolve())
        result.written.append(rel)
        if options.images_out is not None and source is not None:
            write_editor_images(targets, source, Path(options.images_out))
    out_resolved = out.resolve()
    for f in sorted(proj.root.rglob("*")):
        if not f.is_file() or f.resolve() in written or any(p.startswith(".") for p in f.relative_to(proj.root).parts):
            continue
        if out_resolved in f.resolve().parents:
            continue
        if f in proj.skeletons:
            continue  # a skeleton that could not be upgraded is not copied as if it had been
        _copy_atomic(f, out / f.relative_to(proj.root))
    result.seconds["write"] = time.perf_counter() - t0
    return result


def write_report(result: Result, path: str | Path) -> None:
    """``report.json``: one row per region attachment, plus totals and timings."""
    atomic_write_json(path, {
        "counts": result.counts(),
        "skeletons_written": result.written,
        "errors": result.errors,
        "seconds": {k: round(v, 3) for k, v in result.seconds.items()},
        "attachments": [t.row() for t in result.targets],
    })
