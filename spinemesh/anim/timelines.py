"""An animation's timelines read from a skeleton document, once per animation.

Both layouts the document can hold (the binary reader gives the JSON layout): 3.x names
(``rotate`` keys with ``angle``, ``color``, ``twoColor``, ``rotateMix``..., ``deform``) and 4.x
names (``rotate`` with ``value``, split ``translatex``/``translatey``/``scalex``/... timelines,
``rgba``/``rgb``/``alpha``/``rgba2``/``rgb2``, ``mixRotate``..., ``deform`` under 4.0 and
``attachments``/``deform`` from 4.1 on, 4.2's ``inherit``). Each timeline becomes a
:class:`~.curves.Keys` and the name of what it drives; :mod:`.pose` applies them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from itertools import pairwise

import numpy as np

from ..skeleton import first_of_each_name
from ..skeleton_colours import read_colour
from ..skeleton_curves import CURVES_38, CurveSpelling
from ..skeleton_version import doc_major_minor
from .curves import Keys, _number, f32, key_times, read_keys


def color_channels(text, count: int) -> list[float]:
    """``count`` channels (0..1) of a hex colour ``[#]rrggbb[aa]`` as the runtimes read it
    (:func:`spinemesh.skeleton_colours.read_colour`): alpha (the fourth channel) 1 unless the
    text has exactly eight digits (spine-core and libGDX read ``"ff8040"`` on a slot as orange,
    opaque); white where unreadable (fewer than six digits, or not hex, which the runtimes cannot
    read either)."""
    try:
        r, g, b, a = read_colour(text)
    except ValueError:
        return [1.0] * count
    return [r / 255, g / 255, b / 255, 1.0 if a is None else a / 255][:count]


@dataclass
class BoneTimeline:
    """``property``: rotate, translate, translatex, translatey, scale, scalex, scaley, shear,
    shearx, sheary."""

    bone: int
    property: str
    keys: Keys
    #: A 3.7 or 3.8 rotate timeline whose keyed angle jumps by more than half a turn somewhere
    #: (:func:`jumps_a_half_turn`): there the runtime's angle, carried from frame to frame,
    #: comes to differ from the keyed one by whole turns, which its pi of 3.1415927 turns into
    #: a real difference (:meth:`spinemesh.anim.Sampler.pose` replays it frame by frame).
    carried: bool = False


def jumps_a_half_turn(keys: Keys) -> bool:
    """Whether a 3.x rotate timeline's angle jumps by more than 180 degrees anywhere a game
    plays it: from key to key (a key is reached the shorter way round, then its value is taken
    as written), from 0 before the first key, and from the last key back to the first (a loop)."""
    values = [0.0, *(float(v) for v in keys.values[:, 0]), float(keys.values[0, 0]), 0.0]
    return any(abs(b - a) > 180 for a, b in pairwise(values))


@dataclass
class InheritTimeline:
    """4.2: the bone's inherit mode from each key on."""

    bone: int
    times: np.ndarray
    modes: list[str]


@dataclass
class SlotTimeline:
    """``property``: rgba, rgb, alpha (3.x ``color`` reads as rgba, ``twoColor`` as rgba2), rgba2, rgb2."""

    slot: int
    property: str
    keys: Keys


@dataclass
class AttachmentTimeline:
    slot: int
    times: np.ndarray
    names: list[str | None]


@dataclass
class ConstraintTimeline:
    """``kind``: ik, transform, path; ``fields``: the constraint's JSON keys each value sets
    (the keys its data uses in that version); ``flags``: IK's discrete keys per key."""

    kind: str
    name: str
    fields: tuple[str, ...]
    keys: Keys
    flags: list[dict] = field(default_factory=list)


@dataclass
class DeformTimeline:
    """A vertex attachment's deform: per key ``(offset, vertices)`` as stored (offsets from
    the setup vertices, per bone influence when weighted, starting at number ``offset``);
    ``keys`` holds the times and curves."""

    skin: str
    slot: int
    attachment: str
    keys: Keys
    raw: list[tuple[int, list | None]]


#: Keys made when a pose needs them that a timeline keeps (the rest are made again when needed).
KEPT_KEYS = 64


def made_when_needed(made: dict, i: int, make):
    """Key ``i`` of a timeline whose keys are made when a pose needs them, not all up front (a
    file can hold a million keys, each costly in memory once made): ``make(i)``, kept in
    ``made`` among the last :data:`KEPT_KEYS` made."""
    if i not in made:
        if len(made) >= KEPT_KEYS:
            made.clear()
        made[i] = make(i)
    return made[i]


@dataclass
class DrawOrderTimeline:
    """Per key, its ``offsets`` as stored; :meth:`order` makes a key's draw order when a pose
    needs it (made up front, 200,000 keys of ``"offsets": []`` on 500 slots took 2.4 GB)."""

    times: np.ndarray
    offsets: list
    slot_index: dict
    _made: dict = field(default_factory=dict)

    def order(self, i: int) -> list[int] | None:
        """Slot indices in draw order at key ``i``; None: the setup order."""
        return made_when_needed(self._made, i, lambda k: _draw_order(self.offsets[k], self.slot_index))


@dataclass
class SequenceTimeline:
    """4.1+: which image of a sequence an attachment shows (``mode`` and ``index``/``delay`` per key)."""

    skin: str
    slot: int
    attachment: str
    times: np.ndarray
    frames: list[dict]


@dataclass
class Animation:
    """Every timeline of one animation, grouped by what it drives."""

    name: str
    duration: float
    bones: list[BoneTimeline] = field(default_factory=list)
    inherits: list[InheritTimeline] = field(default_factory=list)
    slots: list[SlotTimeline] = field(default_factory=list)
    attachments: list[AttachmentTimeline] = field(default_factory=list)
    constraints: list[ConstraintTimeline] = field(default_factory=list)
    deforms: list[DeformTimeline] = field(default_factory=list)
    draw_order: DrawOrderTimeline | None = None
    sequences: list[SequenceTimeline] = field(default_factory=list)
    physics_resets: list[tuple[str, np.ndarray]] = field(default_factory=list)  # (constraint or "", key times)
    #: 4.x curves no runtime plays (:attr:`~spinemesh.anim.curves.Keys.unplayable`), one line each
    unplayable: list[str] = field(default_factory=list)


def _times(frames: list, four: bool) -> np.ndarray:
    """The keys' times, as :func:`~spinemesh.anim.curves.search` searches them."""
    return key_times(f32([_number(f.get("time", 0), 0) for f in frames if isinstance(f, dict)]), four)


def _mapping(value) -> dict:
    """``value`` when it is a JSON object, else empty (a malformed group is passed over)."""
    return value if isinstance(value, dict) else {}


def _dicts(value) -> list[dict]:
    return [f for f in value if isinstance(f, dict)] if isinstance(value, list) else []


def _getter(*pairs):
    """``frame -> [values]`` for ``(key, default)`` pairs; a default that is a key name takes
    that key's value (4.x ``mixY`` defaults to the key's ``mixX``)."""
    def values(f: dict) -> list[float]:
        out: list[float] = []
        got: dict[str, float] = {}
        for key, default in pairs:
            d = got[default] if isinstance(default, str) else default
            got[key] = _number(f.get(key, d), d)
            out.append(got[key])
        return out
    return values


#: 4.x bone timelines: JSON name -> value keys with defaults.
_BONE_4 = {
    "rotate": (("value", 0),), "translate": (("x", 0), ("y", 0)), "translatex": (("value", 0),),
    "translatey": (("value", 0),), "scale": (("x", 1), ("y", 1)), "scalex": (("value", 1),),
    "scaley": (("value", 1),), "shear": (("x", 0), ("y", 0)), "shearx": (("value", 0),),
    "sheary": (("value", 0),),
}
_BONE_3 = {"rotate": (("angle", 0),), "translate": (("x", 0), ("y", 0)), "scale": (("x", 1), ("y", 1)),
           "shear": (("x", 0), ("y", 0))}

#: Constraint timelines: (4.x fields, 3.x fields) of the mixes, as the constraint data names them.
_TRANSFORM_4 = (("mixRotate", 1), ("mixX", 1), ("mixY", "mixX"), ("mixScaleX", 1), ("mixScaleY", "mixScaleX"),
                ("mixShearY", 1))
_TRANSFORM_3 = (("rotateMix", 1), ("translateMix", 1), ("scaleMix", 1), ("shearMix", 1))
#: 4.3 reads a key without ``mixScaleY`` as 1 (4.0-4.2: its ``mixScaleX``).
_TRANSFORM_43 = tuple(p if p[0] != "mixScaleY" else ("mixScaleY", 1) for p in _TRANSFORM_4)


class _Reader:
    """Reads one animation's timelines, noting every timeline's last key for the duration."""

    def __init__(self, doc: dict, four: bool, out: Animation, spelling: CurveSpelling = CURVES_38):
        self.four, self.out, self.spelling = four, out, spelling
        self.bone_index = {str(b.get("name")): i for i, b in enumerate(doc.get("bones", [])) if isinstance(b, dict)}
        self.slot_index = first_of_each_name(str(s.get("name")) for s in doc.get("slots", []) if isinstance(s, dict))
        self.ends: list[float] = []
        #: 4.3 reads a physics mix key without a value as 1 (4.2: 0), and a transform key's
        #: mixScaleY as 1
        self.four_three = doc_major_minor(doc) == (4, 3)
        #: 3.7 and 3.8 apply a game's first track as MixBlend.first, which carries a bone's angle
        #: from frame to frame (3.5 and 3.6 set it from the setup pose, as 4.x does)
        self.carries_angles = not four and doc_major_minor(doc) in ((3, 7), (3, 8))

    def keys(self, frames, getter, where: str = "", **kw) -> Keys | None:
        """The keys of one timeline (``where``: its place in the animation, for what is said of it)."""
        k = read_keys(frames, getter, self.four, spelling=self.spelling, **kw)
        if k is not None:
            self.ends.append(k.duration)
            if k.unplayable:
                self.out.unplayable.append(f"{where or 'a timeline'}: {k.unplayable}")
        return k

    def discrete(self, frames) -> tuple[list[dict], np.ndarray]:
        fr = _dicts(frames)
        times = _times(fr, self.four)
        if len(times):
            self.ends.append(float(times[-1]))
        return fr, times

    def bones(self, timelines: dict) -> None:
        for bone, tls in timelines.items():
            if bone not in self.bone_index or not isinstance(tls, dict):
                continue
            b = self.bone_index[bone]
            for prop, frames in tls.items():
                if prop == "inherit" and self.four:
                    fr, times = self.discrete(frames)
                    if fr:
                        self.out.inherits.append(InheritTimeline(b, times, [str(f.get("inherit", "normal"))
                                                                            for f in fr]))
                    continue
                spec = (_BONE_4 if self.four else _BONE_3).get(prop)
                k = self.keys(frames, _getter(*spec), f"bones.{bone}.{prop}",
                              angle=(prop == "rotate" and not self.four)) if spec else None
                if k is not None:
                    self.out.bones.append(BoneTimeline(b, prop, k, carried=self.carries_angles and k.angle and jumps_a_half_turn(k)))

    def slots(self, timelines: dict) -> None:
        for slot, tls in timelines.items():
            if slot not in self.slot_index or not isinstance(tls, dict):
                continue
            s = self.slot_index[slot]
            for prop, frames in tls.items():
                if prop == "attachment":
                    fr, times = self.discrete(frames)
                    if fr:
                        names = [None if f.get("name") is None else str(f.get("name")) for f in fr]
                        self.out.attachments.append(AttachmentTimeline(s, times, names))
                    continue
                kind = _COLOR_KINDS.get(prop)
                k = self.keys(frames, _COLOR_GETTERS[kind], f"slots.{slot}.{prop}") if kind else None
                if k is not None:
                    self.out.slots.append(SlotTimeline(s, kind, k))

    def constraints(self, anim: dict) -> None:
        for cname, frames in _mapping(anim.get("ik")).items():
            k = self.keys(frames, _getter(("mix", 1), ("softness", 0)))
            if k is not None:
                flags = [{"bendPositive": f.get("bendPositive", True) is not False,
                          "compress": f.get("compress") is True, "stretch": f.get("stretch") is True}
                         for f in _dicts(frames)]
                self.out.constraints.append(ConstraintTimeline("ik", str(cname), ("mix", "softness"), k, flags))
        for cname, frames in _mapping(anim.get("transform")).items():
            spec = (_TRANSFORM_43 if self.four_three else _TRANSFORM_4) if self.four else _TRANSFORM_3
            k = self.keys(frames, _getter(*spec))
            if k is not None:
                self.out.constraints.append(ConstraintTimeline("transform", str(cname), tuple(p[0] for p in spec), k))
        for cname, tls in _mapping(anim.get("path") or anim.get("paths")).items():
            for prop, frames in tls.items() if isinstance(tls, dict) else ():
                if prop in ("position", "spacing"):
                    spec, fields = (("value" if self.four else prop, 0),), (prop,)
                elif prop == "mix":
                    spec = _PATH_MIX_4 if self.four else _PATH_MIX_3
                    fields = tuple(p[0] for p in spec)
                else:
                    continue
                k = self.keys(frames, _getter(*spec))
                if k is not None:
                    self.out.constraints.append(ConstraintTimeline("path", str(cname), fields, k))

    def sliders(self, timelines: dict) -> None:
        """4.3: a slider's ``time`` and ``mix`` (a key without a value: 1)."""
        for cname, tls in timelines.items():
            for prop, frames in tls.items() if isinstance(tls, dict) else ():
                if prop in ("time", "mix"):
                    k = self.keys(frames, _getter(("value", 1)))
                    if k is not None:
                        self.out.constraints.append(ConstraintTimeline("slider", str(cname), (prop,), k))

    def physics(self, timelines: dict) -> None:
        """4.2 and 4.3: physics values (a constraint's name, or "" for every constraint whose
        ``<value>Global`` is set) and resets."""
        for cname, tls in timelines.items():
            for prop, frames in tls.items() if isinstance(tls, dict) else ():
                if prop == "reset":
                    _, times = self.discrete(frames)
                    if len(times):
                        self.out.physics_resets.append((str(cname), times))
                elif prop in _PHYSICS_VALUES:
                    default = 1 if prop == "mix" and self.four_three else _PHYSICS_VALUES[prop]
                    k = self.keys(frames, _getter(("value", default)))
                    if k is not None:
                        self.out.constraints.append(ConstraintTimeline("physics", str(cname), (prop,), k))


#: Physics timelines and the JSON default of their values (4.3: ``mix`` 1).
_PHYSICS_VALUES = {"inertia": 0, "strength": 0, "damping": 0, "mass": 0, "wind": 0, "gravity": 0, "mix": 0}

_COLOR_KINDS = {"rgba": "rgba", "color": "rgba", "rgb": "rgb", "alpha": "alpha", "rgba2": "rgba2",
                "twoColor": "rgba2", "rgb2": "rgb2"}
_COLOR_GETTERS = {
    "rgba": lambda f: color_channels(f.get("color"), 4),
    "rgb": lambda f: color_channels(f.get("color"), 3),
    "alpha": _getter(("value", 0)),
    "rgba2": lambda f: color_channels(f.get("light"), 4) + color_channels(f.get("dark"), 3),
    "rgb2": lambda f: color_channels(f.get("light"), 3) + color_channels(f.get("dark"), 3),
}
_PATH_MIX_4 = (("mixRotate", 1), ("mixX", 1), ("mixY", "mixX"))
_PATH_MIX_3 = (("rotateMix", 1), ("translateMix", 1))


def read_animation(doc: dict, name: str, four: bool, spelling: CurveSpelling = CURVES_38) -> Animation:
    """The animation ``name`` of ``doc`` (KeyError when it has none), its timelines read
    (4.x layout when ``four``, else 3.x with its version's curve ``spelling``).

    Timelines that name a bone, slot or constraint the skeleton lacks are left out (a runtime
    refuses such a skeleton; the document reader reports them). The duration is the last key
    of any timeline, events and draw order included, as the runtimes compute it.
    """
    anim = (doc.get("animations") or {})[name]
    if not isinstance(anim, dict):
        anim = {}
    out = Animation(name, 0.0)
    r = _Reader(doc, four, out, spelling)
    r.bones(_mapping(anim.get("bones")))
    r.slots(_mapping(anim.get("slots")))
    r.constraints(anim)
    _read_deforms(anim, r.slot_index, four, out, r.ends, spelling)
    fr, times = r.discrete(anim.get("drawOrder", anim.get("draworder")))
    if fr:
        out.draw_order = DrawOrderTimeline(times, [f.get("offsets") for f in fr], r.slot_index)
    r.discrete(anim.get("events"))
    r.physics(_mapping(anim.get("physics")))
    r.sliders(_mapping(anim.get("slider")))
    out.duration = max(r.ends, default=0.0)
    return out


def _read_deforms(anim: dict, slot_index: dict, four: bool, out: Animation, ends: list,
                  spelling: CurveSpelling) -> None:
    """Deform (and 4.1+ sequence) timelines; the offsets are filled by :mod:`.pose`, which
    knows each attachment's vertices."""
    groups = []
    if isinstance(anim.get("attachments"), dict):   # 4.1+
        for skin, slots in anim["attachments"].items():
            for slot, atts in (slots or {}).items() if isinstance(slots, dict) else ():
                for att, tls in (atts or {}).items() if isinstance(atts, dict) else ():
                    if isinstance(tls, dict):
                        groups.append((skin, slot, att, tls.get("deform"), tls.get("sequence")))
    for key in ("deform", "ffd"):
        if isinstance(anim.get(key), dict):
            for skin, slots in anim[key].items():
                for slot, atts in (slots or {}).items() if isinstance(slots, dict) else ():
                    for att, frames in (atts or {}).items() if isinstance(atts, dict) else ():
                        groups.append((skin, slot, att, frames, None))
    for skin, slot, att, frames, seq in groups:
        if slot not in slot_index:
            continue
        fr = _dicts(frames)
        if fr:
            k = (read_keys(fr, None, four, percent=True) if four
                 else read_keys(fr, lambda f: [0.0], four, spelling=spelling))
            ends.append(k.duration)
            if k.unplayable:
                out.unplayable.append(f"deform of {skin}.{slot}.{att}: {k.unplayable}")
            raw = [(int(_number(f.get("offset", 0), 0)), f.get("vertices")) for f in fr]
            out.deforms.append(DeformTimeline(str(skin), slot_index[slot], str(att), k, raw))
        sq = _dicts(seq)
        if sq:
            times = _times(sq, four)
            out.sequences.append(SequenceTimeline(str(skin), slot_index[slot], str(att), times, sq))
            ends.append(float(times[-1]))


def _draw_order(offsets, slot_index: dict) -> list[int] | None:
    """The runtimes' draw order from a key's ``offsets`` (each slot moved by its offset, the
    others keeping their order in the gaps); None for a key without offsets (setup order).

    What the runtimes cannot read (they fail on it) is passed over, so that the order holds
    every slot once: an offset naming a slot before the one the last offset named (out of slot
    order, or named twice), and one moving its slot out of the list or onto a place another
    offset took (that slot keeps its order in the gaps)."""
    if not isinstance(offsets, list):
        return None
    count = len(slot_index)
    order = [-1] * count
    unchanged: list[int] = []
    original = 0
    for o in offsets:
        if not isinstance(o, dict) or str(o.get("slot")) not in slot_index:
            continue
        s = slot_index[str(o.get("slot"))]
        if s < original:
            continue
        while original != s:
            unchanged.append(original)
            original += 1
        at = original + int(_number(o.get("offset", 0), 0))
        if 0 <= at < count and order[at] == -1:
            order[at] = original
        else:
            unchanged.append(original)
        original += 1
    while original < count:
        unchanged.append(original)
        original += 1
    for i in range(count - 1, -1, -1):
        if order[i] == -1:
            order[i] = unchanged.pop()
    return order


