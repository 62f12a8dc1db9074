"""4.3's one list of constraints: IK, path, transform, physics and sliders, each with its type.

From 4.3 on, the JSON has one ``"constraints"`` list whose entries name their ``"type"``;
the binary stores each entry's name, a type byte and the type's fields. Skins and
timelines refer to a constraint by its index in this list. Sliders (new in 4.3) name an
animation, stored by index after every animation has been read.
"""

from __future__ import annotations

import struct

from ..enums import POSITION_MODE, ROTATE_MODE
from ..symmetric import CONSTRAINT_WORDS, enum, fld, index, names_once, put as _put
from .bones import _bone_list
from .constraints import _ik_mix_bits, _ik_mix_softness, _mix_field, _mode_byte, _physics_mass_to_mix
from .fields import _flag_byte, _same, _to_end, flag, fld_u8, opt
from .layout import PROPERTIES, SCALE_Y_MODE, SPACING_MODE, Context

#: Constraint types by their type byte.
CONSTRAINT_TYPES = ("ik", "path", "transform", "physics", "slider")

_PATH_MODES_43 = (("positionMode", POSITION_MODE, 1, 1, "percent"),
                  ("spacingMode", SPACING_MODE, 2, 3, "length"),
                  ("rotateMode", ROTATE_MODE, 4, 3, "tangent"))


def _target_first(node: dict, key: str) -> None:
    """The JSON names a constraint's target (or source) before its bones; the binary after."""
    _to_end(node, tuple(k for k in node if k not in ("type", "name", key)))


def ik(s, node: dict, c: Context) -> None:
    _bone_list(s, node, c)
    index(s, node, "target", *c.bones, "bone")
    value_flags = 0
    if not s.reading:
        value_flags = (2 if "scaleY" in node else 0) | (0 if node.get("bendPositive", True) else 4) \
            | _ik_mix_bits(node)
    flags = _flag_byte(s, node, ((1, "skin", False), (8, "compress", False), (16, "stretch", False)),
                       value_flags)
    if s.reading:
        _put(node, "bendPositive", not flags & 4, True)
    if flags & 2:
        enum(s, node, "scaleY", SCALE_Y_MODE, None, as_byte=True)
    _ik_mix_softness(s, node, flags)
    if s.reading:
        _target_first(node, "target")


def _property(s, node: dict, key: str) -> str:
    """A bone property (rotate, x, y, scaleX, scaleY, shearY) as its byte code."""
    return enum(s, node, key, PROPERTIES, None, as_byte=True)


def _properties(s, node: dict, n: int) -> None:
    """What a transform constraint reads from its source and writes to its bones:
    ``{from: {"offset", "to": {to: {"offset", "max", "scale"}}}}``."""
    if s.reading:
        props = {}
        for _ in range(n):
            tmp = {}
            src = _property(s, tmp, "k")
            entry = props[src] = {}
            fld(s, entry, "offset", 0)
            to = {}
            for _ in range(s.u8(what="property target count")):
                dst = _property(s, tmp, "k")
                target = to[dst] = {}
                fld(s, target, "offset", 0)
                fld(s, target, "max", 1)
                fld(s, target, "scale", 1)
            entry["to"] = to
        if props:
            node["properties"] = props
        return
    for src, entry in node.get("properties", {}).items():
        _property(s, {"k": src}, "k")
        fld(s, entry, "offset", 0)
        to = entry.get("to", {})
        if len(to) > 255:
            raise s.fail(f"at most 255 targets of property {src!r}, got {len(to)}")
        s.u8(len(to))
        for dst, target in to.items():
            _property(s, {"k": dst}, "k")
            fld(s, target, "offset", 0)
            fld(s, target, "max", 1)
            fld(s, target, "scale", 1)


#: A transform constraint's offsets: (key, flag bit); stored only when not 0.
_OFFSETS = (("rotation", 1), ("x", 2), ("y", 4), ("scaleX", 8), ("scaleY", 16), ("shearY", 32))
#: Its mixes: (key, flag bit, the property its bones receive that the mix applies to).
_MIXES = (("mixRotate", 1, "rotate"), ("mixX", 2, "x"), ("mixY", 4, "y"), ("mixScaleX", 8, "scaleX"),
          ("mixScaleY", 16, "scaleY"), ("mixShearY", 32, "shearY"))


def implied_mix(node: dict, key: str) -> float:
    """The value of a transform constraint's mix ``key`` when 4.3's JSON leaves it out: 0 for
    a property no bone receives, else 1, except that mixY follows mixX and mixScaleY follows
    mixScaleX (as SkeletonJson reads them)."""
    prop = _MIX_PROPERTY[key]
    targets = {dst for entry in (node.get("properties") or {}).values() for dst in (entry.get("to") or {})}
    if prop not in targets:
        return 0.0
    if key in ("mixY", "mixScaleY"):
        other = "mixX" if key == "mixY" else "mixScaleX"
        return node.get(other, implied_mix(node, other))
    return 1.0


_MIX_PROPERTY = {key: prop for key, _, prop in _MIXES}


def transform(s, node: dict, c: Context) -> None:
    _bone_list(s, node, c)
    index(s, node, "source", *c.bones, "bone")
    value_flags = 0
    if not s.reading:
        n = len(node.get("properties", {}))
        if n > 7:
            raise s.fail(f"at most 7 source properties in transform constraint {node.get('name')!r}, got {n}")
        value_flags = n << 5
    flags = _flag_byte(s, node, ((1, "skin", False), (2, "localSource", False), (4, "localTarget", False),
                                 (8, "additive", False), (16, "clamp", False)), value_flags)
    _properties(s, node, flags >> 5)
    value_flags = 0 if s.reading else sum(bit for key, bit in _OFFSETS if flag(node, key, 0))
    flags = _flag_byte(s, node, (), value_flags)
    for key, bit in _OFFSETS:
        opt(s, node, key, flags & bit)
    value_flags = 0
    if not s.reading:
        value_flags = sum(bit for key, bit, _ in _MIXES if not _same(node.get(key, implied_mix(node, key)), 0.0))
    flags = _flag_byte(s, node, (), value_flags)
    for key, bit, _ in _MIXES:
        if s.reading:
            # Read in order: mixY's implied value needs mixX already in the node.
            _put(node, key, s.f32() if flags & bit else 0.0, implied_mix(node, key))
        elif flags & bit:
            s.f32(node.get(key, implied_mix(node, key)), what=key)
    if s.reading:
        _target_first(node, "source")


def path(s, node: dict, c: Context) -> None:
    _bone_list(s, node, c)
    index(s, node, "slot", *c.slots, "slot")
    flags = _mode_byte(s, node, _PATH_MODES_43, ((1, "skin", False),),
                       0 if s.reading else (128 if flag(node, "rotation", 0) else 0))
    opt(s, node, "rotation", flags & 128)
    fld(s, node, "position", 0)
    fld(s, node, "spacing", 0)
    _mix_field(s, node, "mixRotate", 1)
    _mix_field(s, node, "mixX", 1)
    _mix_field(s, node, "mixY", None)
    if s.reading:
        _target_first(node, "slot")


_PHYSICS_FLAGS = (("x", 2), ("y", 4), ("rotate", 8), ("shearX", 32))
#: The JSON's default damping, 0.85, as the float32 the binary holds.
_DAMPING = struct.unpack(">f", struct.pack(">f", 0.85))[0]


def _physics_scale(s, node: dict, present: bool) -> None:
    """scaleX, with the scaleY mode folded into its sign: uniform stores -1 - scaleX,
    volume -2 - scaleX."""
    if s.reading:
        if present:
            v = s.f32()
            if v < -2:
                node["scaleX"], mode = -2 - v, "volume"
            elif v < 0:
                node["scaleX"], mode = -1 - v, "uniform"
            else:
                node["scaleX"], mode = v, None
            if node["scaleX"] == 0:
                del node["scaleX"]
            if mode:
                node["scaleY"] = mode
        return
    if present:
        v = node.get("scaleX", 0)
        mode = node.get("scaleY", "none")
        s.f32(-1 - v if mode == "uniform" else -2 - v if mode == "volume" else v, what="scaleX")


def physics(s, node: dict, c: Context) -> None:
    index(s, node, "bone", *c.bones, "bone")
    value_flags = 0
    if not s.reading:
        mode = node.get("scaleY", "none")
        if mode not in SCALE_Y_MODE:
            raise s.fail(f"scaleY one of {', '.join(SCALE_Y_MODE)}, got {mode!r}")
        value_flags = sum(bit for key, bit in _PHYSICS_FLAGS if flag(node, key, 0)) \
            | (16 if flag(node, "scaleX", 0) or mode != "none" else 0) \
            | (64 if flag(node, "limit", 5000, 5000.0) else 0) | (128 if flag(node, "mass", 1, 1.0) else 0)
    flags = _flag_byte(s, node, ((1, "skin", False),), value_flags)
    for key, bit in _PHYSICS_FLAGS[:3]:
        opt(s, node, key, flags & bit)
    _physics_scale(s, node, bool(flags & 16))
    opt(s, node, "shearX", flags & 32)
    opt(s, node, "limit", flags & 64, 5000)
    fld_u8(s, node, "fps", 60)
    # 4.3's JSON defaults for inertia and damping are 0.5 and 0.85 (4.2: 1 and 1).
    fld(s, node, "inertia", 0.5)
    fld(s, node, "strength", 100)
    fld(s, node, "damping", _DAMPING)
    _physics_mass_to_mix(s, node, bool(flags & 128))


def slider(s, node: dict, c: Context) -> None:
    value_flags = 0
    if not s.reading:
        bone = "bone" in node
        mix = node.get("mix", 1)
        value_flags = (16 if not _same(mix, 0.0) else 0) | (32 if not _same(mix, 1.0) else 0) \
            | (64 if bone else 0) | (128 if bone and node.get("local") else 0) \
            | (8 if flag(node, "max" if bone and c.nonessential else "time", 0) else 0)
    flags = _flag_byte(s, node, ((1, "skin", False), (2, "loop", False), (4, "additive", False)), value_flags)
    # A slider driven by a bone keeps the bone's range (nonessential), not a time.
    opt(s, node, "max" if flags & 64 and c.nonessential else "time", flags & 8)
    if flags & 16:
        if flags & 32:
            fld(s, node, "mix", 1)
    elif s.reading:
        node["mix"] = 0
    if flags & 64:
        if s.reading:
            _put(node, "local", bool(flags & 128), False)
        index(s, node, "bone", *c.bones, "bone")
        fld(s, node, "from", 0)
        _property(s, node, "property")
        fld(s, node, "to", 0)
        fld(s, node, "scale", 1)


_BODIES = {"ik": ik, "path": path, "transform": transform, "physics": physics, "slider": slider}


def constraint_list(s, doc: dict, c: Context) -> None:
    """The constraint list, and the name tables built from it into ``c``."""
    if s.reading:
        items = []
        for _ in range(s.count(what="constraint count")):
            name = s.string(what="constraint name")
            at = s.pos
            t = s.u8(what="constraint type")
            if t >= len(CONSTRAINT_TYPES):
                raise s.fail(f"a constraint type below {len(CONSTRAINT_TYPES)}, found {t}", at)
            node = {"type": CONSTRAINT_TYPES[t]}
            if name is not None:
                node["name"] = name
            _BODIES[node["type"]](s, node, c)
            items.append(node)
        if items:
            doc["constraints"] = items
    else:
        items = doc.get("constraints", [])
        _names_once(s, items)
        s.count(len(items))
        for node in items:
            s.string(node.get("name"))
            kind = node.get("type")
            if kind not in _BODIES:
                raise s.fail(f"a constraint type ({', '.join(CONSTRAINT_TYPES)}), got {kind!r}")
            s.u8(CONSTRAINT_TYPES.index(kind))
            _BODIES[kind](s, node, c)
    if s.reading:
        _names_once(s, items)
    _tables(items, c)


def _names_once(s, items: list) -> None:
    """Each type's names once each (:func:`~spinemesh.skeleton_binary.symmetric.names_once`): checked
    reading after the list, writing before it, so that nothing of such a list is written."""
    for kind in CONSTRAINT_TYPES:
        names_once(s, [x.get("name") if x.get("type") == kind else None for x in items], "constraints",
                   CONSTRAINT_WORDS[kind])


def _tables(items: list, c: Context) -> None:
    """Per type, the names by list index (``None`` where another type sits) and the index
    of each name: the tables timelines and skins look constraints up in."""
    types = [x.get("type") for x in items]
    names = [x.get("name") for x in items]
    lookup: dict = {}
    for i, key in enumerate(zip(types, names)):
        lookup.setdefault(key, i)
    c.constraints = (types, names, lookup)
    for kind in CONSTRAINT_TYPES:
        view = [n if t == kind else None for t, n in zip(types, names)]
        table = (view, {n: i for (t, n), i in lookup.items() if t == kind})
        setattr(c, "sliders" if kind == "slider" else kind, table)


def skin_constraints(s, skin: dict, c: Context) -> None:
    """A skin's constraints: indices into the list, in the JSON one name list per type."""
    types, names, lookup = c.constraints
    if s.reading:
        for _ in range(s.count(what="skin constraint count")):
            at = s.pos
            i = s.varint(what="constraint index")
            if not 0 <= i < len(names):
                raise s.fail(f"a constraint index below {len(names)}, found {i}", at)
            skin.setdefault(types[i], []).append(names[i])
        return
    found = []
    for kind in CONSTRAINT_TYPES:
        for name in skin.get(kind, []):
            if (kind, name) not in lookup:
                raise s.fail(f"a known {kind} constraint in skin {skin.get('name')!r}, got {name!r}")
            found.append(lookup[(kind, name)])
    s.count(len(found))
    for i in sorted(found):
        s.varint(i)


def slider_animations(s, doc: dict, c: Context) -> None:
    """After the animations: each slider's animation, by index."""
    anims = list(doc.get("animations", {}))
    lookup = {n: i for i, n in enumerate(anims)}
    for node in doc.get("constraints", []):
        if node.get("type") == "slider":
            index(s, node, "animation", anims, lookup, "animation")
