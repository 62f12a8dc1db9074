"""What the player draws: attachments in world space, frame by frame, packed small.

A pose is the list of attachments a skeleton draws, in draw order (:class:`Drawn`): each one's
vertices in world units, with the texture coordinates and triangles it is drawn with. A side
of the player (the original skeleton, or the upgraded one) keeps a table of the attachments
its poses draw (:class:`SideTable`: image, UVs, triangles, colours by bone, written once in the
page's model script); an animation is stored as, per frame, which attachments are drawn with
which alpha and blend mode, and every vertex position quantised to 16 bits over the
animation's bounds (:func:`encode_animation`), base64 in a ``.js`` file the page loads when
that animation is chosen. Quantisation error is the bounds' larger side / 65,535 (0.015 world
units for a 1,000-unit skeleton), below a pixel at any size the page shows.
"""

from __future__ import annotations

import base64
from dataclasses import dataclass, field

import numpy as np

from ..attachment_geometry import region_quad_transform
from ..skeleton import AttachmentRef, image_paths, iter_skins

#: Bone colours (RGB) of the "vertices coloured by bone" view, one per bone, repeated.
from ..rig.preview import PALETTE

#: Blend modes by the number the player uses (the runtimes' names; 3.x "additive" too).
BLENDS = {"normal": 0, "additive": 1, "multiply": 2, "screen": 3}

#: Animations longer than this are sampled more sparsely so that each keeps at most
#: :data:`MAX_FRAMES` frames, and each animation script holds at most :data:`MAX_VALUES`
#: vertex coordinates (2 bytes each before base64): a stated budget per animation.
FPS = 30
MAX_FRAMES = 300
MAX_VALUES = 1_500_000


@dataclass
class Drawn:
    """One attachment as a pose draws it.

    Attributes
    ----------
    key : (skin, slot, attachment name)
    attachment : dict
        The region or mesh attachment.
    image : str or None
        The image path it draws (a sequence: its setup frame).
    world : ndarray, shape (N, 2)
        Vertex positions in world units (y up); a region's 4 corners of the part its atlas
        stores, in UV order (0,0) (1,0) (1,1) (0,1) of that part.
    alpha : float
        0..1, the slot's and the attachment's alpha multiplied.
    blend : str
        The slot's blend mode.
    bones : ndarray, shape (N, 3), optional
        Colour (RGB 0..255) of each vertex by its bones: the bones' colours mixed by weight.
    """

    key: tuple[str, str, str]
    attachment: dict
    image: str | None
    world: np.ndarray
    alpha: float = 1.0
    blend: str = "normal"
    bones: np.ndarray | None = None


def region_uvs(content: tuple[int, int, int, int] | None, width: int, height: int) -> np.ndarray:
    """UV corners (4, 2) of the part of an image a region draws: its stored ``content`` box
    ``(x0, y0, x1, y1)`` in pixels of a ``width`` x ``height`` image (the whole image when None)."""
    if content is None:
        return np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    x0, y0, x1, y1 = content
    return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]], float) / (width, height)


def texture(att: dict, content=None, size=None) -> tuple[np.ndarray, np.ndarray]:
    """UVs (N, 2) and triangles (M, 3) an attachment is drawn with; ``content`` and ``size``
    ((width, height)) of its image for a region (:func:`region_uvs`)."""
    if att.get("type", "region") == "region":
        w, h = size or (1, 1)
        return region_uvs(content, w, h), np.array([[0, 1, 2], [0, 2, 3]])
    uvs = np.asarray(att.get("uvs", []), float).reshape(-1, 2)
    return uvs, np.asarray(att.get("triangles", []), int).reshape(-1, 3)


def pose_skins(doc: dict) -> list[str]:
    """The skins the setup pose is drawn with, first match first: the skin that supplies most of
    the slots' setup attachments (a project whose default skin is empty dresses it in one), then
    ``default``, as a runtime falls back to the default skin."""
    skins = dict(iter_skins(doc))
    wanted = [(s.get("name"), str(s["attachment"])) for s in doc.get("slots", [])
              if isinstance(s, dict) and s.get("attachment") is not None]

    def supplies(skin: str) -> int:
        return sum(isinstance((skins[skin].get(slot) or {}).get(name), dict) for slot, name in wanted)

    best = max((k for k in skins if k != "default"), key=supplies, default=None)
    return ([best] if best is not None and supplies(best) else []) + (["default"] if "default" in skins else [])


def _colour_alpha(value, default: float = 1.0) -> float:
    """Alpha of an ``RRGGBBAA`` colour (or ``default``)."""
    if isinstance(value, str) and len(value) == 8:
        try:
            return int(value[6:], 16) / 255
        except ValueError:
            return default
    return default


def bone_colours(att: dict, bone_count: int, slot_bone: int) -> np.ndarray:
    """Per-vertex RGB (N, 3) of an attachment: its bones' :data:`PALETTE` colours mixed by
    weight (a region or an unweighted mesh: its slot bone's colour)."""
    from ..rig.binding import parse_vertices

    palette = PALETTE
    if att.get("type", "region") != "mesh":
        return np.tile(palette[slot_bone % len(palette)], (4, 1))
    mesh = parse_vertices(att, bone_count)
    if not mesh.weighted:
        return np.tile(palette[slot_bone % len(palette)], (mesh.count, 1))
    out = np.zeros((mesh.count, 3))
    for v, entry in enumerate(mesh.influences):
        for b, _, _, w in entry:
            out[v] += w * palette[b % len(palette)]
    return out.clip(0, 255)


def setup_pose(doc: dict, content=None, skins: list[str] | None = None) -> list[Drawn]:
    """The attachments a skeleton's setup pose draws, in draw order.

    Parameters
    ----------
    doc : dict
        The skeleton.
    content : callable, optional
        ``content(image path) -> ((x0, y0, x1, y1), (width, height))`` or None: the part of an
        image its atlas stores, for regions (default: the whole image).
    skins : list of str, optional
        Skins looked in, first match first (default :func:`pose_skins`).

    Malformed attachments (bad numbers, bone indices) are left out; the rest is drawn.
    """
    from ..errors import SpineMeshError
    from ..rig.binding import parse_vertices, setup_world
    from ..rig.bones import skeleton_bones

    bones = skeleton_bones(doc)
    by_name = {b.name: b for b in bones}
    worlds = [b.world for b in bones]
    all_skins = dict(iter_skins(doc))
    order = pose_skins(doc) if skins is None else [s for s in skins if s in all_skins]
    out = []
    for slot in doc.get("slots", []):
        if not isinstance(slot, dict) or slot.get("attachment") is None or slot.get("bone") not in by_name:
            continue
        name = str(slot["attachment"])
        found = [(k, all_skins[k][slot.get("name")][name]) for k in order
                 if isinstance((all_skins[k].get(slot.get("name")) or {}).get(name), dict)]
        if not found:
            continue
        skin, att = found[0]
        kind = att.get("type", "region")
        bone = by_name[slot["bone"]]
        paths = image_paths(AttachmentRef(skin, slot.get("name"), name, att)) if kind in ("region", "mesh") else []
        try:
            if kind == "region":
                box = content(paths[0]) if content is not None and paths else None
                uvs = region_uvs(box[0], *box[1]) if box else region_uvs(None, 1, 1)
                quad = region_quad_transform(att)
                world = (uvs @ quad[:, :2].T + quad[:, 2]) @ bone.world[:, :2].T + bone.world[:, 2]
            elif kind == "mesh":
                world = setup_world(parse_vertices(att, len(worlds)), worlds, bone.index)
            else:
                continue
            colours = bone_colours(att, len(worlds), bone.index)
        except (SpineMeshError, TypeError, ValueError, IndexError, KeyError):
            continue
        if not np.isfinite(world).all():
            continue
        alpha = _colour_alpha(slot.get("color")) * _colour_alpha(att.get("color"))
        out.append(Drawn((skin, slot.get("name"), name), att, paths[0] if paths else None, world, alpha,
                         str(slot.get("blend", "normal")), colours))
    return out


@dataclass
class SideTable:
    """The attachments one side of the player draws, each given an index once.

    ``image_index(path) -> int or None`` gives the page's index of an image (None: not
    available, the attachment is drawn as its outline); ``content(path)`` as in
    :func:`setup_pose`.
    """

    image_index: object
    content: object = None
    keys: dict = field(default_factory=dict)
    rows: list = field(default_factory=list)

    def index(self, d: Drawn) -> int:
        """The table index of ``d``'s attachment, added on first sight."""
        key = (d.key, d.image, len(d.world))
        if key not in self.keys:
            box = self.content(d.image) if self.content is not None and d.image else None
            uvs, tris = texture(d.attachment, *(box if box else (None, None)))
            self.keys[key] = len(self.rows)
            colours = d.bones if d.bones is not None and len(d.bones) == len(uvs) else np.full((len(uvs), 3), 128)
            self.rows.append({
                "name": "/".join(map(str, d.key)),
                "img": self.image_index(d.image) if d.image else None,
                "uv": [round(float(v), 5) for v in uvs.ravel()],
                "t": [int(v) for v in tris.ravel()],
                "hull": int(d.attachment.get("hull", len(uvs))) if d.attachment.get("type") == "mesh" else 4,
                "mesh": d.attachment.get("type") == "mesh",
                "c": "".join(f"{int(r):02x}{int(g):02x}{int(b):02x}" for r, g, b in np.round(colours)),
            })
        return self.keys[key]


def bounds(poses: list[list[Drawn]]) -> tuple[float, float, float, float]:
    """``(x0, y0, x1, y1)`` around every vertex of ``poses`` (a unit square when empty)."""
    pts = [d.world for pose in poses for d in pose if len(d.world)]
    if not pts:
        return (0.0, 0.0, 1.0, 1.0)
    allp = np.concatenate(pts)
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    hi = np.maximum(hi, lo + 1e-3)
    return (float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))


def encode_frames(poses: list[list[Drawn]], table: SideTable, box) -> dict:
    """One side of an animation: ``draws`` (per frame: count, then per attachment its table
    index, alpha 0..255 and blend) and ``xy`` (every vertex, frame after frame, quantised to
    0..65535 over ``box``, little-endian uint16, base64)."""
    x0, y0, x1, y1 = box
    span = np.array([x1 - x0, y1 - y0])
    draws: list[int] = []
    xy = []
    for pose in poses:
        draws.append(len(pose))
        for d in pose:
            draws += [table.index(d), int(round(255 * min(max(d.alpha, 0.0), 1.0))), BLENDS.get(d.blend, 0)]
            xy.append(d.world)
    q = np.concatenate(xy) if xy else np.zeros((0, 2))
    q = np.round((q - (x0, y0)) / span * 65535).clip(0, 65535).astype("<u2")
    return {"draws": draws, "xy": base64.b64encode(q.tobytes()).decode("ascii")}


def frame_times(duration: float, vertices_per_frame: int, fps: float = FPS) -> np.ndarray:
    """Times (seconds) an animation of ``duration`` is sampled at: ``fps`` per second, fewer
    when the animation would pass :data:`MAX_FRAMES` frames or :data:`MAX_VALUES` coordinates
    (``vertices_per_frame`` the most a frame draws); one frame (t = 0) for a still pose."""
    if duration <= 0:
        return np.zeros(1)
    budget = max(1, min(MAX_FRAMES, MAX_VALUES // max(1, 2 * vertices_per_frame)))
    n = int(min(budget, max(1, np.ceil(duration * fps))))
    return np.arange(n) * (duration / n)
