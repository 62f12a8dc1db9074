"""IK, transform, path and physics constraints of 4.0 to 4.2 (each in its own list)."""

from __future__ import annotations

import math

from ..enums import POSITION_MODE, ROTATE_MODE
from ..symmetric import bend, boolean, enum, fld, index, put as _put, text
from .bones import _bone_list
from .fields import _flag_byte, _same, _to_end, flag, fld_int, fld_u8, opt
from .layout import SPACING_MODE, Context


def _bone_target_head(s, node: dict, c: Context) -> None:
    """What IK and transform constraints start with: name, order, skin flag (before 4.3's
    flag bytes), the constrained bones and the target bone."""
    text(s, node, "name")
    fld_int(s, node, "order")
    if not c.L.flags:
        boolean(s, node, "skin")
    _bone_list(s, node, c)
    index(s, node, "target", *c.bones, "bone")


def ik(s, node: dict, c: Context) -> None:
    _bone_target_head(s, node, c)
    if not c.L.flags:
        fld(s, node, "mix", 1)
        fld(s, node, "softness", 0)
        bend(s, node)
        boolean(s, node, "compress")
        boolean(s, node, "stretch")
        boolean(s, node, "uniform")
        return
    value_flags = 0 if s.reading else _ik_mix_bits(node)
    flags = _flag_byte(s, node, ((1, "skin", False), (2, "bendPositive", True), (4, "compress", False),
                                 (8, "stretch", False), (16, "uniform", False)), value_flags)
    _ik_mix_softness(s, node, flags)
    if s.reading:
        _skin_after_order(node)


def _ik_mix_bits(node: dict) -> int:
    """The bits of an IK constraint's flag byte (4.2 on) that say which of mix and softness
    follow: 32 mix is not 0, 64 mix is not 1, 128 softness is not 0."""
    mix = node.get("mix", 1)
    # The editor sets "mix is not 1" even when "mix is not 0" is clear (mix 0).
    return (32 if not _same(mix, 0.0) else 0) | (64 if not _same(mix, 1.0) else 0) \
        | (128 if flag(node, "softness", 0) else 0)


def _ik_mix_softness(s, node: dict, flags: int) -> None:
    """An IK constraint's mix and softness, as its flag byte (4.2 on) says they are stored."""
    if flags & 32:
        if flags & 64:
            fld(s, node, "mix", 1)
    elif s.reading:
        node["mix"] = 0
    opt(s, node, "softness", flags & 128)


def _skin_after_order(node: dict) -> None:
    """4.2 keeps a constraint's skin flag in a flag byte after its bones; the JSON has it
    right after the order."""
    _to_end(node, tuple(k for k in node if k not in ("name", "order", "skin")))


_TRANSFORM_1 = (("rotation", 0, 8), ("x", 0, 16), ("y", 0, 32), ("scaleX", 0, 64), ("scaleY", 0, 128))
_TRANSFORM_2 = (("shearY", 0, 1), ("mixRotate", 1, 2), ("mixX", 1, 4), ("mixY", None, 8),
                ("mixScaleX", 1, 16), ("mixScaleY", None, 32), ("mixShearY", 1, 64))


def _json_default(node: dict, key: str, d):
    """JSON default of a transform/path mix: ``mixY`` follows ``mixX``, ``mixScaleY`` ``mixScaleX``."""
    if d is not None:
        return d
    return node.get("mixX", 1) if key == "mixY" else node.get("mixScaleX", 1)


def transform(s, node: dict, c: Context) -> None:
    _bone_target_head(s, node, c)
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
        flags = _mode_byte(s, node, _PATH_MODES, (),
                           0 if s.reading else (128 if flag(node, "rotation", 0) else 0))
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


def _mode_byte(s, node: dict, modes: tuple, bits: tuple, value_flags: int = 0) -> int:
    """A flag byte holding enum ``modes`` ``(key, names, shift, mask, default)`` besides
    boolean ``bits`` and precomputed ``value_flags`` (see :func:`_flag_byte`)."""
    if s.reading:
        at = s.pos
        flags = _flag_byte(s, node, bits)
        for key, names, shift, mask, d in modes:
            i = flags >> shift & mask
            if i >= len(names):
                raise s.fail(f"a valid {key}, found {i}", at)
            _put(node, key, names[i], d)
        return flags
    for key, names, shift, mask, d in modes:
        v = node.get(key, d)
        if v not in names:
            raise s.fail(f"{key} one of {', '.join(names)}, got {v!r}")
        value_flags |= names.index(v) << shift
    return _flag_byte(s, node, bits, value_flags)


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
    fld_u8(s, node, "fps", 60)
    fld(s, node, "inertia", 1)
    fld(s, node, "strength", 100)
    fld(s, node, "damping", 1)
    _physics_mass_to_mix(s, node, bool(flags & 128))


def _physics_mass_to_mix(s, node: dict, has_mass: bool) -> None:
    """The end of a physics constraint, the same in 4.2 and 4.3: the mass (when its flag bit is
    set), wind, gravity, then the flag byte of the globals and the mix."""
    if has_mass:
        # The binary keeps the inverse of the mass that the JSON holds.
        if s.reading:
            inv = s.f32()
            mass = 1 / inv if inv else math.inf
            s.float_sum += mass  # infinite for a zero inverse, refused like a stored one
            _put(node, "mass", mass, 1)
        else:
            mass = node.get("mass", 1)
            if mass == 0:  # the runtimes divide by it, reading JSON; its inverse is no float
                raise s.fail(f"a physics mass other than 0 (the binary stores its inverse), got {mass!r}")
            s.f32(1 / mass)
    fld(s, node, "wind", 0)
    fld(s, node, "gravity", 0)
    value_flags = 0 if s.reading else (128 if flag(node, "mix", 1, 1.0) else 0)
    flags = _flag_byte(s, node, _PHYSICS_GLOBALS, value_flags)
    opt(s, node, "mix", flags & 128, 1)
