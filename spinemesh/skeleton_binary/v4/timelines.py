"""Keyframe timelines: curves, value layouts per timeline type, the typed groups."""

from __future__ import annotations

import struct

from ..enums import CURVE_BEZIER, CURVE_LINEAR, CURVE_STEPPED, INHERIT
from ..stream import colour_bytes
from ..symmetric import bend, boolean, enum, fld, index, put as _put
from .constraints import _mix_field
from .fields import _floats_struct, _same, fields, flag, floats, opt, seq
from .layout import SEQUENCE_MODE, Context, Layout


def _time(s, frame: dict) -> float:
    if s.reading:
        t = s.f32()
        _put(frame, "time", t, 0)
        return t
    return s.f32(frame.get("time", 0), what="time")


def curve(s, prev: dict, channels: int) -> int:
    """The curve byte (and bezier control points) of the segment that ends at this frame."""
    if s.reading:
        at = s.pos
        kind = s.u8()
        if kind == CURVE_STEPPED:
            prev["curve"] = "stepped"
        elif kind == CURVE_BEZIER:
            prev["curve"] = floats(s, None, 4 * channels, "bezier curve")
        elif kind != CURVE_LINEAR:
            raise s.fail(f"a curve type 0, 1 or 2, found {kind}", at)
        return kind
    cv = prev.get("curve")
    if cv is None or cv == "linear":
        return s.u8(CURVE_LINEAR)
    if cv == "stepped":
        return s.u8(CURVE_STEPPED)
    s.u8(CURVE_BEZIER)
    if not isinstance(cv, list) or len(cv) < 4 * channels:
        raise s.fail(f"a curve of {4 * channels} numbers, got {cv!r}")
    floats(s, cv[:4 * channels], 4 * channels, "bezier curve")
    return CURVE_BEZIER


def bezier_count(frames: list, channels: int) -> int:
    """Bezier segments times channels: the count the binary stores before the frames."""
    return sum(channels for f in frames[:-1] if isinstance(f.get("curve"), list))


def curve_timeline(s, frames: list | None, values, channels: int, curve_first: bool = False) -> list:
    """Frame count, bezier count, then per frame: time, ``values(s, frame)`` and, from the
    second frame on, the curve of the segment before it (before the values when
    ``curve_first``, as deform timelines have it)."""
    if s.reading:
        n = s.count(what="frame count")
        s.count(what="bezier count")
        spec = getattr(values, "spec", None)
        if spec is not None and not curve_first and hasattr(s, "plain_frames"):
            return s.plain_frames(n, spec)
        frames = []
        prev = None
        for _ in range(n):
            f = {}
            _time(s, f)
            if curve_first:
                if prev is not None:
                    curve(s, prev, channels)
                values(s, f)
            else:
                values(s, f)
                if prev is not None:
                    curve(s, prev, channels)
            frames.append(f)
            prev = f
        return frames
    s.count(len(frames))
    s.count(bezier_count(frames, channels))
    for i, f in enumerate(frames):
        _time(s, f)
        if curve_first:
            if i:
                curve(s, frames[i - 1], channels)
            values(s, f)
        else:
            values(s, f)
            if i:
                curve(s, frames[i - 1], channels)
    return frames


def _value_fn(*keys_defaults):
    def values(s, f):
        fields(s, f, keys_defaults)
    # For curve_timeline's fast path: (key, "f" for float32, default).
    values.spec = _FrameSpec(tuple((key, "f", d) for key, d in keys_defaults), len(keys_defaults))
    return values


class _FrameSpec:
    """How :meth:`_RefReader.plain_frames` reads the frames of one kind of timeline.

    ``layout`` holds ``(key, kind, default)`` per value, kind ``"f"`` for a float32 or a
    byte count for a colour; ``channels`` is the number of bezier curves per segment.
    """

    def __init__(self, layout: tuple, channels: int):
        self.layout = layout
        st = struct.Struct(">f" + "".join("f" if kind == "f" else f"{kind}s" for _, kind, _ in layout))
        self.unpack, self.size = st.unpack_from, st.size
        self.curve_unpack, self.curve_size = _floats_struct(4 * channels)
        # One float value (rotate, translatex, ...): the most common timelines.
        self.single = len(layout) == 1 and layout[0][1] == "f"
        self.key0, _, self.d0 = layout[0]


def _color_fn(*keys):
    """Colour channels as bytes: ``(key, nbytes, default)``."""
    def values(s, f):
        for key, nbytes, d in keys:
            if s.reading:
                raw = s.raw(n=nbytes, what="colour")
                _put(f, key, raw.hex(), d)
            else:
                v = f.get(key, d)
                if v is None:
                    raise s.fail(f"a {key} colour in every key of this timeline")
                v = str(v)
                try:
                    s.raw(colour_bytes(v, nbytes))
                except ValueError:
                    raise s.fail(f"a hex colour of six or eight digits for {key}, got {v!r}") from None
    # For curve_timeline's fast path: (key, byte count, default).
    values.spec = _FrameSpec(keys, sum(nbytes for _, nbytes, _ in keys))
    return values


def _alpha(s, f):
    if s.reading:
        _put(f, "value", s.u8() / 255, 0)
    else:
        s.u8(max(0, min(255, round(float(f.get("value", 0)) * 255))))


#: Slot timeline types: (JSON name, values, channels). Key colours have no default in the
#: JSON format: they are always written.
SLOT_TIMELINES = (
    ("attachment", None, 0),
    ("rgba", _color_fn(("color", 4, None)), 4),
    ("rgb", _color_fn(("color", 3, None)), 3),
    ("rgba2", _color_fn(("light", 4, None), ("dark", 3, None)), 7),
    ("rgb2", _color_fn(("light", 3, None), ("dark", 3, None)), 6),
    ("alpha", _alpha, 1),
)

_V0 = _value_fn(("value", 0))
_XY0 = _value_fn(("x", 0), ("y", 0))
#: Bone timeline types, by type byte: (JSON name, values, channels).
BONE_TIMELINES = (
    ("rotate", _V0, 1), ("translate", _XY0, 2), ("translatex", _V0, 1), ("translatey", _V0, 1),
    ("scale", _value_fn(("x", 1), ("y", 1)), 2), ("scalex", _value_fn(("value", 1)), 1),
    ("scaley", _value_fn(("value", 1)), 1), ("shear", _XY0, 2), ("shearx", _V0, 1),
    ("sheary", _V0, 1), ("inherit", None, 0),
)
_TRANSFORM_KEYS = _value_fn(("mixRotate", 1), ("mixX", 1), ("mixY", 1), ("mixScaleX", 1),
                            ("mixScaleY", 1), ("mixShearY", 1))
PATH_TIMELINES = (("position", _V0, 1), ("spacing", _V0, 1),
                  ("mix", _value_fn(("mixRotate", 1), ("mixX", 1), ("mixY", 1)), 3))
#: Physics timeline types by type byte (3 is unused).
PHYSICS_TIMELINES = {0: "inertia", 1: "strength", 2: "damping", 4: "mass", 5: "wind",
                     6: "gravity", 7: "mix", 8: "reset"}
_PHYSICS_TYPES = {v: k for k, v in PHYSICS_TIMELINES.items()}


def _transform_values(s, f):
    # JSON defaults: mixY follows mixX and mixScaleY follows mixScaleX.
    for key, d in (("mixRotate", 1), ("mixX", 1), ("mixY", None), ("mixScaleX", 1),
                   ("mixScaleY", None), ("mixShearY", 1)):
        _mix_field(s, f, key, d)


def _transform_values_43(s, f):
    # 4.3's JSON: mixY still follows mixX, but mixScaleY defaults to 1.
    for key, d in (("mixRotate", 1), ("mixX", 1), ("mixY", None), ("mixScaleX", 1),
                   ("mixScaleY", 1), ("mixShearY", 1)):
        _mix_field(s, f, key, d)


#: 4.3 slider timeline types by type byte; both values default to 1 in the JSON.
SLIDER_TIMELINES = ("time", "mix")
_V1 = _value_fn(("value", 1))


def _slider_body(s, timelines, kind):
    t = _type_byte(s, kind, SLIDER_TIMELINES, "slider")
    name = SLIDER_TIMELINES[t]
    frames = curve_timeline(s, None if s.reading else timelines[kind], _V1, 1)
    if s.reading:
        timelines[name] = frames


def _path_mix_values(s, f):
    for key, d in (("mixRotate", 1), ("mixX", 1), ("mixY", None)):
        _mix_field(s, f, key, d)


def _typed_groups(s, group: dict | None, names: list, lookup: dict, what: str, body, offset=0,
                  name_of=None) -> dict:
    """``count, (index, count, (type, ...)*)*``: the shape of slot, bone, path, physics timelines."""
    if s.reading:
        out = {}
        for _ in range(s.count(what=f"{what} timeline count")):
            tmp = {}
            index(s, tmp, "k", names, lookup, what, offset)
            timelines = out.setdefault(tmp["k"], {})
            for _ in range(s.count(what="timeline count")):
                body(s, timelines, None)
        return out
    s.count(len(group))
    for name, timelines in group.items():
        index(s, {"k": name}, "k", names, lookup, what, offset)
        s.count(len(timelines))
        for kind, frames in timelines.items():
            body(s, timelines, kind)
    return group


def _type_byte(s, kind, table_names, what):
    if s.reading:
        at = s.pos
        t = s.u8()
        if t >= len(table_names) or table_names[t] is None:
            raise s.fail(f"a {what} timeline type, found {t}", at)
        return t
    if kind not in table_names:
        raise s.fail(f"a {what} timeline ({', '.join(n for n in table_names if n)}), got {kind!r}")
    return s.u8(table_names.index(kind))


_PATH_NAMES = [t[0] for t in PATH_TIMELINES]
_PHYSICS_NAMES = [PHYSICS_TIMELINES.get(i) for i in range(9)]


def _frames_without_curves(s, frames: list | None, value) -> list:
    """A timeline whose frames do not curve: the frame count, then each frame's time and
    ``value(s, frame)`` (None: a time alone). Reading, ``frames`` is None and the frames read
    are returned; writing, ``frames`` are written and returned."""
    if s.reading:
        frames = []
        for _ in range(s.count(what="frame count")):
            f = {}
            _time(s, f)
            if value is not None:
                value(s, f)
            frames.append(f)
        return frames
    s.count(len(frames))
    for f in frames:
        _time(s, f)
        if value is not None:
            value(s, f)
    return frames


def _attachment_name(s, frame: dict) -> None:
    """An attachment key's name: a string reference; null (no attachment) is kept as None, as the
    4.0 editor's JSON writes it."""
    if s.reading:
        frame["name"] = s.string_ref()
    else:
        s.string_ref(frame.get("name"))


def _attachment_name_or_none(s, frame: dict) -> None:
    """An attachment key's name: null (no attachment) is left out, as the editors' JSON from 4.1 on
    leaves it (:attr:`.layout.Layout.null_attachment_names`); a missing name is written as null."""
    if s.reading:
        name = s.string_ref()
        if name is not None:
            frame["name"] = name
    else:
        s.string_ref(frame.get("name"))


def _inherit_mode(s, frame: dict) -> None:
    """An inherit key's mode, as its byte code."""
    enum(s, frame, "inherit", INHERIT, "normal", as_byte=True)


def _typed_body(table: tuple, what: str, uncurved: str, uncurved_value):
    """The body of one timeline of a slot's or a bone's: its type byte (an index into ``table``,
    whose rows are ``(name, values, channels)``), then its frames, with curves but for the type
    ``uncurved``, whose frames are a time and ``uncurved_value(s, frame)``."""
    names = [t[0] for t in table]

    def body(s, timelines, kind):
        name, values, channels = table[_type_byte(s, kind, names, what)]
        frames = None if s.reading else timelines[kind]
        if name == uncurved:
            frames = _frames_without_curves(s, frames, uncurved_value)
        else:
            frames = curve_timeline(s, frames, values, channels)
        if s.reading:
            timelines[name] = frames

    return body


_slot_body = _typed_body(SLOT_TIMELINES, "slot", "attachment", _attachment_name)
_slot_body_names_only = _typed_body(SLOT_TIMELINES, "slot", "attachment", _attachment_name_or_none)


def slot_body(L: Layout):
    """The slot timelines' body of layout ``L``: its attachment keys with or without a null name."""
    return _slot_body if L.null_attachment_names else _slot_body_names_only
_bone_body = _typed_body(BONE_TIMELINES, "bone", "inherit", _inherit_mode)


def _path_body(s, timelines, kind):
    t = _type_byte(s, kind, _PATH_NAMES, "path")
    name, values, channels = PATH_TIMELINES[t]
    if name == "mix":
        values = _path_mix_values
    frames = curve_timeline(s, None if s.reading else timelines[kind], values, channels)
    if s.reading:
        timelines[name] = frames


def _physics_body(s, timelines, kind, mix_values=None):
    t = _type_byte(s, kind, _PHYSICS_NAMES, "physics")
    name = PHYSICS_TIMELINES[t]
    if name == "reset":
        frames = _frames_without_curves(s, None if s.reading else timelines[kind], None)
        if s.reading:
            timelines[name] = frames
        return
    values = mix_values if name == "mix" and mix_values is not None else _V0
    frames = curve_timeline(s, None if s.reading else timelines[kind], values, 1)
    if s.reading:
        timelines[name] = frames


def _physics_body_43(s, timelines, kind):
    """4.3's JSON: a physics mix key's value defaults to 1 (4.2: 0, like the others)."""
    _physics_body(s, timelines, kind, _V1)


def ik_timeline(s, frames: list | None, c: Context) -> list:
    if not c.L.flags:
        return curve_timeline_ik40(s, frames)
    if s.reading:
        n = s.count(what="frame count")
        s.count(what="bezier count")
        frames = []
        for i in range(n):
            at = s.pos
            flags = s.u8()
            f = {}
            _time(s, f)
            if flags & 1:
                if flags & 2:
                    fld(s, f, "mix", 1)
            else:
                f["mix"] = 0
            opt(s, f, "softness", flags & 4)
            _put(f, "bendPositive", bool(flags & 8), True)
            _put(f, "compress", bool(flags & 16), False)
            _put(f, "stretch", bool(flags & 32), False)
            if i:
                prev = frames[-1]
                if flags & 64:
                    prev["curve"] = "stepped"
                elif flags & 128:
                    prev["curve"] = floats(s, None, 8, "bezier curve")
            elif flags & 192:
                raise s.fail("no curve flags on the first IK frame", at)
            frames.append(f)
        return frames
    s.count(len(frames))
    s.count(bezier_count(frames, 2))
    for i, f in enumerate(frames):
        mix = f.get("mix", 1)
        flags = (1 if not _same(mix, 0.0) else 0) | (2 if not _same(mix, 1.0) else 0) \
            | (4 if flag(f, "softness", 0) else 0) | (8 if f.get("bendPositive", True) else 0) \
            | (16 if f.get("compress") else 0) | (32 if f.get("stretch") else 0)
        cv = frames[i - 1].get("curve") if i else None
        if cv == "stepped":
            flags |= 64
        elif isinstance(cv, list):
            flags |= 128
        s.u8(flags)
        _time(s, f)
        if flags & 3 == 3:
            s.f32(mix)
        if flags & 4:
            s.f32(f.get("softness", 0))
        if flags & 128:
            if len(cv) < 8:
                raise s.fail(f"an IK curve of 8 numbers, got {cv!r}")
            floats(s, cv[:8], 8, "bezier curve")
    return frames


def curve_timeline_ik40(s, frames: list | None) -> list:
    """4.0/4.1 IK frames: time, mix, softness, then bend, compress, stretch; curve between."""
    def values(s, f):
        fld(s, f, "mix", 1)
        fld(s, f, "softness", 0)

    def tail(s, f):
        bend(s, f)
        boolean(s, f, "compress")
        boolean(s, f, "stretch")

    if s.reading:
        n = s.count(what="frame count")
        s.count(what="bezier count")
        frames = []
        for i in range(n):
            f = {}
            _time(s, f)
            values(s, f)
            if i:
                curve(s, frames[-1], 2)
            tail(s, f)
            frames.append(f)
        return frames
    s.count(len(frames))
    s.count(bezier_count(frames, 2))
    for i, f in enumerate(frames):
        _time(s, f)
        values(s, f)
        if i:
            curve(s, frames[i - 1], 2)
        tail(s, f)
    return frames


def _deform_values(s, f):
    if s.reading:
        end = s.count(what="deform length")
        if end:
            _put(f, "offset", s.varint(), 0)
            f["vertices"] = floats(s, None, end, "deform vertices")
        return
    verts = f.get("vertices")
    if not verts:
        s.count(0)
        return
    s.count(len(verts))
    s.varint(f.get("offset", 0), what="deform offset")
    floats(s, verts, len(verts), "deform vertices")


def _sequence_frames(s, frames: list | None) -> list:
    # The JSON leaves out a key's delay when it equals the previous key's.
    last = [0.0]

    def one(s, f):
        _time(s, f)
        if s.reading:
            v = s.i32()
            mode = v & 0xF
            if mode >= len(SEQUENCE_MODE):
                raise s.fail(f"a sequence mode below {len(SEQUENCE_MODE)}, found {mode}", s.pos - 4)
            _put(f, "mode", SEQUENCE_MODE[mode], "hold")
            _put(f, "index", v >> 4, 0)
        else:
            mode = f.get("mode", "hold")
            if mode not in SEQUENCE_MODE:
                raise s.fail(f"a sequence mode, got {mode!r}")
            s.i32((s.whole(f.get("index", 0), "a sequence key's index") << 4) | SEQUENCE_MODE.index(mode))
        last[0] = fld(s, f, "delay", last[0])
    return seq(s, frames, one, what="frame count")
