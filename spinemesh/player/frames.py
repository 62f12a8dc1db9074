"""What the player draws: attachments in world space, frame by frame, packed small.

A pose is the list of attachments a skeleton draws, in draw order (:class:`Drawn`): each one's
vertices in world units, with the texture coordinates and triangles it is drawn with. A side
of the player (the original skeleton, or the upgraded one) keeps a table of the attachments
its poses draw (:class:`SideTable`: image, UVs, triangles, colours by bone, written once in the
page's model script); an animation is stored as, per frame, which attachments are drawn with
which alpha, tint, blend mode and clipping polygon, and every vertex position quantised to 16 bits over the
animation's bounds (:func:`encode_frames`), base64 in a ``.js`` file the page loads when
that animation is chosen. Quantisation error is the bounds' larger side / 65,535 (0.015 world
units for a 1,000-unit skeleton), below a pixel at any size the page shows.
"""

from __future__ import annotations

import base64
from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np

from ..rig.preview import bone_colour, bone_palette  # the bones' colours of the weights pictures, here by vertex
from ..skeleton import iter_skins, skins_by_name
from ..words import counted

#: Blend modes by the number the player uses (the runtimes' names; 3.x "additive" too).
BLENDS = {"normal": 0, "additive": 1, "multiply": 2, "screen": 3}

#: The budget of the player's data: animations are sampled at :data:`FPS` frames a second,
#: more sparsely where an animation would pass :data:`MAX_FRAMES` frames or its script
#: :data:`MAX_VALUES` vertex coordinates (2 bytes each before base64, so at most 4 MB of
#: script, loaded only when that animation is chosen); a skeleton's animations are sampled in
#: at most :data:`MAX_SKINS` skins (its setup pose's first), and in about :data:`MAX_POSES`
#: poses per skeleton and side in all: where they would pass it, in its setup pose's skin
#: alone, then fewer frames a second, down to :data:`MIN_FPS` (the time it takes to write:
#: about 3 ms a pose).
FPS = 30
MAX_FRAMES = 300
MAX_VALUES = 1_500_000
MAX_SKINS = 4
MAX_POSES = 4000
MIN_FPS = 2.0

#: Most animations of one skeleton the player shows (the first, in the skeleton's order): each
#: costs a script file and at least a pose per side, and a skeleton file can list millions of
#: empty ones (real projects have at most about 200).
MAX_ANIMATIONS = 1000


@dataclass
class Drawn:
    """One attachment as a pose draws it.

    Attributes
    ----------
    key : (skin, slot, attachment key)
    image : str or None
        The image path it draws (a sequence: the frame shown).
    world : ndarray, shape (N, 2)
        Vertex positions in world units (y up).
    uvs : ndarray, shape (N, 2)
        The same vertices in the attachment's original image (u right, v down, 0..1).
    triangles : ndarray, shape (3T,)
    mesh : bool
        A mesh (else a region).
    alpha : float
        0..1: the skeleton's, the slot's and the attachment's alpha multiplied.
    tint : (float, float, float)
        0..1: their colours multiplied, the same way (what the image's colour is multiplied by).
    blend : str
        The slot's blend mode.
    bones : ndarray, shape (N, 3), optional
        Colour (RGB 0..255) of each vertex by its bones: the bones' colours mixed by weight.
    clip : ndarray, shape (M, 2), or None
        The world polygon of the clipping attachment that clips it (one array object shared by
        every attachment that polygon clips in a pose), if any.
    dark : (float, float, float) or None
        0..1: the slot's dark colour (two-colour tint), None where it has none.
    """

    key: tuple[str, str, str]
    image: str | None
    world: np.ndarray
    uvs: np.ndarray
    triangles: np.ndarray
    mesh: bool = False
    alpha: float = 1.0
    tint: tuple = (1.0, 1.0, 1.0)
    blend: str = "normal"
    bones: np.ndarray | None = None
    clip: np.ndarray | None = None
    dark: tuple | None = None


def pose_skins(doc: dict) -> list[str]:
    """The skins the setup pose is drawn with, first match first: the skin that supplies most of
    the slots' setup attachments (a project whose default skin is empty dresses it in one), then
    ``default``, as a runtime falls back to the default skin."""
    held = setup_counts(doc)
    best = max((k for k in held if k != "default"), key=held.get, default=None)
    return ([best] if best is not None and held[best] else []) + (["default"] if "default" in held else [])


def _setup_attachments(doc: dict) -> list[tuple[str, str]]:
    """The slots' setup attachments, ``(slot, attachment)``, in slot order."""
    return [(s.get("name"), str(s["attachment"])) for s in doc.get("slots", [])
            if isinstance(s, dict) and s.get("attachment") is not None]


def _held(slots: dict, wanted) -> list[tuple[str, str]]:
    """Those of the ``(slot, attachment)`` pairs ``wanted`` that a skin's ``slots`` holds."""
    return [(slot, name) for slot, name in wanted if isinstance((slots.get(slot) or {}).get(name), dict)]


def setup_counts(doc: dict) -> dict[str, int]:
    """Per skin, in the document's order, how many of the slots' setup attachments it holds."""
    wanted = _setup_attachments(doc)
    return {k: len(_held(slots, wanted)) for k, slots in iter_skins(doc)}


def bone_colours(att: dict | None, count: int, bone_count: int, slot_bone: int) -> np.ndarray:
    """Per-vertex RGB (count, 3) of an attachment: its bones' colours (:func:`~spinemesh.rig.preview.bone_colour`
    of each bone's place in the skeleton) mixed by weight (a region, an unweighted or a linked mesh:
    its slot bone's colour)."""
    from ..errors import SpineMeshError
    from ..rig.binding import parse_vertices

    own = np.tile(np.array(bone_colour(slot_bone), float), (count, 1))
    if not isinstance(att, dict) or att.get("type") != "mesh":
        return own
    try:
        mesh = parse_vertices(att, bone_count)
    except (SpineMeshError, TypeError, ValueError, IndexError):
        return own
    if not mesh.weighted or mesh.count != count:
        return own
    out = np.zeros((count, 3))
    palette = bone_palette(bone_count)
    for v, entry in enumerate(mesh.influences):
        for b, _, _, w in entry:
            out[v] += w * palette[b]
    return out.clip(0, 255)


class PoseSampler:
    """Poses of one skeleton as the player draws them, through :class:`spinemesh.anim.Sampler`.

    Parameters
    ----------
    doc : dict
        The skeleton.
    skin : str, tuple of str, or None
        The skin shown (None: the default skin only; a tuple: those skins combined, :func:`outfit`).
    regions : callable, optional
        ``regions(path)``, the atlas regions (:func:`spinemesh.anim.atlas_regions`): a region
        quad follows its region's trimming.
    """

    def __init__(self, doc: dict, skin: str | None, regions=None):
        from ..anim import Sampler

        self.doc = doc
        self.sampler = Sampler(doc, skin, regions)
        self.skins = skins_by_name(doc)
        self.bone_index = {n: i for i, n in enumerate(self.sampler.bone_names)}
        self._colours: dict = {}

    def pose(self, animation: str | None, time: float) -> tuple[list[Drawn], dict[str, str]]:
        """The attachments drawn at ``time`` of ``animation`` (None: the setup pose), in draw
        order, and the bones not posed as a runtime poses them (name -> why)."""
        return self._drawn(self.sampler.pose(animation, time))

    def play(self, animation: str, times) -> list[tuple[list[Drawn], dict[str, str]]]:
        """:meth:`pose` at each of ``times`` (ascending), along one game loop: physics is
        stepped once through the animation, not replayed from 0 for each time."""
        return [self._drawn(p) for p in self.sampler.play(animation, [float(t) for t in times])]

    def play_pair(self, twin: PoseSampler, animation: str, times) -> list[tuple[tuple, tuple]]:
        """:meth:`play` of this sampler and ``twin`` at once, their bones posed once for both
        (:meth:`spinemesh.anim.Sampler.play_pair`: ``twin``'s skeleton moves as this one's)."""
        return [(self._drawn(p), twin._drawn(q))
                for p, q in self.sampler.play_pair(twin.sampler, animation, [float(t) for t in times])]

    def _drawn(self, pose) -> tuple[list[Drawn], dict[str, str]]:
        out = []
        for s in pose.slots:
            world = np.asarray(s.vertices, float)
            if not len(world) or not np.isfinite(world).all():
                continue
            key = (s.skin, s.slot, s.key)
            if (key, len(world)) not in self._colours:
                att = ((self.skins.get(s.skin) or {}).get(s.slot) or {}).get(s.key)
                self._colours[key, len(world)] = bone_colours(att, len(world), len(self.bone_index),
                                                              self.bone_index.get(s.bone, 0))
            out.append(Drawn(key, s.path or None, world, np.asarray(s.uvs, float).reshape(-1, 2),
                             np.asarray(s.triangles, int).ravel(), s.type == "mesh", float(s.color[3]),
                             tuple(np.asarray(s.color, float)[:3].tolist()), s.blend,
                             self._colours[key, len(world)], _clip_polygon(s.clip),
                             None if s.dark is None else tuple(np.asarray(s.dark, float).tolist())))
        return out, dict(pose.why)


def _clip_polygon(clip) -> np.ndarray | None:
    """A pose's clipping polygon as the player draws it: None when it is missing, has fewer
    than 3 vertices or a coordinate that is not a number (the runtime then clips nothing)."""
    if clip is None:
        return None
    poly = np.asarray(clip, float).reshape(-1, 2)
    return poly if len(poly) >= 3 and np.isfinite(poly).all() else None


@dataclass
class SideTable:
    """The attachments one side of the player draws, each given an index once.

    ``image_index(path) -> int or None`` gives the page's index of an image (None: not
    available; the attachment is then left out of the picture but kept in the wireframe).
    """

    image_index: object
    keys: dict = field(default_factory=dict)
    rows: list = field(default_factory=list)

    def index(self, d: Drawn) -> int:
        """The table index of ``d``'s attachment, added on first sight."""
        key = (d.key, d.image, len(d.world))
        if key not in self.keys:
            self.keys[key] = len(self.rows)
            colours = d.bones if d.bones is not None and len(d.bones) == len(d.uvs) else np.full((len(d.uvs), 3), 128)
            self.rows.append({
                "name": "/".join(map(str, d.key)),
                "img": self.image_index(d.image) if d.image else None,
                "uv": [round(float(v), 5) for v in d.uvs.ravel()],
                "t": [int(v) for v in d.triangles],
                "mesh": d.mesh,
                "c": "".join(f"{int(r):02x}{int(g):02x}{int(b):02x}" for r, g, b in np.round(colours)),
            })
        return self.keys[key]

    def absorb(self, side: EncodedSide) -> dict:
        """``side``'s frames (:func:`encode_frames` against a table of its own) with this
        table's indices: its attachments added in the order it first drew them, as if its
        frames had been encoded against this table."""
        where = []
        for key, row in zip(side.keys, side.rows):
            if key not in self.keys:
                self.keys[key] = len(self.rows)
                self.rows.append({**row, "img": self.image_index(row["img"]) if row["img"] else None})
            where.append(self.keys[key])
        draws = list(side.frames["draws"])
        i = 0
        while i < len(draws):  # per frame: its count, then 5 numbers per attachment, the table index first
            count = draws[i]
            for j in range(i + 1, i + 1 + 5 * count, 5):
                draws[j] = where[draws[j]]
            i += 1 + 5 * count
        tints = {"tints": side.frames["tints"]} if "tints" in side.frames else {}
        return {"draws": draws, "xy": side.frames["xy"], **tints}


@dataclass
class EncodedSide:
    """One side of an animation as the player's data hold it, against a table of its own:
    ``frames`` (:func:`encode_frames`), and that table's ``keys`` and ``rows`` in index order
    (each row's ``img`` the image path, made the page's image index by :meth:`SideTable.absorb`)."""

    frames: dict
    keys: list
    rows: list


@dataclass
class EncodedAnimation:
    """An :class:`Animation` encoded (:func:`encode_animation`): small to send from a worker
    process (the frames quantised; each attachment's image, UVs and triangles once), and
    written into a page by :meth:`SideTable.absorb`. ``by_skin``: per skin, ``(frames,
    box, (original side, upgraded side))``, the box padded (world units)."""

    name: str
    duration: float
    rate: float
    note: str
    by_skin: dict


def encode_animation(anim: Animation) -> EncodedAnimation:
    """``anim``'s frames quantised over their padded bounds, each side against a table of its own."""
    by_skin = {}
    for skin, (before, after) in anim.by_skin.items():
        box = bounds(before + after)
        pad = 0.02 * max(box[2] - box[0], box[3] - box[1])
        box = (box[0] - pad, box[1] - pad, box[2] + pad, box[3] + pad)
        sides = []
        for poses in (before, after):
            table = SideTable(lambda path: path)
            frames = encode_frames(poses, table, box)
            sides.append(EncodedSide(frames, list(table.keys), table.rows))
        by_skin[skin] = (len(before), box, tuple(sides))
    return EncodedAnimation(anim.name, anim.duration, anim.rate, anim.note, by_skin)


#: Largest coordinate, in world units, the player's bounds reach (a skeleton scaled beyond it is
#: drawn flattened against the box's edge: no page shows it anyway).
MAX_WORLD = 1e300


def bounds(poses: list[list[Drawn]]) -> tuple[float, float, float, float]:
    """``(x0, y0, x1, y1)`` around every vertex of ``poses`` and the clipping polygons they
    are drawn with (a unit square when empty)."""
    pts = [d.world for pose in poses for d in pose if len(d.world)]
    pts += [d.clip for pose in poses for d in pose if d.clip is not None]
    if not pts:
        return (0.0, 0.0, 1.0, 1.0)
    # finite vertices of 1e308 on both sides would make the box's span, and its padding, infinite
    allp = np.concatenate(pts).clip(-MAX_WORLD, MAX_WORLD)
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    hi = np.maximum(hi, lo + 1e-3)
    return (float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1]))


def encode_frames(poses: list[list[Drawn]], table: SideTable, box) -> dict:
    """One side of an animation: ``draws`` (per frame: count, then per attachment its table
    index, alpha 0..255, blend, tint (:func:`tint_number`, or ``-1 - k`` for the ``k``-th of
    ``tints``) and its clipping: 0 none, -1 the previous attachment's polygon, M > 0 a new
    polygon of M vertices), ``xy`` (every vertex, frame after frame, each new clipping polygon's
    before the vertices of the attachment it first clips, quantised to 0..65535 over ``box``,
    little-endian uint16, base64), and, only where a colour overshoots 0..1, ``tints``
    (:func:`overshooting_tint`)."""
    x0, y0, x1, y1 = box
    span = np.array([x1 - x0, y1 - y0])
    draws: list[int] = []
    tints: dict[tuple, int] = {}
    xy = []
    for pose in poses:
        draws.append(len(pose))
        previous = None
        for d in pose:
            if d.clip is None:
                clip = 0
            elif previous is not None and (d.clip is previous or np.array_equal(d.clip, previous)):
                clip = -1
            else:
                clip = len(d.clip)
                xy.append(d.clip)
            previous = d.clip
            unclamped = overshooting_tint(d.tint, d.dark, d.alpha)
            tint = tint_number(d.tint, d.dark) if unclamped is None else -1 - tints.setdefault(unclamped, len(tints))
            # an alpha past 1 goes with the tint (its matrix multiplies the texels' alpha; the draw's, clamped, is 1)
            draws += [table.index(d), int(round(255 * min(max(d.alpha, 0.0), 1.0))), BLENDS.get(d.blend, 0),
                      tint, clip]
            xy.append(d.world)
    q = np.concatenate(xy) if xy else np.zeros((0, 2))
    q = np.round((q - (x0, y0)) / span * 65535).clip(0, 65535).astype("<u2")
    out = {"draws": draws, "xy": base64.b64encode(q.tobytes()).decode("ascii")}
    if tints:  # a page whose colours stay within 0..1 holds what it held before
        out["tints"] = [list(t) for t in tints]
    return out


#: The largest magnitude of an overshooting colour channel a page holds: past it every texel's
#: colour but one (0 or 1) is the same once the output is clamped; a page holds no infinity.
MAX_TINT_CHANNEL = 1000.0


def overshooting_tint(light, dark=None, alpha: float = 1.0) -> tuple | None:
    """``(light r, g, b, dark r, g, b, alpha)`` (no dark colour: 0, 0, 0; an alpha of 1 or less:
    1, the draw's own alpha doing the rest), each rounded to 1e-5 and within
    :data:`MAX_TINT_CHANNEL`, where a colour channel is outside 0..1 or the alpha above 1; None
    where all are within.

    4.0 to 4.2 assign some colour timelines' values as keyed, so a Bezier curve overshoots 0..1,
    and their shaders clamp only the colour drawn, ``dark + texel * (light - dark)`` and ``texel
    alpha * alpha``: the player draws those tints unclamped (its colour matrix clamps its output
    alike), where :func:`tint_number`, bytes of 0..255, would clamp them first. An alpha below 0
    draws nothing either way.

    Examples
    --------
    >>> overshooting_tint((1.0, 0.5, 0.0), None, 0.5) is None
    True
    >>> overshooting_tint((1.25, 0.5, 0.0), (0.0, -0.5, 0.0))
    (1.25, 0.5, 0.0, 0.0, -0.5, 0.0, 1.0)
    >>> overshooting_tint((1.0, 0.5, 0.0), None, 1.5)
    (1.0, 0.5, 0.0, 0.0, 0.0, 0.0, 1.5)
    """
    channels = [*light[:3], *(dark[:3] if dark is not None else (0.0, 0.0, 0.0))]
    if all(0.0 <= c <= 1.0 for c in channels) and not alpha > 1.0:
        return None
    bounded = [float(np.clip(np.nan_to_num(c), -MAX_TINT_CHANNEL, MAX_TINT_CHANNEL)) for c in [*channels, max(alpha, 1.0)]]
    return tuple(round(c, 5) + 0.0 for c in bounded)


def _rgb24(colour) -> int:
    r, g, b = (int(round(255 * min(max(c, 0.0), 1.0))) for c in colour)
    return (r << 16) | (g << 8) | b


def tint_number(light, dark=None) -> int:
    """The tint the player draws an attachment with, one number: the light colour (RGB 0..1) as
    24 bits, plus the dark colour's 24 bits times 2**24 where the slot has a dark colour (the
    two-colour tint; channels clamped to 0..1). A dark colour of black draws as no dark colour
    (``dark + texel * (light - dark)`` is then ``texel * light``): both are 0, and a page whose
    slots have none holds the numbers it held before. At most 2**48, exact in JavaScript.

    Examples
    --------
    >>> hex(tint_number((1.0, 0.5, 0.0)))
    '0xff8000'
    >>> tint_number((1.0, 1.0, 1.0), (0.0, 0.0, 0.0)) == tint_number((1.0, 1.0, 1.0))
    True
    >>> tint_number((1.0, 1.0, 1.0), (1.0, 0.0, 0.0)) == 0xffffff + 0xff0000 * 2 ** 24
    True
    """
    return _rgb24(light) + (0 if dark is None else _rgb24(dark) << 24)


def frame_rate(duration: float, vertices_per_frame: int, fps: float = FPS) -> float:
    """Frames a second an animation of ``duration`` is sampled at: ``fps``, fewer when it would
    pass :data:`MAX_FRAMES` frames or :data:`MAX_VALUES` coordinates (``vertices_per_frame``
    the most a frame draws). Frame ``i`` is the pose at ``i / rate`` seconds, for every such
    time before ``duration`` (one frame, t = 0, for a still pose)."""
    if duration <= 0:
        return float(fps)
    budget = max(1, min(MAX_FRAMES, MAX_VALUES // max(1, 2 * vertices_per_frame)))
    return float(min(fps, budget / duration))


def frame_times(duration: float, rate: float) -> np.ndarray:
    """The times (seconds) of the frames: ``i / rate`` for every one before ``duration``."""
    n = max(1, int(np.ceil(duration * rate - 1e-9))) if duration > 0 else 1
    return np.arange(n) / rate


@dataclass
class Animation:
    """One animation of the player: its name and duration (seconds), per skin the poses of both
    sides at its sampled times (``{skin: (before poses, after poses)}``), and a note shown
    with it (what the page could not reproduce)."""

    name: str
    duration: float
    by_skin: dict = field(default_factory=dict)
    note: str = ""
    rate: float = FPS  # frames a second: frame i is the pose at i / rate seconds


def outfit(doc: dict) -> tuple[str, ...]:
    """The skins that together dress the setup pose when no one skin does (a mix-and-match
    character: a body skin, a clothes skin, ...), most slots first; ``()`` when one skin, or the
    default skin, dresses every slot the others can.

    Chosen one by one: the skin that supplies the most setup attachments still missing (the
    default skin's are never missing), until none supplies another.

    Examples
    --------
    >>> doc = {"slots": [{"name": "body", "attachment": "b"}, {"name": "hat", "attachment": "h"}],
    ...        "skins": [{"name": "default", "attachments": {}},
    ...                  {"name": "naked", "attachments": {"body": {"b": {}}}},
    ...                  {"name": "cap", "attachments": {"hat": {"h": {}}}}]}
    >>> outfit(doc)
    ('naked', 'cap')
    """
    skins = skins_by_name(doc)
    wanted = _setup_attachments(doc)
    missing = set(wanted) - set(_held(skins.get("default") or {}, wanted))  # the default skin's are never missing

    def supplied(skin: str) -> set:
        return set(_held(skins[skin], missing))

    chosen: list[str] = []
    while missing:
        best = max((k for k in skins if k != "default" and k not in chosen), key=lambda k: len(supplied(k)), default=None)
        if best is None or not supplied(best):
            break
        chosen.append(best)
        missing -= supplied(best)
    return tuple(chosen) if len(chosen) > 1 else ()


def skin_label(skins: tuple[str, ...]) -> str:
    """What the player calls skins combined (:func:`outfit`): ``"body + clothes"``, the first
    three named when there are more."""
    shown = " + ".join(skins[:3])
    return shown + (f" + {len(skins) - 3} more" if len(skins) > 3 else "")


def sampled_skins(doc: dict) -> list[str | tuple[str, ...]]:
    """The skins the player offers, at most :data:`MAX_SKINS`: where several skins together dress
    the setup pose (:func:`outfit`), them combined first; then the setup pose's, then those with
    the most attachments (whole outfits before single accessories). A default skin that holds
    none of the setup pose's attachments is one of the others, by its size: a character whose
    skins are all named and whose default skin holds a few effects is first played dressed
    (the first skin is the one its animations are sampled in when the budget allows one)."""
    held = setup_counts(doc)
    order = [k for k in pose_skins(doc) if held.get(k)]
    sizes = {k: sum(len(v) for v in slots.values() if isinstance(v, dict)) for k, slots in iter_skins(doc)}
    rest = sorted((k for k in sizes if k not in order), key=lambda k: -sizes[k])
    combined = outfit(doc)
    return (([combined] if combined else []) + order[:1] + rest + order[1:])[:MAX_SKINS] or ["default"]


def _note(why: dict[str, str], rate: float = FPS, empty: bool = False) -> str:
    """What the player says under an animation: that it draws nothing (``empty``: no frame of the
    original shows an attachment, so the canvases stay blank on purpose), that it is shown at
    fewer frames a second than :data:`FPS` (``rate``: the budget's), and the bones not posed as
    a game poses them (``why``: name -> reason)."""
    parts = []
    if empty:
        parts.append("Nothing to see: played alone, as here, this animation shows no attachment (or only fully "
                     "transparent ones); a game may play it over another animation.")
    if rate < FPS - 1e-9:
        parts.append(f"Shown at {rate:.3g} frames a second, not {FPS}, to keep the preview small (a game "
                     "plays every frame).")
    if why:
        names = sorted(why)
        parts.append(f"Not as a game shows it: {', '.join(names[:5])}{' and more' if len(names) > 5 else ''} "
                     f"({next(iter(why.values()))}).")
    return " ".join(parts)


@dataclass
class Sampling:
    """How the animations of one skeleton's player are sampled, decided once before any is
    (:func:`plan_sampling`), so that any subset of them can be sampled apart, in any process,
    to the same frames (:func:`sample_animations`).

    Attributes
    ----------
    skins : list of (str, str, tuple of str or None)
        Per skin shown: its label in the player and the skin both sides are posed in (None:
        the default skin; a tuple: skins combined, :func:`outfit`).
    alike : bool
        Both skeletons move alike (:func:`spinemesh.anim.same_motion`): their bones are stepped once.
    per_second : float
        Frames a second at most (the skeleton's budget of :data:`MAX_POSES`).
    vertices : int
        The most vertices a frame of the setup pose draws (each animation's budget).
    durations : dict of str to float
        The animations shown, seconds each, in the skeleton's order.
    """

    skins: list
    alike: bool
    per_second: float
    vertices: int
    durations: dict


def sides_of(before: dict, after: dict, sampling_skins: list, regions=None) -> dict:
    """``{label: (original's PoseSampler, upgraded's PoseSampler)}`` for ``Sampling.skins``."""
    return {label: (PoseSampler(before, skin, regions), PoseSampler(after, skin, regions))
            for label, skin in sampling_skins}


def plan_sampling(before: dict, after: dict, regions=None,
                  problems: list | None = None) -> tuple[Animation, Sampling, dict]:
    """The setup pose of a skeleton's player, how its animations are sampled within the stated
    budget (:data:`MAX_POSES`), and the samplers of both sides (:func:`sides_of`).

    An animation whose duration cannot be read is left out with one line in ``problems``, as
    are the animations beyond the first :data:`MAX_ANIMATIONS`, and the skins not offered alone
    (beyond :data:`MAX_SKINS`).
    """
    from ..anim import POSE_ERRORS, same_motion
    from ..anim.curves import unplayable_said

    problems = problems if problems is not None else []
    chosen = sampled_skins(after)
    left = [k for k, slots in iter_skins(after) if k != "default" and k not in chosen and slots]
    if left:  # else a user looks in vain for a skin in the list
        problems.append(f"skin{'s' if len(left) > 1 else ''} {', '.join(left[:10])}{' and more' if len(left) > 10 else ''} "
                        f"not offered alone: the player offers at most {MAX_SKINS} skins, those that dress the setup "
                        "pose first")
    skins = [(s if isinstance(s, str) else skin_label(s), None if s == "default" else s) for s in chosen]
    sides = sides_of(before, after, skins, regions)
    first = sides[skins[0][0]][1]
    setup = {label: ([b.pose(None, 0)[0]], [a.pose(None, 0)[0]]) for label, (b, a) in sides.items()}
    durations = {}
    names = first.sampler.animation_names()
    if len(names) > MAX_ANIMATIONS:
        problems.append(f"{counted(len(names) - MAX_ANIMATIONS, 'animation')} not shown: the player shows the first "
                        f"{MAX_ANIMATIONS:,}")
    for name in names[:MAX_ANIMATIONS]:
        try:
            durations[name] = max(0.0, float(first.sampler.duration(name)))
            # what pose says too (the upgrade keeps animations as they are: one side says it)
            problems.extend(unplayable_said(name, u, "shown linear here")
                            for u in first.sampler.animation(name)[0].unplayable[:3])
        except POSE_ERRORS as e:
            problems.append(f"animation {name!r} not shown: {e}")
    seconds = max(1e-6, sum(d for d in durations.values() if np.isfinite(d)))
    if len(sides) > 1 and MAX_POSES / (len(sides) * seconds) < FPS:  # over budget: one skin first
        skins, sides = skins[:1], {skins[0][0]: sides[skins[0][0]]}
    per_second = min(float(FPS), max(MIN_FPS, MAX_POSES / (len(sides) * seconds)))
    vertices = max((sum(len(d.world) for d in pose) for b, a in setup.values() for pose in b + a), default=1)
    # an upgrade changes attachments: the bones are stepped once for both sides
    sampling = Sampling(skins, same_motion(before, after), per_second, vertices, durations)
    blank = all(not any(d.alpha > 0 for d in before[0]) for before, _ in setup.values())
    note = ("Nothing to see in the setup pose: no slot shows an attachment (or each is fully transparent) "
            "until an animation sets one; choose an animation." if blank else "")
    return Animation("setup pose", 0.0, setup, note=note), sampling, sides


def sample_animations(sides: dict, sampling: Sampling, names) -> Iterator[tuple[str, Animation | str]]:
    """The animations ``names`` (of ``sampling.durations``) sampled on both sides, one by one:
    per name, the :class:`Animation`, or the line saying why it is not shown."""
    from ..anim import POSE_ERRORS

    for name in names:
        duration = sampling.durations[name]
        rate = frame_rate(duration, sampling.vertices, sampling.per_second)
        times = frame_times(duration, rate)
        anim = Animation(name, duration, rate=rate)
        why: dict[str, str] = {}
        try:
            for label, (b, a) in sides.items():
                poses = [], []
                pairs = b.play_pair(a, name, times) if sampling.alike else zip(b.play(name, times), a.play(name, times))
                for both in pairs:
                    for side, (drawn, not_exact) in zip(poses, both):
                        side.append(drawn)
                        why.update(not_exact)
                anim.by_skin[label] = poses
        except POSE_ERRORS as e:
            yield name, f"animation {name!r} not shown: {e}"
            continue
        empty = all(not any(d.alpha > 0 for d in pose) for before, _ in anim.by_skin.values() for pose in before)
        anim.note = _note(why, rate, empty)
        yield name, anim


def sample_and_encode(sides: dict, sampling: Sampling, names) -> list[tuple[str, EncodedAnimation | str]]:
    """:func:`sample_animations`, each animation encoded as soon as it is sampled (the poses
    of one animation held at a time; what a worker process sends back)."""
    return [(name, got if isinstance(got, str) else encode_animation(got))
            for name, got in sample_animations(sides, sampling, names)]


def animations(before: dict, after: dict, regions=None, problems: list | None = None) -> list[Animation]:
    """The setup pose and every animation of a skeleton, original (``before``) and upgraded
    (``after``), sampled for the player within the stated budget (:data:`MAX_POSES`).

    An animation that cannot be sampled is left out with one line in ``problems``, as are
    the animations beyond the first :data:`MAX_ANIMATIONS`.
    """
    problems = problems if problems is not None else []
    setup, sampling, sides = plan_sampling(before, after, regions, problems)
    return [setup] + collect(sample_animations(sides, sampling, list(sampling.durations)), problems)


def collect(sampled, problems: list) -> list:
    """The animations of :func:`sample_animations`' answers, the others' lines put in ``problems``."""
    out = []
    for _, got in sampled:
        if isinstance(got, str):
            problems.append(got)
        else:
            out.append(got)
    return out
