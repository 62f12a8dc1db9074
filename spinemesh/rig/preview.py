"""Pictures of weighted meshes: the weights overlay and one bent pose.

Left panel: the sprite with its wireframe, each vertex a dot coloured by its bones (the
colours of its bones mixed by weight, as the editor's weights overlay shows them), the bone
segments drawn in their colours. Right panel: the textured mesh deformed by the runtime's
skinning (each vertex at ``sum(weight * M_bone @ local)``) after every chosen bone but the
one nearest the root turned by ``BEND`` degrees, so that one sees where the mesh folds.
"""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np

from ..errors import SpineMeshError
from ..fsutil import atomic_write_png
from ..skeleton import image_paths, iter_attachments
from ..written_folder import mark_written_folder
from .binding import parse_vertices, setup_world
from .bones import skeleton_bones

#: Turn of each bent bone in the right panel, degrees.
BEND = 25.0

#: Bone colours (RGB), repeated when a mesh has more bones.
PALETTE = np.array([(230, 25, 75), (60, 180, 75), (0, 130, 200), (245, 130, 48), (145, 30, 180),
                    (70, 240, 240), (240, 50, 230), (210, 245, 60), (0, 128, 128), (170, 110, 40)], float)


def bent_worlds(doc: dict, bone_ids: list[int], degrees: float = BEND) -> list[np.ndarray]:
    """World transforms after turning every listed bone but the first by ``degrees``."""
    bent = {"bones": copy.deepcopy(doc.get("bones", []))}
    for b in bone_ids[1:]:
        node = bent["bones"][b]
        node["rotation"] = float(node.get("rotation", 0)) + degrees
    return [b.world for b in skeleton_bones(bent)]


def skinned(mesh, worlds: list[np.ndarray]) -> np.ndarray:
    """Vertex world positions (N, 2) of a weighted mesh for the given bone transforms."""
    return setup_world(mesh, worlds, 0)


def checkerboard(height: int, width: int, cell: int = 8) -> np.ndarray:
    """A neutral light-grey checkerboard (RGB uint8, (height, width, 3)) to draw art on, as
    image editors show transparency: art of any colour stands out from one of its squares."""
    y, x = np.mgrid[:height, :width]
    light = ((y // cell + x // cell) % 2).astype(bool)
    out = np.full((height, width, 3), 204, np.uint8)
    out[light] = 236
    return out


def _fit(points: np.ndarray, size: int, pad: int = 16) -> tuple[float, np.ndarray]:
    lo, hi = points.min(axis=0), points.max(axis=0)
    scale = (size - 2 * pad) / max(float((hi - lo).max()), 1e-6)
    return scale, lo - pad / scale


def _warp_triangles(canvas: np.ndarray, sprite: np.ndarray, src: np.ndarray, dst: np.ndarray,
                    triangles: np.ndarray) -> None:
    """Draw the sprite's triangles ``src`` (pixels) at ``dst`` (canvas pixels), alpha-blended."""
    import cv2

    h, w = canvas.shape[:2]
    for t in triangles:
        s, d = src[t].astype(np.float32), dst[t].astype(np.float32)
        x0, y0 = np.floor(d.min(axis=0)).astype(int)
        x1, y1 = np.ceil(d.max(axis=0)).astype(int) + 1
        x0, y0, x1, y1 = max(x0, 0), max(y0, 0), min(x1, w), min(y1, h)
        if x1 <= x0 or y1 <= y0:
            continue
        m = cv2.getAffineTransform(s, (d - (x0, y0)).astype(np.float32))
        patch = cv2.warpAffine(sprite, m, (x1 - x0, y1 - y0), flags=cv2.INTER_LINEAR,
                               borderMode=cv2.BORDER_CONSTANT, borderValue=(0, 0, 0, 0))
        mask = np.zeros((y1 - y0, x1 - x0), np.uint8)
        cv2.fillConvexPoly(mask, np.round(d - (x0, y0)).astype(np.int32), 1)
        a = patch[..., 3:4].astype(float) / 255 * mask[..., None]
        region = canvas[y0:y1, x0:x1, :3].astype(float)
        canvas[y0:y1, x0:x1, :3] = (region * (1 - a) + patch[..., :3] * a).astype(np.uint8)


def picture(sprite: np.ndarray, uvs: np.ndarray, triangles: np.ndarray, mesh, weights_by_bone: np.ndarray,
            setup: np.ndarray, bent: np.ndarray, segments: np.ndarray, size: int = 384) -> np.ndarray:
    """The two panels side by side, RGB uint8 of shape (size, 2 * size, 3).

    Parameters
    ----------
    sprite : ndarray (H, W, 4)
        The attachment's image, RGBA.
    uvs : ndarray (N, 2)
        Vertex UVs (0..1 over the image).
    weights_by_bone : ndarray (N, B)
        Weights over the mesh's B bones (colour columns).
    setup, bent : ndarray (N, 2)
        World positions in the setup pose and in the bent pose.
    segments : ndarray (B, 2, 2)
        Bone segments in the setup pose, world units.
    """
    import cv2

    left = checkerboard(size, size)  # dark art and light art both show on it
    right = left.copy()
    h, w = sprite.shape[:2]
    both = np.concatenate([setup, bent, segments.reshape(-1, 2)])
    scale, origin = _fit(both, size)

    def to_canvas(p):
        q = (np.asarray(p, float) - origin) * scale
        return np.c_[q[:, 0], size - q[:, 1]]  # world y up, picture y down

    src = uvs * (w, h)
    for panel, where in ((left, setup), (right, bent)):
        _warp_triangles(panel, sprite, src, to_canvas(where), triangles)
    colours = weights_by_bone @ PALETTE[np.arange(weights_by_bone.shape[1]) % len(PALETTE)]
    for panel, where in ((left, setup), (right, bent)):
        pts = np.round(to_canvas(where)).astype(np.int32)
        for t in triangles:
            cv2.polylines(panel, [pts[t]], True, (90, 90, 90), 1, cv2.LINE_AA)
    pts = np.round(to_canvas(setup)).astype(np.int32)
    for i, seg in enumerate(segments):
        a, b = np.round(to_canvas(seg)).astype(np.int32)
        c = tuple(int(x) for x in PALETTE[i % len(PALETTE)])
        cv2.line(left, tuple(a), tuple(b), c, 3, cv2.LINE_AA)
        cv2.circle(left, tuple(a), 5, c, -1, cv2.LINE_AA)
    for p, c in zip(pts, colours):
        cv2.circle(left, tuple(p), 4, tuple(int(x) for x in c), -1, cv2.LINE_AA)
        cv2.circle(left, tuple(p), 4, (0, 0, 0), 1, cv2.LINE_AA)
    return np.concatenate([left, right], axis=1)


def setup_image(ref) -> str:
    """The image an attachment draws in the setup pose: its path, or its sequence's setup frame."""
    frames = image_paths(ref)
    sequence = ref.attachment.get("sequence")
    setup = sequence.get("setup", 0) if isinstance(sequence, dict) else 0
    return frames[setup if isinstance(setup, int) and 0 <= setup < len(frames) else 0]


def weighted_picture(doc: dict, att: dict, rig, sprite: np.ndarray) -> np.ndarray:
    """:func:`picture` of one weighted mesh attachment ``att`` of ``doc``: its vertices coloured
    by bone in the setup pose, its bones, and the mesh with its bones turned by :data:`BEND`.

    ``rig`` is :func:`.document.build_rig` of ``doc``; ``sprite`` the image it draws, RGBA.
    """
    mesh = parse_vertices(att, len(rig.bones))
    ids = mesh.bones()
    col = {b: i for i, b in enumerate(ids)}
    wb = np.zeros((mesh.count, len(ids)))
    for v, entry in enumerate(mesh.influences):
        for b, _, _, wt in entry:
            wb[v, col[b]] += wt
    setup = skinned(mesh, rig.worlds)
    bent = skinned(mesh, bent_worlds(doc, ids))
    uvs = np.asarray(att["uvs"], float).reshape(-1, 2)
    tris = np.asarray(att["triangles"], int).reshape(-1, 3)
    segs = np.stack([rig.bones[b].segment() for b in ids])
    return picture(sprite, uvs, tris, mesh, wb, setup, bent, segs)


def write_previews(doc: dict, skeleton: Path, project, rig, outcomes, folder: Path, on_picture=None) -> list[str]:
    """One PNG per weighted attachment in ``folder``; returns problems (one line each).
    ``on_picture()``: called after each weighted attachment, drawn or not."""
    from ..project import image_source_for

    problems = []
    done = {(o.skin, o.slot, o.name) for o in outcomes if o.status == "weighted"}
    if not done:
        return problems
    try:
        source = image_source_for(doc, skeleton, project)
    except SpineMeshError as e:
        return [f"{skeleton.name}: no previews: {e}"]
    if source is None:
        return [f"{skeleton.name}: no previews: no atlas or images folder holds its images"]
    mark_written_folder(folder)  # before its first picture: a later run writes into it again
    for ref in iter_attachments(doc):
        if (ref.skin, ref.slot, ref.name) not in done:
            continue
        try:
            sprite = source.get(setup_image(ref)).rgba
        except SpineMeshError as e:
            problems.append(f"{skeleton.name} {ref.slot}/{ref.name}: no preview: {e}")
        else:
            image = weighted_picture(doc, ref.attachment, rig, sprite)
            safe = "".join(c if c.isalnum() or c in "-_." else "_" for c in f"{skeleton.stem}-{ref.skin}-{ref.slot}-{ref.name}")
            atomic_write_png(folder / f"{safe}.png", image)
        if on_picture is not None:
            on_picture()
    return problems
