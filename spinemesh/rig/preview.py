"""Pictures of weighted meshes: the weights overlay and one bent pose, with a legend.

Left panel: the sprite with its wireframe, each vertex a dot coloured by its bones (the
colours of its bones mixed by weight, as the editor's weights overlay shows them), the bone
segments drawn in their colours, each numbered at its root. Right panel: the textured mesh
deformed by the runtime's skinning (each vertex at ``sum(weight * M_bone @ local)``) after
every chosen bone but the one nearest the root turned by ``BEND`` degrees, so that one sees
where the mesh folds. Under them, the legend: each bone of the mesh, its number, its colour and
its name (:func:`legend`). OpenCV's font draws printable ASCII only, and a long name or many
bones do not fit a strip: :func:`write_previews` writes a caption beside each picture
(:func:`caption`, JSON) that names every bone in full with its number and colour.
"""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np

from ..errors import SpineMeshError
from ..files.atomic import atomic_write_json, atomic_write_png
from ..files.names import name_apart, safe_name
from ..skeleton import image_paths, iter_attachments
from ..written_folder import mark_written_folder
from .binding import parse_vertices, setup_world
from .bones import skeleton_bones

#: Turn of each bent bone in the right panel, degrees.
BEND = 25.0

#: The first bones' colours (RGB): twenty colours told apart at a glance (Sasha Trubetskoy's
#: list), the ten strongest first; the bones past them get :func:`bone_colour`'s own.
PALETTE = np.array([(230, 25, 75), (60, 180, 75), (0, 130, 200), (245, 130, 48), (145, 30, 180),
                    (70, 240, 240), (240, 50, 230), (210, 245, 60), (0, 128, 128), (170, 110, 40),
                    (255, 225, 25), (0, 0, 128), (128, 0, 0), (128, 128, 0), (128, 128, 128),
                    (250, 190, 190), (230, 190, 255), (170, 255, 195), (255, 215, 180), (255, 250, 200)], float)

#: Past :data:`PALETTE`: (saturation, value) taken in turn, each at the next hue.
_SHADES = ((1.0, 0.75), (0.45, 0.9), (0.8, 0.45))


#: The legend under the panels (:func:`legend`): bones per row, texels a row, rows at most (more
#: bones: the last entry says how many more, named in the caption).
LEGEND_COLUMNS = 3
LEGEND_ROW = 18
LEGEND_ROWS = 8


def bone_colour(index: int) -> tuple[int, int, int]:
    """The colour (RGB) of a mesh's ``index``-th bone (0-based, in :meth:`.binding.MeshVertices.bones` order).

    :data:`PALETTE`'s first, then hues a golden-ratio turn apart at three shades in turn: no two
    bones of a mesh share a colour (they repeated past the tenth), and the legend's numbers still
    tell close ones apart.

    Examples
    --------
    >>> bone_colour(0), bone_colour(20), len({bone_colour(i) for i in range(256)})
    ((230, 25, 75), (191, 0, 57), 256)
    """
    if index < len(PALETTE):
        return tuple(int(c) for c in PALETTE[index])
    import colorsys

    k = index - len(PALETTE)
    saturation, value = _SHADES[k % len(_SHADES)]
    rgb = colorsys.hsv_to_rgb((0.95 + k * 0.6180339887498949) % 1.0, saturation, value)
    return tuple(round(255 * c) for c in rgb)


def bone_palette(count: int) -> np.ndarray:
    """The colours of bones ``0`` to ``count - 1`` (:func:`bone_colour`), float RGB of shape (count, 3)."""
    return np.array([bone_colour(i) for i in range(count)], float).reshape(-1, 3)


def drawable(name: str) -> bool:
    """Whether OpenCV's Hershey font draws ``name``: printable ASCII only (it draws ``?`` for the rest)."""
    return name.isascii() and name.isprintable()


def _fitted(text: str, width: int, scale: float) -> str:
    """``text`` cut with ``...`` to fit ``width`` texels in the legend's font."""
    import cv2

    def wide(t: str) -> int:
        return cv2.getTextSize(t, cv2.FONT_HERSHEY_SIMPLEX, scale, 1)[0][0]

    if wide(text) <= width:
        return text
    while text and wide(text + "...") > width:
        text = text[:-1]
    return text + "..."


def legend(names: list[str], width: int) -> np.ndarray:
    """The legend strip: RGB uint8 of shape (rows * :data:`LEGEND_ROW` + 8, ``width``, 3).

    Each bone of ``names`` (a mesh's bones, in :meth:`.binding.MeshVertices.bones` order) gets a swatch of its
    colour (:func:`bone_colour`, one per bone), its number (1-based, as drawn at the bone's root) and its name, cut to its column;
    a name the font cannot draw (:func:`drawable`) reads ``(name in the caption)``. At most
    :data:`LEGEND_COLUMNS` x :data:`LEGEND_ROWS` entries; past them the last says how many more.
    """
    import cv2

    room = LEGEND_COLUMNS * LEGEND_ROWS
    entries = list(enumerate(names))
    more = 0
    if len(entries) > room:
        more = len(entries) - (room - 1)
        entries = entries[:room - 1]
    rows = max(1, -(-(len(entries) + (1 if more else 0)) // LEGEND_COLUMNS))
    strip = np.full((rows * LEGEND_ROW + 8, width, 3), 255, np.uint8)
    column = width // LEGEND_COLUMNS
    scale = 0.4
    for k, (i, name) in enumerate(entries):
        x, y = (k % LEGEND_COLUMNS) * column + 6, (k // LEGEND_COLUMNS) * LEGEND_ROW + 4
        cv2.rectangle(strip, (x, y + 2), (x + 12, y + 14), bone_colour(i), -1)
        cv2.rectangle(strip, (x, y + 2), (x + 12, y + 14), (0, 0, 0), 1)
        words = f"{i + 1} {name if drawable(name) else '(name in the caption)'}"
        cv2.putText(strip, _fitted(words, column - 26, scale), (x + 18, y + 13), cv2.FONT_HERSHEY_SIMPLEX,
                    scale, (0, 0, 0), 1, cv2.LINE_AA)
    if more:
        k = len(entries)
        x, y = (k % LEGEND_COLUMNS) * column + 6, (k // LEGEND_COLUMNS) * LEGEND_ROW + 4
        cv2.putText(strip, _fitted(f"+{more} more bones (in the caption)", column - 8, scale), (x, y + 13),
                    cv2.FONT_HERSHEY_SIMPLEX, scale, (0, 0, 0), 1, cv2.LINE_AA)
    return strip


def caption(names: list[str], skin: str, slot: str, attachment: str, picture: str) -> dict:
    """The caption written beside a weights picture (JSON): which mesh it shows and, for each of
    its bones in the legend's order, its number, full name and colour (``#rrggbb``)."""
    return {"picture": picture, "skin": skin, "slot": slot, "attachment": attachment,
            "bones": [{"number": i + 1, "name": n, "colour": "#{:02x}{:02x}{:02x}".format(*bone_colour(i))}
                      for i, n in enumerate(names)]}


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
    colours = weights_by_bone @ bone_palette(weights_by_bone.shape[1])
    for panel, where in ((left, setup), (right, bent)):
        pts = np.round(to_canvas(where)).astype(np.int32)
        for t in triangles:
            cv2.polylines(panel, [pts[t]], True, (90, 90, 90), 1, cv2.LINE_AA)
    pts = np.round(to_canvas(setup)).astype(np.int32)
    for i, seg in enumerate(segments):
        a, b = np.round(to_canvas(seg)).astype(np.int32)
        c = bone_colour(i)
        cv2.line(left, tuple(a), tuple(b), c, 3, cv2.LINE_AA)
        cv2.circle(left, tuple(a), 5, c, -1, cv2.LINE_AA)
        # its number in the legend, beside its root
        cv2.putText(left, str(i + 1), (int(a[0]) + 6, int(a[1]) - 6), cv2.FONT_HERSHEY_SIMPLEX, 0.4,
                    (0, 0, 0), 1, cv2.LINE_AA)
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


def mesh_bone_names(mesh, rig) -> list[str]:
    """The names of the bones a weighted mesh uses (``mesh``: its :func:`.binding.parse_vertices`),
    in the legend's order (:meth:`.binding.MeshVertices.bones`)."""
    return [rig.bones[b].name for b in mesh.bones()]


def weighted_picture(doc: dict, att: dict, rig, sprite: np.ndarray, mesh=None) -> np.ndarray:
    """:func:`picture` of one weighted mesh attachment ``att`` of ``doc``: its vertices coloured
    by bone in the setup pose, its bones, and the mesh with its bones turned by :data:`BEND`,
    with its :func:`legend` under them.

    ``rig`` is :func:`.document.build_rig` of ``doc``; ``sprite`` the image it draws, RGBA;
    ``mesh`` its vertices as :func:`.binding.parse_vertices` reads them, when read already.
    """
    mesh = parse_vertices(att, len(rig.bones)) if mesh is None else mesh
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
    panels = picture(sprite, uvs, tris, mesh, wb, setup, bent, segs)
    return np.concatenate([panels, legend(mesh_bone_names(mesh, rig), panels.shape[1])])


def write_previews(doc: dict, skeleton: Path, project, rig, outcomes, folder: Path, on_picture=None,
                   taken: set[str] | None = None) -> list[str]:
    """One PNG per weighted attachment in ``folder``, and beside it its :func:`caption` (the same
    name, ``.json``); returns problems (one line each). ``on_picture()``: called after each
    weighted attachment, drawn or not. ``taken``: the names of the pictures written into
    ``folder`` so far (:func:`~spinemesh.files.names.name_apart`), shared by the skeletons of a run."""
    taken = set() if taken is None else taken
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
            mesh = parse_vertices(ref.attachment, len(rig.bones))  # once, for the picture and its caption
            image = weighted_picture(doc, ref.attachment, rig, sprite, mesh)
            # two attachments (or skeletons) of names made one here, or one on a macOS or Windows disk: apart
            safe = name_apart(safe_name(f"{skeleton.stem}-{ref.skin}-{ref.slot}-{ref.name}", 160), taken)
            atomic_write_png(folder / f"{safe}.png", image)
            atomic_write_json(folder / f"{safe}.json", caption(mesh_bone_names(mesh, rig), ref.skin,
                                                                ref.slot, ref.name, f"{safe}.png"))
        if on_picture is not None:
            on_picture()
    return problems
