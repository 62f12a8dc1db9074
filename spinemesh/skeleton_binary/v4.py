"""The ``.skel`` layout of Spine 4.0, 4.1 and 4.2, declared once for reading and writing.

Every function below takes a stream ``s`` (a :class:`~.stream.SkelReader` or
:class:`~.stream.SkelWriter`) and the document node it fills (reading) or encodes
(writing). The document is the one the Spine editor's JSON export of the same version
holds: same keys, same nesting, values equal to their defaults left out.

What the three versions change is read as data from a :class:`Layout`: 4.1 added
sequences and attachment timelines; 4.2 packs optional fields behind flag bytes, adds
physics constraints, inherit timelines, a reference scale, bone icons and visibility.

Reading is done by :class:`_RefReader`, a reader with bulk methods for the hot spots
(mesh arrays, weighted vertices, timeline frames); writing by :class:`_RefWriter`.

Binary-only information
-----------------------
A few things of a ``.skel`` have no place in the editor's JSON. They are kept under the
top-level key ``"_skel"``, absent when everything is derivable, so that reading and
writing a ``.skel`` gives back the same bytes:

- ``"nonessential": false`` when the file lacks nonessential data (colours, mesh edges and
  sizes, bone icons...);
- ``"strings"`` and ``"refs"``: the shared string table and the index each string reference
  used. The editor's table may hold a string twice and in any order; the writer's own
  table (:func:`string_table`) holds each once, in order of first use;
- ``"timelines"``: per animation, the stored timeline count where it is not the one
  :func:`timeline_count` derives (never seen in the examples).

A document loaded from JSON has no ``"_skel"``; the writer then writes nonessential data
and its own string table. If a document was edited so that it uses strings the recorded
table lacks, the recorded table is dropped the same way.

Facts about the format were learnt from the Spine runtimes' ``SkeletonBinary`` and
``SkeletonJson`` loaders (spine-libgdx, branches 4.0 to 4.2); no code was taken from them.
"""

from __future__ import annotations

import base64
import math
import struct

from .stream import MAX_COUNT, MAX_STRING_BYTES, SkelReader, SkelWriter

from .enums import ATTACHMENT_TYPES, BLEND, EXTRA, INHERIT, POSITION_MODE, ROTATE_MODE  # noqa: F401

SPACING_MODE = ("length", "fixed", "percent", "proportional")
SEQUENCE_MODE = ("hold", "once", "loop", "pingpong", "onceReverse", "loopReverse", "pingpongReverse")

from .enums import CURVE_BEZIER, CURVE_LINEAR, CURVE_STEPPED  # noqa: E402,F401


class Layout:
    """What one 4.x minor version stores, as flags read by the declarations.

    Parameters
    ----------
    version : str
        The editor version from the header, e.g. ``"4.2.22"``.
    """

    def __init__(self, version: str):
        self.version = version
        self.minor = int(version.split(".")[1])
        self.flags = self.minor >= 2                 # optional fields behind flag bytes
        self.physics = self.minor >= 2
        self.reference_scale = self.minor >= 2
        self.inherit_key = "inherit" if self.minor >= 2 else "transform"
        self.names_are_refs = self.minor < 2         # skin and event names as string refs
        self.sequences = self.minor >= 1
        self.attachment_timelines = self.minor >= 1  # "attachments": deform + sequence
        self.linked_key = "timelines" if self.minor >= 1 else "deform"
        self.short_arrays = self.minor < 2           # triangles, edges as int16


def _layout(s, version: str) -> Layout:
    parts = version.split(".")
    if len(parts) < 2 or not parts[1].isdigit() or parts[0] != "4" or int(parts[1]) > 2:
        raise s.fail(f"Spine 4.0, 4.1 or 4.2, found version {version!r}", 8)
    return Layout(version)


# -- small symmetric helpers -----------------------------------------------------------

_STRUCTS: dict[int, tuple] = {}


def _floats_struct(n: int) -> tuple:
    """``(unpack_from, size)`` for ``n`` big-endian float32s, cached."""
    got = _STRUCTS.get(n)
    if got is None:
        st = struct.Struct(f">{n}f")
        got = (st.unpack_from, st.size)
        if n <= 64:  # field runs and curves; long arrays vary too much to be worth keeping
            _STRUCTS[n] = got
    return got


def _same(v, default) -> bool:
    """``v`` equals ``default`` and may be left out (keeps ``-0.0``, which packs differently)."""
    if v is None or default is None:
        return v is default
    if v != default:
        return False
    return not (isinstance(v, float) and v == 0 and math.copysign(1.0, v) < 0)


def _put(node: dict, key: str, v, default) -> None:
    """Set ``node[key] = v`` unless ``v`` is the default (the hottest helper: kept inline-fast)."""
    if v != default:
        node[key] = v
    elif v == 0 and type(v) is float and math.copysign(1.0, v) < 0:
        node[key] = v


def _to_end(node: dict, keys: tuple) -> None:
    """Move ``keys`` (those present) to the end of ``node``, in that order: the editor's
    JSON key order where it differs from the binary's field order."""
    for k in keys:
        if k in node:
            node[k] = node.pop(k)


def fields(s, node: dict, keys_defaults: tuple, order: tuple | None = None) -> None:
    """Consecutive float32 fields ``(key, default)``, read or written in one go.

    ``order``, indices into ``keys_defaults``, is the order in which a read puts them into
    ``node`` when the editor's JSON orders them differently from the binary.
    """
    n = len(keys_defaults)
    if s.reading:
        values = s.f32s(n)
        for i in order or range(n):
            key, d = keys_defaults[i]
            v = values[i]
            if v != d or (v == 0 and math.copysign(1.0, v) < 0):
                node[key] = v
    else:
        floats(s, [node.get(key, d) for key, d in keys_defaults], n, ", ".join(k for k, _ in keys_defaults))


def fld(s, node: dict, key: str, default=0.0):
    """A float32 that is always stored; left out of the document when it is ``default``."""
    if s.reading:
        v = s.f32()
        _put(node, key, v, default)
        return v
    return s.f32(node.get(key, default), what=key)


def opt(s, node: dict, key: str, present: bool, default=0.0):
    """A float32 stored only when a flag says so (4.2)."""
    if not present:
        return default
    return fld(s, node, key, default)


def flag(node: dict, key: str, default, stored_default=0.0) -> bool:
    """Writer side of a 4.2 flag bit: set when the value differs from the binary default."""
    v = node.get(key, default)
    return not _same(v, stored_default) if isinstance(v, (int, float)) else v != stored_default


def boolean(s, node: dict, key: str, default: bool = False) -> bool:
    if s.reading:
        v = s.bool()
        _put(node, key, v, default)
        return v
    return s.bool(node.get(key, default))


def color(s, node: dict, key: str, default: str | None):
    if s.reading:
        v = s.color()
        _put(node, key, v, default)
        return v
    return s.color(node.get(key, default), what=key)


def ref(s, node: dict, key: str):
    """A string-table reference; null means the key is absent."""
    if s.reading:
        v = s.string_ref()
        if v is not None:
            node[key] = v
        return v
    return s.string_ref(node.get(key))


def text(s, node: dict, key: str):
    """An inline string; null means the key is absent."""
    if s.reading:
        v = s.string()
        if v is not None:
            node[key] = v
        return v
    return s.string(node.get(key))


def index(s, node: dict, key: str, names: list, lookup: dict, what: str, offset: int = 0):
    """A varint index into ``names`` stored as the name itself in the document."""
    if s.reading:
        at = s.pos
        i = s.varint(what=what) - offset
        if not 0 <= i < len(names):
            raise s.fail(f"{what} index below {len(names)}, found {i}", at)
        node[key] = names[i]
        return names[i]
    name = node.get(key)
    if name not in lookup:
        raise s.fail(f"a known {what} for {key!r}, got {name!r}")
    s.varint(lookup[name] + offset)
    return name


def enum(s, node: dict, key: str, names: tuple, default: str, as_byte: bool = False):
    if s.reading:
        at = s.pos
        i = s.u8() if as_byte else s.varint()
        if not 0 <= i < len(names):
            raise s.fail(f"{key} between 0 and {len(names) - 1}, found {i}", at)
        _put(node, key, names[i], default)
        return names[i]
    v = node.get(key, default)
    if v not in names:
        raise s.fail(f"{key} one of {', '.join(names)}, got {v!r}")
    return s.u8(names.index(v)) if as_byte else s.varint(names.index(v))


def floats(s, values, n: int, what: str = "floats") -> list:
    """``n`` float32 values in one go (bulk arrays: vertices, uvs, deform offsets)."""
    if s.reading:
        return s.f32s(n, what)
    try:
        s.raw(struct.pack(f">{n}f", *values))
    except struct.error:
        raise s.fail(f"{n} numbers for {what}") from None
    return values


def seq(s, items: list | None, fn, *args, what: str = "count") -> list:
    """A varint count followed by that many structures."""
    if s.reading:
        out = []
        for _ in range(s.count(what=what)):
            node = {}
            fn(s, node, *args)
            out.append(node)
        return out
    s.count(len(items))
    for node in items:
        fn(s, node, *args)
    return items


def _names(items) -> tuple[list, dict]:
    names = [x.get("name") for x in items]
    lookup = {}
    for i, n in enumerate(names):
        lookup.setdefault(n, i)
    return names, lookup


class Context:
    """What the declarations need beyond their own node: the layout and name tables."""

    def __init__(self, layout: Layout, nonessential: bool):
        self.L = layout
        self.nonessential = nonessential
        self.bones = self.slots = self.ik = self.transform = self.path = self.physics = ([], {})
        self.skins = ([], {})
        self.events: list[dict] = []
        self.event_names = ([], {})
        #: 4.2 linked meshes read before their skin's name is known: (node, offset).
        self.linked: list = []


# -- skeleton header -------------------------------------------------------------------

def header(s, doc: dict, extra: dict) -> tuple[Layout, bool]:
    sk = doc.setdefault("skeleton", {}) if s.reading else doc.get("skeleton", {})
    if s.reading:
        h = s.i64(what="hash")
        sk["hash"] = base64.b64encode(struct.pack(">q", h)).decode("ascii").rstrip("=")
        version = s.string(what="version")
        if version is None:
            raise s.fail("a version string", 8)
        sk["spine"] = version
    else:
        h = sk.get("hash")
        raw = base64.b64decode(h + "=" * (-len(h) % 4)) if h else b"\0" * 8
        if len(raw) != 8:
            raise s.fail(f"an 8-byte base64 hash, got {h!r}")
        s.raw(raw)
        version = s.string(str(sk.get("spine", "")))
    layout = _layout(s, version)
    for key in ("x", "y", "width", "height"):
        if s.reading:
            sk[key] = s.f32()
        else:
            s.f32(sk.get(key, 0.0))
    if layout.reference_scale:
        fld(s, sk, "referenceScale", 100)
    nonessential = s.bool(extra.get("nonessential", True))
    if nonessential:
        fld(s, sk, "fps", 30)
        text(s, sk, "images")
        text(s, sk, "audio")
    if s.reading and not nonessential:
        extra["nonessential"] = False
    return layout, nonessential


# -- bones, slots, constraints ---------------------------------------------------------

_BONE_FIELDS = (("rotation", 0), ("x", 0), ("y", 0), ("scaleX", 1), ("scaleY", 1),
                ("shearX", 0), ("shearY", 0), ("length", 0))


def bone(s, node: dict, c: Context, i: int) -> None:
    if s.reading:
        node["name"] = s.string(what="bone name")
        if i > 0:
            index(s, node, "parent", *c.bones, "bone")
            c.bones[0].append(node["name"])
        else:
            c.bones[0].append(node["name"])
    else:
        s.string(node.get("name"))
        if i > 0:
            # A parent comes before its children: the reader knows only earlier bones.
            parent = c.bones[1].get(node.get("parent"))
            if parent is not None and parent >= i:
                raise s.fail(f"bone {node.get('name')!r} to come after its parent {node.get('parent')!r}")
            index(s, node, "parent", *c.bones, "bone")
    fields(s, node, _BONE_FIELDS, order=(7, 0, 1, 2, 3, 4, 5, 6))  # the JSON has length first
    enum(s, node, c.L.inherit_key, INHERIT, "normal", as_byte=c.L.flags)
    boolean(s, node, "skin")
    if c.nonessential:
        color(s, node, "color", "9b9b9bff")
        if c.L.flags:
            text(s, node, "icon")
            boolean(s, node, "visible", True)


def bones(s, doc: dict, c: Context) -> None:
    if s.reading:
        c.bones = ([], {})
        out = doc["bones"] = []
        for i in range(s.count(what="bone count")):
            node = {}
            bone(s, node, c, i)
            out.append(node)
        c.bones = (c.bones[0], {n: i for i, n in reversed(list(enumerate(c.bones[0])))})
    else:
        items = doc.get("bones", [])
        c.bones = _names(items)
        s.count(len(items))
        for i, node in enumerate(items):
            bone(s, node, c, i)


def slot(s, node: dict, c: Context) -> None:
    text(s, node, "name")
    index(s, node, "bone", *c.bones, "bone")
    color(s, node, "color", "ffffffff")
    if s.reading:
        dark = s.i32()
        if dark != -1:
            node["dark"] = "%06x" % (dark & 0xFFFFFF)
            if dark >> 24 & 0xFF:
                node["dark"] += "%02x" % (dark >> 24 & 0xFF)
    else:
        dark = node.get("dark")
        s.i32(-1 if dark is None else _dark_int(s, dark))
    ref(s, node, "attachment")
    enum(s, node, "blend", BLEND, "normal")
    if c.nonessential and c.L.flags:
        boolean(s, node, "visible", True)


def _dark_int(s, dark: str) -> int:
    try:
        v = int(dark[:6], 16) | (int(dark[6:8], 16) << 24 if len(dark) >= 8 else 0)
    except ValueError:
        raise s.fail(f"a hex dark colour, got {dark!r}") from None
    return v - (1 << 32) if v & 0x80000000 else v


def _bone_list(s, node: dict, c: Context, key: str = "bones") -> None:
    names, lookup = c.bones
    if s.reading:
        out = node[key] = []
        for _ in range(s.count(what="bone count")):
            at = s.pos
            i = s.varint()
            if not 0 <= i < len(names):
                raise s.fail(f"bone index below {len(names)}, found {i}", at)
            out.append(names[i])
        return
    items = node.get(key, [])
    s.count(len(items))
    for name in items:
        if name not in lookup:
            raise s.fail(f"a known bone, got {name!r}")
        s.varint(lookup[name])


def ik(s, node: dict, c: Context) -> None:
    text(s, node, "name")
    fld_int(s, node, "order")
    if not c.L.flags:
        boolean(s, node, "skin")
    _bone_list(s, node, c)
    index(s, node, "target", *c.bones, "bone")
    if not c.L.flags:
        fld(s, node, "mix", 1)
        fld(s, node, "softness", 0)
        if s.reading:
            _put(node, "bendPositive", s.i8() != -1, True)
        else:
            s.i8(1 if node.get("bendPositive", True) else -1)
        boolean(s, node, "compress")
        boolean(s, node, "stretch")
        boolean(s, node, "uniform")
        return
    value_flags = 0
    if not s.reading:
        mix = node.get("mix", 1)
        # The editor sets "mix is not 1" even when "mix is not 0" is clear (mix 0).
        value_flags = (32 if not _same(mix, 0.0) else 0) | (64 if not _same(mix, 1.0) else 0) \
            | (128 if flag(node, "softness", 0) else 0)
    flags = _flag_byte(s, node, ((1, "skin", False), (2, "bendPositive", True), (4, "compress", False),
                                 (8, "stretch", False), (16, "uniform", False)), value_flags)
    if flags & 32:
        if flags & 64:
            fld(s, node, "mix", 1)
    elif s.reading:
        node["mix"] = 0
    opt(s, node, "softness", flags & 128)
    if s.reading:
        _skin_after_order(node)


def _skin_after_order(node: dict) -> None:
    """4.2 keeps a constraint's skin flag in a flag byte after its bones; the JSON has it
    right after the order."""
    _to_end(node, tuple(k for k in node if k not in ("name", "order", "skin")))


def fld_int(s, node: dict, key: str, default: int = 0) -> int:
    if s.reading:
        v = s.varint()
        _put(node, key, v, default)
        return v
    return s.varint(node.get(key, default))


def _flag_byte(s, node: dict, bits: tuple, value_flags: int = 0) -> int:
    """A flag byte: boolean keys at the low ``bits`` masks, plus precomputed ``value_flags``."""
    if s.reading:
        flags = s.u8()
        for mask, key, d in bits:
            _put(node, key, bool(flags & mask), d)
        return flags
    flags = value_flags
    for mask, key, d in bits:
        if node.get(key, d):
            flags |= mask
    s.u8(flags)
    return flags


_TRANSFORM_1 = (("rotation", 0, 8), ("x", 0, 16), ("y", 0, 32), ("scaleX", 0, 64), ("scaleY", 0, 128))
_TRANSFORM_2 = (("shearY", 0, 1), ("mixRotate", 1, 2), ("mixX", 1, 4), ("mixY", None, 8),
                ("mixScaleX", 1, 16), ("mixScaleY", None, 32), ("mixShearY", 1, 64))


def _json_default(node: dict, key: str, d):
    """JSON default of a transform/path mix: ``mixY`` follows ``mixX``, ``mixScaleY`` ``mixScaleX``."""
    if d is not None:
        return d
    return node.get("mixX", 1) if key == "mixY" else node.get("mixScaleX", 1)


def transform(s, node: dict, c: Context) -> None:
    text(s, node, "name")
    fld_int(s, node, "order")
    if not c.L.flags:
        boolean(s, node, "skin")
    _bone_list(s, node, c)
    index(s, node, "target", *c.bones, "bone")
    if not c.L.flags:
        boolean(s, node, "local")
        boolean(s, node, "relative")
        for key, d, _ in _TRANSFORM_1 + _TRANSFORM_2:
            _mix_field(s, node, key, d)
        return
    # Two flag bytes, each followed by the floats it announces.
    for table, bools in ((_TRANSFORM_1, ((1, "skin", False), (2, "local", False), (4, "relative", False))),
                         (_TRANSFORM_2, ())):
        value_flags = 0
        if not s.reading:
            for key, d, mask in table:
                if not _same(node.get(key, _json_default(node, key, d)), 0.0):
                    value_flags |= mask
        flags = _flag_byte(s, node, bools, value_flags)
        for key, d, mask in table:
            if flags & mask:
                _mix_field(s, node, key, d)
            elif s.reading:
                _put(node, key, 0, _json_default(node, key, d))
    if s.reading:
        _skin_after_order(node)


def _mix_field(s, node: dict, key: str, d) -> None:
    if s.reading:
        v = s.f32()
        _put(node, key, v, _json_default(node, key, d))
    else:
        s.f32(node.get(key, _json_default(node, key, d)), what=key)


def path_constraint(s, node: dict, c: Context) -> None:
    text(s, node, "name")
    fld_int(s, node, "order")
    boolean(s, node, "skin")
    _bone_list(s, node, c)
    index(s, node, "target", *c.slots, "slot")
    if c.L.flags:
        if s.reading:
            flags = s.u8()
            for key, names, shift, mask, d in _PATH_MODES:
                i = flags >> shift & mask
                if i >= len(names):
                    raise s.fail(f"a valid {key}, found {i}", s.pos - 1)
                _put(node, key, names[i], d)
        else:
            flags = 0
            for key, names, shift, mask, d in _PATH_MODES:
                v = node.get(key, d)
                if v not in names:
                    raise s.fail(f"{key} one of {', '.join(names)}, got {v!r}")
                flags |= names.index(v) << shift
            if flag(node, "rotation", 0):
                flags |= 128
            s.u8(flags)
        opt(s, node, "rotation", flags & 128)
    else:
        enum(s, node, "positionMode", POSITION_MODE, "percent")
        enum(s, node, "spacingMode", SPACING_MODE, "length")
        enum(s, node, "rotateMode", ROTATE_MODE, "tangent")
        fld(s, node, "rotation", 0)
    fld(s, node, "position", 0)
    fld(s, node, "spacing", 0)
    _mix_field(s, node, "mixRotate", 1)
    _mix_field(s, node, "mixX", 1)
    _mix_field(s, node, "mixY", None)


_PATH_MODES = (("positionMode", POSITION_MODE, 0, 1, "percent"),
               ("spacingMode", SPACING_MODE, 1, 3, "length"),
               ("rotateMode", ROTATE_MODE, 3, 3, "tangent"))

_PHYSICS_1 = (("x", 0, 2), ("y", 0, 4), ("rotate", 0, 8), ("scaleX", 0, 16), ("shearX", 0, 32))
_PHYSICS_GLOBALS = ((1, "inertiaGlobal", False), (2, "strengthGlobal", False), (4, "dampingGlobal", False),
                    (8, "massGlobal", False), (16, "windGlobal", False), (32, "gravityGlobal", False),
                    (64, "mixGlobal", False))


def physics(s, node: dict, c: Context) -> None:
    text(s, node, "name")
    fld_int(s, node, "order")
    index(s, node, "bone", *c.bones, "bone")
    value_flags = 0
    if not s.reading:
        for key, d, mask in _PHYSICS_1:
            if flag(node, key, d):
                value_flags |= mask
        if flag(node, "limit", 5000, 5000.0):
            value_flags |= 64
        if flag(node, "mass", 1, 1.0):
            value_flags |= 128
    flags = _flag_byte(s, node, ((1, "skin", False),), value_flags)
    for key, d, mask in _PHYSICS_1:
        opt(s, node, key, flags & mask)
    opt(s, node, "limit", flags & 64, 5000)
    if s.reading:
        _put(node, "fps", s.u8(), 60)
    else:
        s.u8(int(node.get("fps", 60)))
    fld(s, node, "inertia", 1)
    fld(s, node, "strength", 100)
    fld(s, node, "damping", 1)
    if flags & 128:
        # The binary keeps the inverse of the mass that the JSON holds.
        if s.reading:
            inv = s.f32()
            _put(node, "mass", 1 / inv if inv else math.inf, 1)
        else:
            s.f32(1 / node.get("mass", 1))
    fld(s, node, "wind", 0)
    fld(s, node, "gravity", 0)
    value_flags = 0 if s.reading else (128 if flag(node, "mix", 1, 1.0) else 0)
    flags = _flag_byte(s, node, _PHYSICS_GLOBALS, value_flags)
    opt(s, node, "mix", flags & 128, 1)


# -- attachments -----------------------------------------------------------------------

def sequence(s, node: dict, present: bool) -> None:
    if not present:
        return
    sq = node.setdefault("sequence", {}) if s.reading else node["sequence"]
    fld_int(s, sq, "count", -1)
    fld_int(s, sq, "start", 1)
    fld_int(s, sq, "digits", 0)
    fld_int(s, sq, "setup", 0)


def vertices(s, node: dict, weighted: bool | None, c: Context, count_key: str | None = "vertexCount",
             n: int | None = None) -> int:
    """Vertex count, then plain ``x, y`` pairs or, when weighted, per vertex
    ``boneCount, (bone, x, y, weight) * boneCount``: the JSON's ``vertices`` layout.

    ``weighted`` is ``None`` for 4.0/4.1, where a boolean before the data says it. ``n``
    is the vertex count when it came earlier (4.0/4.1 meshes store it before the uvs).
    Returns the vertex count.
    """
    counted = n is not None
    if s.reading:
        if not counted:
            n = s.count(what="vertex count")
        if count_key:
            node[count_key] = n
        if weighted is None:
            weighted = s.bool()
        if not weighted:
            node["vertices"] = floats(s, None, 2 * n, "vertices")
        else:
            node["vertices"] = s.weighted(None, n, len(c.bones[0]))
        return n
    verts = node.get("vertices", [])
    if not counted:
        n = _vertex_count(node, count_key)
        s.count(n)
    is_weighted = len(verts) != 2 * n
    if weighted is None:
        s.bool(is_weighted)
    if not is_weighted:
        floats(s, verts, 2 * n, "vertices")
    else:
        s.weighted(verts, n, len(c.bones[0]))
    return n


def _vertex_count(node: dict, count_key: str | None) -> int:
    if count_key and count_key in node:
        return int(node[count_key])
    if "uvs" in node:
        return len(node["uvs"]) // 2
    return len(node.get("vertices", [])) // 2


def _weighted(node: dict, count_key: str | None) -> bool:
    return len(node.get("vertices", [])) != 2 * _vertex_count(node, count_key)


def shorts(s, node: dict, key: str, n: int | None, c: Context) -> None:
    """Triangles or edges: int16s after a count (4.0/4.1), varints of a known count (4.2)."""
    if s.reading:
        if c.L.short_arrays:
            n = s.count(what=f"{key} count")
            node[key] = list(struct.unpack(f">{n}h", s.raw(n=2 * n, what=key)))
        else:
            if n is None:
                n = s.count(what=f"{key} count")
            if n < 0:
                raise s.fail(f"a mesh with at least 3 vertices, found {n // 3} {key}")
            node[key] = s.varints(None, n, key)
        return
    items = node.get(key, [])
    if c.L.short_arrays:
        s.count(len(items))
        try:
            s.raw(struct.pack(f">{len(items)}h", *items))
        except struct.error:
            raise s.fail(f"16-bit {key}") from None
        return
    if n is None:
        s.count(len(items))
    elif n != len(items):
        raise s.fail(f"{n} {key} indices for this mesh (2 * vertices - hull - 2 triangles), got {len(items)}")
    s.varints(items, n)


_REGION_FIELDS = (("rotation", 0), ("x", 0), ("y", 0), ("scaleX", 1), ("scaleY", 1),
                  ("width", 0), ("height", 0))




def attachment(s, node: dict, key: str, c: Context) -> None:
    if c.L.flags:
        attachment_42(s, node, key, c)
    else:
        attachment_40(s, node, key, c)


def _type_of(s, node: dict) -> int:
    t = node.get("type", "region")
    if t not in ATTACHMENT_TYPES:
        raise s.fail(f"an attachment type ({', '.join(ATTACHMENT_TYPES)}), got {t!r}")
    return ATTACHMENT_TYPES.index(t)


def attachment_42(s, node: dict, key: str, c: Context) -> None:
    if s.reading:
        at = s.pos
        flags = s.u8()
        t = flags & 7
        if t >= len(ATTACHMENT_TYPES):
            raise s.fail(f"an attachment type below {len(ATTACHMENT_TYPES)}, found {t}", at)
        if t:
            node["type"] = ATTACHMENT_TYPES[t]
    else:
        t = _type_of(s, node)
        flags = t | (8 if node.get("name", key) != key else 0)
        kind = ATTACHMENT_TYPES[t]
        if kind in ("region", "mesh", "linkedmesh"):
            flags |= (16 if node.get("path", node.get("name", key)) != node.get("name", key) else 0) \
                | (32 if node.get("color", "ffffffff") != "ffffffff" else 0) \
                | (64 if node.get("sequence") is not None else 0)
            if kind == "region" and flag(node, "rotation", 0):
                flags |= 128
            if kind == "mesh" and _weighted(node, None):
                flags |= 128
            if kind == "linkedmesh" and node.get("timelines", True):
                flags |= 128
        elif kind == "path":
            flags |= (16 if node.get("closed") else 0) | (32 if node.get("constantSpeed", True) else 0) \
                | (64 if _weighted(node, "vertexCount") else 0)
        elif kind in ("boundingbox", "clipping") and _weighted(node, "vertexCount"):
            flags |= 16
        s.u8(flags)
    if flags & 8:
        ref(s, node, "name")
    kind = ATTACHMENT_TYPES[t]
    if kind == "region":
        if flags & 16:
            ref(s, node, "path")
        if flags & 32:
            color(s, node, "color", None)
        sequence(s, node, flags & 64)
        opt(s, node, "rotation", flags & 128)
        fields(s, node, _REGION_FIELDS[1:])
        if s.reading:
            _to_end(node, ("rotation", "width", "height", "sequence"))
    elif kind == "boundingbox":
        vertices(s, node, bool(flags & 16), c)
        if c.nonessential:
            color(s, node, "color", "60f000ff")
    elif kind == "mesh":
        if flags & 16:
            ref(s, node, "path")
        if flags & 32:
            color(s, node, "color", None)
        sequence(s, node, flags & 64)
        hull = fld_int(s, node, "hull", None)
        n = vertices(s, node, bool(flags & 128), c, count_key=None)
        if s.reading:
            uvs = floats(s, None, 2 * n, "uvs")
            # Key order of the editor's export: uvs, triangles, vertices, hull.
            verts = node.pop("vertices")
            h = node.pop("hull", None)
            node["uvs"] = uvs
            shorts(s, node, "triangles", (2 * n - hull - 2) * 3, c)
            node["vertices"] = verts
            if h is not None:
                node["hull"] = h
        else:
            floats(s, node.get("uvs", []), 2 * n, "uvs")
            shorts(s, node, "triangles", (2 * n - int(hull) - 2) * 3, c)
        if c.nonessential:
            shorts(s, node, "edges", None, c)
            fld(s, node, "width", 0)
            fld(s, node, "height", 0)
    elif kind == "linkedmesh":
        if flags & 16:
            ref(s, node, "path")
        if flags & 32:
            color(s, node, "color", None)
        sequence(s, node, flags & 64)
        if s.reading and not flags & 128:
            node["timelines"] = False
        if s.reading:
            # The skin may come later in the file: resolved once every skin is read.
            at = s.pos
            node["skin"] = s.varint()
            c.linked.append((node, at))
        else:
            tmp = {"skin": node.get("skin", "default")}
            index(s, tmp, "skin", *c.skins, "skin")
        ref(s, node, "parent")
        if c.nonessential:
            fld(s, node, "width", 0)
            fld(s, node, "height", 0)
    elif kind == "path":
        if s.reading:
            _put(node, "closed", bool(flags & 16), False)
            _put(node, "constantSpeed", bool(flags & 32), True)
        n = vertices(s, node, bool(flags & 64), c)
        node_lengths(s, node, n)
        if c.nonessential:
            color(s, node, "color", "ff7f00ff")
        if s.reading:
            _to_end(node, ("vertexCount", "vertices", "color"))  # the JSON has lengths first
    elif kind == "point":
        point(s, node, c)
    elif kind == "clipping":
        index(s, node, "end", *c.slots, "slot")
        vertices(s, node, bool(flags & 16), c)
        if c.nonessential:
            color(s, node, "color", "ce3a3aff")


def node_lengths(s, node: dict, n: int) -> None:
    if s.reading:
        node["lengths"] = floats(s, None, n // 3, "path lengths")
    else:
        floats(s, node.get("lengths", []), n // 3, "path lengths")


def point(s, node: dict, c: Context) -> None:
    fld(s, node, "rotation", 0)
    fld(s, node, "x", 0)
    fld(s, node, "y", 0)
    if c.nonessential:
        color(s, node, "color", "f1f100ff")


def attachment_40(s, node: dict, key: str, c: Context) -> None:
    L = c.L
    ref(s, node, "name")
    if s.reading:
        at = s.pos
        t = s.u8()
        if t >= len(ATTACHMENT_TYPES):
            raise s.fail(f"an attachment type below {len(ATTACHMENT_TYPES)}, found {t}", at)
        if t:
            node["type"] = ATTACHMENT_TYPES[t]
    else:
        t = s.u8(_type_of(s, node))
    kind = ATTACHMENT_TYPES[t]
    if kind == "region":
        ref(s, node, "path")
        fields(s, node, _REGION_FIELDS, order=(1, 2, 3, 4, 0, 5, 6))
        color(s, node, "color", "ffffffff")
        _sequence_40(s, node, L)
        if s.reading:
            # The JSON has the colour before the geometry.
            _to_end(node, ("x", "y", "scaleX", "scaleY", "rotation", "width", "height", "sequence"))
    elif kind == "boundingbox":
        vertices(s, node, None, c)
        if c.nonessential:
            color(s, node, "color", "60f000ff")
    elif kind == "mesh":
        ref(s, node, "path")
        color(s, node, "color", "ffffffff")
        if s.reading:
            n = s.count(what="vertex count")
            node["uvs"] = floats(s, None, 2 * n, "uvs")
            shorts(s, node, "triangles", None, c)
        else:
            n = s.count(_vertex_count(node, None))
            floats(s, node.get("uvs", []), 2 * n, "uvs")
            shorts(s, node, "triangles", None, c)
        vertices(s, node, None, c, count_key=None, n=n)
        fld_int(s, node, "hull", None)
        _sequence_40(s, node, L)
        if c.nonessential:
            shorts(s, node, "edges", None, c)
            fld(s, node, "width", 0)
            fld(s, node, "height", 0)
    elif kind == "linkedmesh":
        ref(s, node, "path")
        color(s, node, "color", "ffffffff")
        ref(s, node, "skin")
        ref(s, node, "parent")
        boolean(s, node, L.linked_key, True)
        _sequence_40(s, node, L)
        if c.nonessential:
            fld(s, node, "width", 0)
            fld(s, node, "height", 0)
    elif kind == "path":
        boolean(s, node, "closed", False)
        boolean(s, node, "constantSpeed", True)
        n = vertices(s, node, None, c)
        node_lengths(s, node, n)
        if c.nonessential:
            color(s, node, "color", "ff7f00ff")
    elif kind == "point":
        point(s, node, c)
    elif kind == "clipping":
        index(s, node, "end", *c.slots, "slot")
        vertices(s, node, None, c)
        if c.nonessential:
            color(s, node, "color", "ce3a3aff")


def _sequence_40(s, node: dict, L: Layout) -> None:
    if not L.sequences:
        return
    present = s.bool(node.get("sequence") is not None)
    sequence(s, node, present)


# -- skins -----------------------------------------------------------------------------

def skin_attachments(s, skin: dict, c: Context, nslots: int | None = None) -> None:
    names, lookup = c.slots
    if s.reading:
        atts = {}
        for _ in range(nslots):
            at = s.pos
            i = s.varint()
            if not 0 <= i < len(names):
                raise s.fail(f"slot index below {len(names)}, found {i}", at)
            slot_atts = atts.setdefault(names[i], {})
            for _ in range(s.count(what="attachment count")):
                key = s.string_ref()
                if key is None:
                    raise s.fail("an attachment name", s.pos - 1)
                node = {}
                attachment(s, node, key, c)
                slot_atts[key] = node
        if atts:
            skin["attachments"] = atts
        return
    for slot_name, slot_atts in skin.get("attachments", {}).items():
        if slot_name not in lookup:
            raise s.fail(f"a known slot in skin {skin.get('name')!r}, got {slot_name!r}")
        s.varint(lookup[slot_name])
        s.count(len(slot_atts))
        for key, node in slot_atts.items():
            s.string_ref(key)
            attachment(s, node, key, c)


def _constraint_names(s, skin: dict, key: str, table: tuple) -> None:
    names, lookup = table
    if s.reading:
        n = s.count(what=f"skin {key} count")
        if n:
            out = skin[key] = []
            for _ in range(n):
                at = s.pos
                i = s.varint()
                if not 0 <= i < len(names):
                    raise s.fail(f"{key} index below {len(names)}, found {i}", at)
                out.append(names[i])
        return
    items = skin.get(key, [])
    s.count(len(items))
    for name in items:
        if name not in lookup:
            raise s.fail(f"a known {key} constraint, got {name!r}")
        s.varint(lookup[name])


def skin(s, node: dict, c: Context) -> None:
    if c.L.names_are_refs:
        ref(s, node, "name")
    else:
        text(s, node, "name")
    if c.nonessential and c.L.flags:
        color(s, node, "color", "fe9e4fff")
    _bone_list(s, node, c)
    if s.reading and not node["bones"]:
        del node["bones"]
    _constraint_names(s, node, "ik", c.ik)
    _constraint_names(s, node, "transform", c.transform)
    _constraint_names(s, node, "path", c.path)
    if c.L.physics:
        _constraint_names(s, node, "physics", c.physics)
    nslots = s.count(len(node.get("attachments", {})), what="skin slot count")
    skin_attachments(s, node, c, nslots)


def skins(s, doc: dict, c: Context) -> None:
    if s.reading:
        out = doc["skins"] = []
        nslots = s.count(what="default skin slot count")
        if nslots:
            default = {"name": "default"}
            skin_attachments(s, default, c, nslots)
            out.append(default)
        out.extend(seq(s, None, skin, c, what="skin count"))
        return
    items = _written_skins(doc)
    default = items[0] if items and items[0].get("name") == "default" else None
    if default is None:
        s.count(0)
    else:
        s.count(len(default.get("attachments", {})))
        skin_attachments(s, default, c)
    seq(s, items[1:] if default is not None else items, skin, c)


def _written_skins(doc: dict) -> list:
    """The skins as the binary has them: a default skin without attachments has no place
    there (its slot count 0 means "no default skin"), and skin indices skip it."""
    items = doc.get("skins", [])
    if items and items[0].get("name") == "default" and not items[0].get("attachments"):
        return items[1:]
    return items


# -- events ----------------------------------------------------------------------------

def event(s, node: dict, c: Context) -> None:
    # Events are a JSON object keyed by name; the list form here is turned into it later.
    if c.L.names_are_refs:
        ref(s, node, "name")
    else:
        text(s, node, "name")
    if s.reading:
        _put(node, "int", s.varint(positive=False), 0)
    else:
        s.varint(int(node.get("int", 0)), positive=False)
    fld(s, node, "float", 0)
    text(s, node, "string")
    text(s, node, "audio")
    if node.get("audio") is not None:
        fld(s, node, "volume", 1)
        fld(s, node, "balance", 0)


# -- timelines -------------------------------------------------------------------------

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
                    s.raw(bytes.fromhex(v[:2 * nbytes].ljust(2 * nbytes, "f")))
                except ValueError:
                    raise s.fail(f"a hex colour for {key}, got {v!r}") from None
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


_SLOT_NAMES = [t[0] for t in SLOT_TIMELINES]
_BONE_NAMES = [t[0] for t in BONE_TIMELINES]
_PATH_NAMES = [t[0] for t in PATH_TIMELINES]
_PHYSICS_NAMES = [PHYSICS_TIMELINES.get(i) for i in range(9)]


def _slot_body(s, timelines, kind):
    t = _type_byte(s, kind, _SLOT_NAMES, "slot")
    name, values, channels = SLOT_TIMELINES[t]
    frames = None if s.reading else timelines[kind]
    if name == "attachment":
        if s.reading:
            frames = []
            for _ in range(s.count(what="frame count")):
                f = {}
                _time(s, f)
                f["name"] = s.string_ref()
                frames.append(f)
        else:
            s.count(len(frames))
            for f in frames:
                _time(s, f)
                s.string_ref(f.get("name"))
    else:
        frames = curve_timeline(s, frames, values, channels)
    if s.reading:
        timelines[name] = frames


def _bone_body(s, timelines, kind):
    t = _type_byte(s, kind, _BONE_NAMES, "bone")
    name, values, channels = BONE_TIMELINES[t]
    frames = None if s.reading else timelines[kind]
    if name == "inherit":
        if s.reading:
            frames = []
            for _ in range(s.count(what="frame count")):
                f = {}
                _time(s, f)
                enum(s, f, "inherit", INHERIT, "normal", as_byte=True)
                frames.append(f)
        else:
            s.count(len(frames))
            for f in frames:
                _time(s, f)
                enum(s, f, "inherit", INHERIT, "normal", as_byte=True)
    else:
        frames = curve_timeline(s, frames, values, channels)
    if s.reading:
        timelines[name] = frames


def _path_body(s, timelines, kind):
    t = _type_byte(s, kind, _PATH_NAMES, "path")
    name, values, channels = PATH_TIMELINES[t]
    if name == "mix":
        values = _path_mix_values
    frames = curve_timeline(s, None if s.reading else timelines[kind], values, channels)
    if s.reading:
        timelines[name] = frames


def _physics_body(s, timelines, kind):
    t = _type_byte(s, kind, _PHYSICS_NAMES, "physics")
    name = PHYSICS_TIMELINES[t]
    if name == "reset":
        if s.reading:
            frames = []
            for _ in range(s.count(what="frame count")):
                f = {}
                _time(s, f)
                frames.append(f)
            timelines[name] = frames
        else:
            frames = timelines[kind]
            s.count(len(frames))
            for f in frames:
                _time(s, f)
        return
    frames = curve_timeline(s, None if s.reading else timelines[kind], _V0, 1)
    if s.reading:
        timelines[name] = frames


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
        if s.reading:
            _put(f, "bendPositive", s.i8() != -1, True)
        else:
            s.i8(1 if f.get("bendPositive", True) else -1)
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
    s.varint(int(f.get("offset", 0)))
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
            s.i32((int(f.get("index", 0)) << 4) | SEQUENCE_MODE.index(mode))
        last[0] = fld(s, f, "delay", last[0])
    return seq(s, frames, one, what="frame count")


def attachment_timelines(s, anim: dict, c: Context) -> None:
    """Deform (4.0: ``"deform"``) and sequence timelines (4.1+: ``"attachments"``), by skin, slot, attachment."""
    key = "attachments" if c.L.attachment_timelines else "deform"
    skin_names, skin_lookup = c.skins
    slot_names, slot_lookup = c.slots
    if s.reading:
        n = s.count(what="skin count")
        if not n:
            return
        out = anim[key] = {}
        for _ in range(n):
            tmp = {}
            index(s, tmp, "k", skin_names, skin_lookup, "skin")
            by_slot = out.setdefault(tmp["k"], {})
            for _ in range(s.count(what="slot count")):
                index(s, tmp, "k", slot_names, slot_lookup, "slot")
                by_att = by_slot.setdefault(tmp["k"], {})
                for _ in range(s.count(what="attachment count")):
                    name = s.string_ref()
                    if c.L.attachment_timelines:
                        at = s.pos
                        t = s.u8()
                        holder = by_att.setdefault(name, {})
                        if t == 0:
                            holder["deform"] = curve_timeline(s, None, _deform_values, 1, curve_first=True)
                        elif t == 1:
                            holder["sequence"] = _sequence_frames(s, None)
                        else:
                            raise s.fail(f"an attachment timeline type 0 or 1, found {t}", at)
                    else:
                        by_att[name] = curve_timeline(s, None, _deform_values, 1, curve_first=True)
        return
    group = anim.get(key, {})
    s.count(len(group))
    for skin_name, by_slot in group.items():
        index(s, {"k": skin_name}, "k", skin_names, skin_lookup, "skin")
        s.count(len(by_slot))
        for slot_name, by_att in by_slot.items():
            index(s, {"k": slot_name}, "k", slot_names, slot_lookup, "slot")
            if c.L.attachment_timelines:
                s.count(sum(len(h) for h in by_att.values()))
                for name, holder in by_att.items():
                    for kind, frames in holder.items():
                        s.string_ref(name)
                        if kind == "deform":
                            s.u8(0)
                            curve_timeline(s, frames, _deform_values, 1, curve_first=True)
                        elif kind == "sequence":
                            s.u8(1)
                            _sequence_frames(s, frames)
                        else:
                            raise s.fail(f"a deform or sequence timeline, got {kind!r}")
            else:
                s.count(len(by_att))
                for name, frames in by_att.items():
                    s.string_ref(name)
                    curve_timeline(s, frames, _deform_values, 1, curve_first=True)


def draw_order(s, anim: dict, c: Context) -> None:
    names, lookup = c.slots
    if s.reading:
        n = s.count(what="draw order count")
        if not n:
            return
        frames = anim["drawOrder"] = []
        for _ in range(n):
            f = {}
            _time(s, f)
            k = s.count(what="offset count")
            if k:
                offsets = f["offsets"] = []
                for _ in range(k):
                    o = {}
                    index(s, o, "slot", names, lookup, "slot")
                    o["offset"] = s.varint()
                    offsets.append(o)
            frames.append(f)
        return
    frames = anim.get("drawOrder", anim.get("draworder", []))
    s.count(len(frames))
    for f in frames:
        _time(s, f)
        offsets = f.get("offsets") or []
        s.count(len(offsets))
        for o in offsets:
            index(s, o, "slot", names, lookup, "slot")
            s.varint(int(o.get("offset", 0)))


def events_timeline(s, anim: dict, c: Context) -> None:
    names, lookup = c.event_names
    if s.reading:
        n = s.count(what="event count")
        if not n:
            return
        frames = anim["events"] = []
        for _ in range(n):
            f = {}
            _time(s, f)
            index(s, f, "name", names, lookup, "event")
            data = c.events[lookup[f["name"]]]
            _event_key(s, f, data, c)
            frames.append(f)
        return
    frames = anim.get("events", [])
    s.count(len(frames))
    for f in frames:
        _time(s, f)
        index(s, f, "name", names, lookup, "event")
        _event_key(s, f, c.events[lookup[f["name"]]], c)


def _event_key(s, f: dict, data: dict, c: Context) -> None:
    # A key's values default to its event's; the JSON leaves out equal ones.
    if s.reading:
        _put(f, "int", s.varint(positive=False), data.get("int", 0))
    else:
        s.varint(int(f.get("int", data.get("int", 0))), positive=False)
    fld(s, f, "float", data.get("float", 0))
    if c.L.flags:
        text(s, f, "string")
    elif s.bool("string" in f):
        text(s, f, "string")
    if data.get("audio") is not None:
        fld(s, f, "volume", data.get("volume", 1))
        fld(s, f, "balance", data.get("balance", 0))


def timeline_count(anim: dict, L: Layout) -> int:
    """How many runtime timelines an animation makes: the count stored before it."""
    n = 0
    for group in ("slots", "bones", "path", "physics"):
        for timelines in anim.get(group, {}).values():
            n += len(timelines)
    n += len(anim.get("ik", {})) + len(anim.get("transform", {}))
    if L.attachment_timelines:
        for by_slot in anim.get("attachments", {}).values():
            for by_att in by_slot.values():
                n += sum(len(h) for h in by_att.values())
    else:
        for by_slot in anim.get("deform", {}).values():
            for by_att in by_slot.values():
                n += len(by_att)
    n += 1 if anim.get("drawOrder") else 0
    n += 1 if anim.get("events") else 0
    return n


def animation(s, anim: dict, c: Context, extra_counts: dict, name: str) -> None:
    if s.reading:
        count = s.count(what="timeline count")
    else:
        count = s.count(extra_counts.get(name, timeline_count(anim, c.L)))
    for key, names_lookup, body, offset in (
            ("slots", c.slots, _slot_body, 0), ("bones", c.bones, _bone_body, 0)):
        got = _typed_groups(s, None if s.reading else anim.get(key, {}), *names_lookup, key[:-1], body, offset)
        if s.reading and got:
            anim[key] = got
    # IK and transform constraints: one timeline each.
    for key, table in (("ik", c.ik), ("transform", c.transform)):
        names, lookup = table
        if s.reading:
            n = s.count(what=f"{key} timeline count")
            if n:
                out = anim[key] = {}
                for _ in range(n):
                    tmp = {}
                    index(s, tmp, "k", names, lookup, key)
                    if key == "ik":
                        out[tmp["k"]] = ik_timeline(s, None, c)
                    else:
                        out[tmp["k"]] = curve_timeline(s, None, _transform_values, 6)
        else:
            group = anim.get(key, {})
            s.count(len(group))
            for cname, frames in group.items():
                index(s, {"k": cname}, "k", names, lookup, key)
                if key == "ik":
                    ik_timeline(s, frames, c)
                else:
                    curve_timeline(s, frames, _transform_values, 6)
    got = _typed_groups(s, None if s.reading else anim.get("path", {}), *c.path, "path", _path_body)
    if s.reading and got:
        anim["path"] = got
    if c.L.physics:
        # Index 0 means every physics constraint: the JSON's "" key.
        names = [""] + c.physics[0]
        lookup = {n: i for i, n in reversed(list(enumerate(names)))}
        got = _typed_groups(s, None if s.reading else anim.get("physics", {}), names, lookup,
                            "physics", _physics_body)
        if s.reading and got:
            anim["physics"] = got
    attachment_timelines(s, anim, c)
    draw_order(s, anim, c)
    events_timeline(s, anim, c)
    if s.reading and count != timeline_count(anim, c.L):
        extra_counts[name] = count


# -- the whole file --------------------------------------------------------------------

def _constraints(s, doc: dict, key: str, fn, c: Context) -> tuple:
    if s.reading:
        items = seq(s, None, fn, c, what=f"{key} count")
        if items:
            doc[key] = items
        return _names(items)
    items = doc.get(key, [])
    seq(s, items, fn, c)
    return _names(items)


def skeleton(s, doc: dict) -> dict:
    extra = {} if s.reading else dict(doc.get(EXTRA, {}))
    L, nonessential = header(s, doc, extra)
    c = Context(L, nonessential)
    # The shared string table.
    if s.reading:
        s.strings = [s.string() for _ in range(s.count(what="string count"))]
        if any(x is None for x in s.strings):
            raise s.fail("non-null strings in the string table")
    else:
        strings = extra.get("strings")
        derived = string_table(doc, L)
        if strings is None or not set(derived) <= set(strings):
            # No recorded table, or the document now uses strings it lacks.
            strings = derived
            s.refs = []
        s.set_strings(strings)
        s.count(len(strings))
        for x in strings:
            s.string(x)
    bones(s, doc, c)
    if s.reading:
        items = seq(s, None, slot, c, what="slot count")
        doc["slots"] = items
        c.slots = _names(items)
    else:
        c.slots = _names(doc.get("slots", []))
        seq(s, doc.get("slots", []), slot, c)
    c.ik = _constraints(s, doc, "ik", ik, c)
    c.transform = _constraints(s, doc, "transform", transform, c)
    c.path = _constraints(s, doc, "path", path_constraint, c)
    if L.physics:
        c.physics = _constraints(s, doc, "physics", physics, c)
    if s.reading:
        skins(s, doc, c)
        c.skins = _names(doc["skins"])
        for node, at in c.linked:
            i = node["skin"]
            if not 0 <= i < len(c.skins[0]):
                raise s.fail(f"skin index below {len(c.skins[0])}, found {i}", at)
            node["skin"] = c.skins[0][i]
            if node["skin"] == "default":
                del node["skin"]
    else:
        c.skins = _names(_written_skins(doc))
        skins(s, doc, c)
    # Events: a list in the binary, a name-keyed object in the JSON.
    if s.reading:
        items = seq(s, None, event, c, what="event count")
        c.events = items
        c.event_names = _names(items)
        if items:
            doc["events"] = {e.pop("name", ""): e for e in items}
            for e, name in zip(items, c.event_names[0]):
                e["name"] = name
    else:
        evs = doc.get("events", {})
        items = [dict(v, name=k) for k, v in evs.items()]
        c.events = items
        c.event_names = _names(items)
        seq(s, items, event, c)
    counts = {} if s.reading else extra.get("timelines", {})
    if s.reading:
        anims = {}
        for _ in range(s.count(what="animation count")):
            name = s.string(what="animation name")
            anim = {}
            animation(s, anim, c, counts, name)
            anims[name] = anim
        doc["animations"] = anims
        for e in c.events:
            e.pop("name", None)
        if counts:
            extra["timelines"] = counts
        if not s.at_end:
            raise s.fail(f"end of file, found {len(s.data) - s.pos} more bytes")
        refs = getattr(s, "refs", [])
        if not _derivable(s.strings, refs):
            extra["strings"] = list(s.strings)
            extra["refs"] = list(refs)
        if extra:
            doc[EXTRA] = extra
    else:
        anims = doc.get("animations", {})
        s.count(len(anims))
        for name, anim in anims.items():
            s.string(name)
            animation(s, anim, c, counts, name)
    return doc


def _derivable(strings: list[str], refs: list[int]) -> bool:
    """Whether the writer's own string table (:func:`string_table`) gives these bytes.

    It does when the table has no duplicate and the references, in file order, first use
    index 1, then 2, and so on: the writer numbers strings in the order it first writes
    them, which is the reader's order.
    """
    if len(set(strings)) != len(strings):
        return False
    expected = 1
    for k in refs:
        if k == expected:
            expected += 1
        elif k > expected:
            return False
    return expected - 1 == len(strings)


def string_table(doc: dict, L: Layout) -> list[str]:
    """The string table the editor writes: every string-table value once, in first use order."""
    seen: dict[str, None] = {}

    def add(v):
        if v is not None and v not in seen:
            seen[v] = None

    for sl in doc.get("slots", []):
        add(sl.get("attachment"))
    for sk in doc.get("skins", []):
        if L.names_are_refs and sk.get("name") != "default":
            add(sk.get("name"))
        for slot_atts in sk.get("attachments", {}).values():
            for key, att in slot_atts.items():
                add(key)
                add(att.get("name"))
                add(att.get("path"))
                if att.get("type") == "linkedmesh":
                    if L.names_are_refs:
                        add(att.get("skin"))
                    add(att.get("parent"))
    if L.names_are_refs:
        for name in doc.get("events", {}):
            add(name)
    for anim in doc.get("animations", {}).values():
        for timelines in anim.get("slots", {}).values():
            for f in timelines.get("attachment", []):
                add(f.get("name"))
        group = anim.get("attachments", anim.get("deform", {}))
        for by_slot in group.values():
            for by_att in by_slot.values():
                for name in by_att:
                    add(name)
    return list(seen)


_F32 = struct.Struct(">f")
_I32 = struct.Struct(">i")
class _RefReader(SkelReader):
    """A reader that also records which table index every string reference used.

    The editor's string table may hold a string more than once and references pick any
    copy, so the indices themselves are needed to write the same bytes again.

    It also reads the hottest primitives straight from a ``bytes`` copy of the file and
    adds bulk reads (:meth:`varints`, :meth:`weighted`): meshes are most of a file.
    """

    def __init__(self, data, path=None):
        super().__init__(data, path)
        self.buf = bytes(self.data)
        self.end = len(self.buf)
        self.refs: list[int] = []

    def _eof(self, what: str):
        return self.fail(f"{what}, found end of file after {len(self.buf) - self.pos} bytes")

    def u8(self, value=None, what: str = "byte") -> int:
        pos = self.pos
        try:
            b = self.buf[pos]
        except IndexError:
            raise self._eof(what) from None
        self.pos = pos + 1
        return b

    def bool(self, value=None, what: str = "boolean") -> bool:
        return self.u8(what=what) != 0

    def raw(self, value=None, n: int = 0, what: str = "bytes") -> bytes:
        pos = self.pos
        end = pos + n
        if end > self.end or n < 0:
            raise self._eof(f"{what} ({n} bytes)")
        self.pos = end
        return self.buf[pos:end]

    def color(self, value=None, what: str = "colour") -> str:
        return self.raw(n=4, what=what).hex()

    def i32(self, value=None, what: str = "int") -> int:
        pos = self.pos
        if pos + 4 > self.end:
            raise self._eof(what)
        self.pos = pos + 4
        return _I32.unpack_from(self.buf, pos)[0]

    def string(self, value=None, what: str = "string") -> str | None:
        at = pos = self.pos
        if pos < self.end and 1 < self.buf[pos] < 0x80:
            # The common case: a short string, its length in one byte.
            end = pos + self.buf[pos]
            if end <= self.end:
                try:
                    text = self.buf[pos + 1:end].decode("utf-8")
                except UnicodeDecodeError as e:
                    raise self.fail(f"UTF-8 {what}: {e.reason}", at) from None
                self.pos = end
                return text
        n = self.varint(what=f"{what} length")
        if n == 0:
            return None
        if n < 0 or n - 1 > MAX_STRING_BYTES:
            raise self.fail(f"{what} length, found {n - 1} bytes", at)
        raw = self.raw(n=n - 1, what=what)
        try:
            return raw.decode("utf-8")
        except UnicodeDecodeError as e:
            raise self.fail(f"UTF-8 {what}: {e.reason}", at) from None

    def f32(self, value=None, what: str = "float") -> float:
        pos = self.pos
        try:
            v = _F32.unpack_from(self.buf, pos)[0]
        except struct.error:
            raise self._eof(what) from None
        self.pos = pos + 4
        return v

    def varint(self, value=None, positive: bool = True, what: str = "varint") -> int:
        buf, pos = self.buf, self.pos
        try:
            b = buf[pos]
            if b < 0x80 and positive:
                self.pos = pos + 1
                return b
            result, shift = 0, 0
            while True:
                b = buf[pos]
                pos += 1
                result |= (b & 0x7F) << shift
                if not b & 0x80 or shift == 28:
                    break
                shift += 7
        except IndexError:
            raise self._eof(what) from None
        self.pos = pos
        result &= 0xFFFFFFFF
        if positive:
            return result - (1 << 32) if result & 0x80000000 else result
        return (result >> 1) ^ -(result & 1)

    def plain_frames(self, n: int, spec: "_FrameSpec") -> list[dict]:
        """Frames of a timeline whose values are float32s or colour bytes, the hot loop of
        animations: the same result as :func:`curve_timeline`, in fewer steps."""
        buf = self.buf
        layout = spec.layout
        unpack, size = spec.unpack, spec.size
        curve_unpack, curve_size = spec.curve_unpack, spec.curve_size
        single, key0, d0 = spec.single, spec.key0, spec.d0
        frames = []
        prev = None
        copysign = math.copysign
        pos = self.pos
        try:
            for _ in range(n):
                vals = unpack(buf, pos)
                pos += size
                f = {}
                t = vals[0]
                if t != 0 or copysign(1.0, t) < 0:
                    f["time"] = t
                if single:
                    v = vals[1]
                    if v != d0 or (v == 0 and copysign(1.0, v) < 0):
                        f[key0] = v
                else:
                    for (key, kind, d), v in zip(layout, vals[1:]):
                        if kind != "f":
                            f[key] = v.hex()
                        elif v != d or (v == 0 and copysign(1.0, v) < 0):
                            f[key] = v
                if prev is not None:
                    kind = buf[pos]
                    pos += 1
                    if kind == CURVE_BEZIER:
                        prev["curve"] = list(curve_unpack(buf, pos))
                        pos += curve_size
                    elif kind == CURVE_STEPPED:
                        prev["curve"] = "stepped"
                    elif kind != CURVE_LINEAR:
                        self.pos = pos - 1
                        raise self.fail(f"a curve type 0, 1 or 2, found {kind}")
                frames.append(f)
                prev = f
        except (struct.error, IndexError):
            self.pos = pos
            raise self._eof("timeline frames") from None
        self.pos = pos
        return frames

    def count(self, value=None, what: str = "count") -> int:
        at = self.pos
        if at < self.end and self.buf[at] < 0x80:
            self.pos = at + 1
            return self.buf[at]
        n = self.varint(what=what)
        if n < 0 or n > MAX_COUNT:
            raise self.fail(f"{what} between 0 and {MAX_COUNT}, found {n}", at)
        return n

    def f32s(self, n: int, what: str = "floats") -> list[float]:
        """``n`` float32s as a list (bulk arrays and runs of fields)."""
        pos = self.pos
        if n < 0 or pos + 4 * n > self.end:
            raise self._eof(f"{what} ({n} floats)")
        unpack, size = _floats_struct(n)
        self.pos = pos + size
        return list(unpack(self.buf, pos))

    def varints(self, values=None, n: int = 0, what: str = "indices") -> list[int]:
        """``n`` non-negative varints (triangles, edges of 4.2 meshes)."""
        buf, pos = self.buf, self.pos
        out = []
        append = out.append
        try:
            for _ in range(n):
                b = buf[pos]
                pos += 1
                if b < 0x80:
                    append(b)
                    continue
                result, shift = b & 0x7F, 7
                while True:
                    b = buf[pos]
                    pos += 1
                    result |= (b & 0x7F) << shift
                    if not b & 0x80 or shift == 28:
                        break
                    shift += 7
                append(result & 0xFFFFFFFF)
        except IndexError:
            self.pos = pos
            raise self._eof(what) from None
        self.pos = pos
        return out

    def weighted(self, values=None, n: int = 0, nbones: int = 0) -> list:
        """``n`` weighted vertices as the JSON's flat ``[count, (bone, x, y, weight)*]``."""
        buf, pos = self.buf, self.pos
        out = []
        append, extend = out.append, out.extend
        unpack = _XYW.unpack_from
        try:
            for _ in range(n):
                k = buf[pos]
                pos += 1
                if k >= 0x80:  # over 127 bones on one vertex: the long varint path
                    self.pos = pos - 1
                    k = self.count(what="bones per vertex")
                    pos = self.pos
                append(k)
                for _ in range(k):
                    b = buf[pos]
                    pos += 1
                    if b >= 0x80:
                        self.pos = pos - 1
                        b = self.varint()
                        pos = self.pos
                    if not 0 <= b < nbones:
                        raise self.fail(f"bone index below {nbones}, found {b}", pos - 1)
                    append(b)
                    extend(unpack(buf, pos))
                    pos += 12
        except (IndexError, struct.error):
            self.pos = pos
            raise self._eof("weighted vertices") from None
        self.pos = pos
        return out

    def string_ref(self, value=None, what: str = "string reference"):
        at = pos = self.pos
        if pos < self.end and self.buf[pos] < 0x80:
            i = self.buf[pos]
            self.pos = pos + 1
        else:
            i = self.varint(what=what)
        self.refs.append(i)
        if i == 0:
            return None
        if i < 0 or i > len(self.strings):
            raise self.fail(f"{what} into a table of {len(self.strings)} strings, found {i}", at)
        return self.strings[i - 1]


_XYW = struct.Struct(">3f")


class _RefWriter(SkelWriter):
    """A writer that reuses recorded string-reference indices where they still fit.

    It has the reader's bulk methods, so that declarations stay symmetric.
    """

    def varints(self, values, n: int = 0, what: str = "indices") -> list[int]:
        for v in values:
            self.varint(int(v))
        return values

    def weighted(self, values, n: int = 0, nbones: int = 0) -> list:
        i = 0
        try:
            for _ in range(n):
                k = int(values[i])
                self.count(k)
                i += 1
                for _ in range(k):
                    b = int(values[i])
                    if not 0 <= b < nbones:
                        raise self.fail(f"bone index below {nbones} in weighted vertices, got {b}")
                    self.varint(b)
                    self.out += _XYW.pack(values[i + 1], values[i + 2], values[i + 3])
                    i += 4
        except (IndexError, ValueError, TypeError, struct.error):
            raise self.fail("weighted vertices [boneCount, (bone, x, y, weight)...]") from None
        if i != len(values):
            raise self.fail(f"{i} numbers of weighted vertices, got {len(values)}")
        return values

    def __init__(self, path=None, refs: list[int] | None = None):
        super().__init__(path)
        self.refs = refs or []
        self._next = 0

    def string_ref(self, value, what: str = "string reference"):
        i = self._next
        self._next += 1
        if i < len(self.refs):
            k = self.refs[i]
            if (k == 0 and value is None) or (0 < k <= len(self.strings) and self.strings[k - 1] == value):
                self.varint(k)
                return value
        return super().string_ref(value, what)


def read(reader: SkelReader) -> dict:
    """Read a whole 4.0/4.1/4.2 ``.skel`` into a JSON-layout document."""
    r = _RefReader(reader.data, reader.path)
    r.pos = reader.pos
    doc: dict = {}
    try:
        skeleton(r, doc)
    finally:
        reader.pos = r.pos
    return _json_order(doc)


def write(writer, doc: dict) -> None:
    """Encode a document (read from ``.skel`` or loaded from JSON) as 4.x ``.skel`` bytes."""
    if not isinstance(doc, dict):
        raise writer.fail(f"a skeleton document (a JSON object), got {type(doc).__name__}")
    extra = doc.get(EXTRA, {})
    if not isinstance(extra, dict):
        extra = {}
    w = _RefWriter(writer.path, extra.get("refs") if extra.get("strings") is not None else None)
    try:
        skeleton(w, doc)
    except (AttributeError, TypeError, ValueError, KeyError, IndexError, OverflowError, struct.error) as e:
        # A document whose values have the wrong types (e.g. a hand-edited JSON).
        raise w.fail(f"a well-formed 4.x skeleton document ({type(e).__name__}: {e})") from None
    writer.raw(w.getvalue())


def tidy_floats(node):
    """A copy of a document with every float written as the shortest decimal that is still
    the same float32 (``-188.6337890625`` becomes ``-188.63379``, ``100.0`` becomes ``100``).

    For JSON text meant for people: writing the copy as ``.skel`` gives the same bytes.
    """
    import numpy as np

    return _tidy(node, np.float32)


def _tidy(node, f32):
    if isinstance(node, float):
        if node != node or node in (math.inf, -math.inf):
            return node
        if node.is_integer() and math.copysign(1.0, node) > 0:
            return int(node)
        return float(str(f32(node)))
    if isinstance(node, dict):
        return {k: _tidy(v, f32) for k, v in node.items()}
    if isinstance(node, list):
        return [_tidy(v, f32) for v in node]
    return node


_TOP_ORDER = ("skeleton", "bones", "slots", "ik", "transform", "path", "physics", "skins",
              "events", "animations", EXTRA)


def _json_order(doc: dict) -> dict:
    """Top-level keys in the order of the editor's export."""
    return {k: doc[k] for k in _TOP_ORDER if k in doc} | {k: v for k, v in doc.items() if k not in _TOP_ORDER}
