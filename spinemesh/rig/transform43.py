"""Spine 4.3's transform constraints and its local values taken back from a world transform.

4.3 rewrote the transform constraint as a *property mapping*: each property read from the
source bone (``rotate``, ``x``, ``y``, ``scaleX``, ``scaleY``, ``shearY``; in its world or,
``localSource``, its local values, plus the constraint's offsets) less the property's
``offset`` is mapped onto any of the same properties of each constrained bone as
``to.offset + value * to.scale``, optionally clamped between ``to.offset`` and ``to.max``
(``clamp``), then mixed in (the pose's mix of that target property): replacing the bone's
value, or added to it (``additive``), in the bone's world transform or, ``localTarget``, in its
local values. The JSON spells it::

    {"type": "transform", "source": "face", "bones": ["eye"], "x": -90, "y": -66,
     "localSource": false, "localTarget": false, "additive": false, "clamp": false,
     "properties": {"x": {"offset": 0, "to": {"x": {"offset": 0, "max": 100, "scale": 1}}}},
     "mixX": 0.4}

A mix of a target property no mapping writes is 0 in the setup pose (``mixY`` defaults to
``mixX``, ``mixScaleY`` to ``mixScaleX``; the others to 1 when mapped).

4.3 also keeps a bone's local values and world transform in step lazily: a constraint that
changes the world transform has the local values taken back from it (:func:`local_from_world_43`,
``updateLocalTransform``) before anything reads them. The skeleton is at the origin with scale 1.
The math follows the public spine-core 4.3 (``TransformConstraint``, ``TransformConstraintData``,
``BonePose``); the implementation is ours.
"""

from __future__ import annotations

import math

import numpy as np

from .transform import DEG_RAD, PI, RAD_DEG, _num, float_divide, wrap_pi

#: The runtime's threshold for a zero squared length (``MathUtils.epsilon2``).
EPSILON2 = 0.00001 * 0.00001

#: The properties a 4.3 transform constraint reads and writes, in the runtime's order, with
#: the index of the constraint's offset each reads and the name of the mix each writes with.
PROPERTIES = ("rotate", "x", "y", "scaleX", "scaleY", "shearY")
MIXES = ("mixRotate", "mixX", "mixY", "mixScaleX", "mixScaleY", "mixShearY")
_OFFSETS = ("rotation", "x", "y", "scaleX", "scaleY", "shearY")


class Unmapped(ValueError):
    """A 4.3 transform constraint names a property the runtime does not know."""


def _atan2_deg(y: float, x: float) -> float:
    return math.atan2(y, x) * RAD_DEG


def _wrap_shear(shear_y: float) -> float:
    if shear_y > 180:
        return shear_y - 360
    if shear_y <= -180:
        return shear_y + 360
    return shear_y


def _decompose(ra: float, rb: float, rc: float, rd: float, ro: float) -> list[float]:
    """Rotation, scales and shear (x shear 0) of a local 2x2 matrix, ``ro`` added to the
    rotation (``BonePose.set5``): ``[rotation, scaleX, scaleY, shearX, shearY]``."""
    x, y = ra * ra + rc * rc, rb * rb + rd * rd
    if x > EPSILON2:
        r = _atan2_deg(rc, ra)
        scale_x, scale_y, shear_y = math.sqrt(x), math.sqrt(y), 0.0
        if y > EPSILON2:
            shear_y = _atan2_deg(rd, rb)
            if ra * rd - rb * rc < 0:
                scale_y = -scale_y
                shear_y += 90 - r
            else:
                shear_y -= 90 + r
            shear_y = _wrap_shear(shear_y)
        return [r + ro, scale_x, scale_y, 0.0, shear_y]
    rotation = _atan2_deg(rd, rb) - 90 + ro if y > EPSILON2 else ro
    return [rotation, 0.0, math.sqrt(y), 0.0, 0.0]


def _decompose_sheared(ra: float, rb: float, rc: float, rd: float) -> list[float]:
    """Scales and both shears of a local 2x2 matrix whose rotation is known (``BonePose.set4``):
    ``[scaleX, scaleY, shearX, shearY]``."""
    x, y = ra * ra + rc * rc, rb * rb + rd * rd
    shear_x, scale_x = (_atan2_deg(rc, ra), math.sqrt(x)) if x > EPSILON2 else (0.0, 0.0)
    scale_y, shear_y = math.sqrt(y), 0.0
    if y > EPSILON2:
        shear_y = _atan2_deg(rd, rb)
        if ra * rd - rb * rc < 0:
            scale_y = -scale_y
            shear_y += 90
        else:
            shear_y -= 90
        shear_y = _wrap_shear(shear_y)
    return [scale_x, scale_y, shear_x, shear_y]


def local_from_world_43(world: tuple[float, ...], inherit: str, parent: tuple[float, ...] | None) -> list[float]:
    """A bone's local values ``[x, y, rotation, scaleX, scaleY, shearX, shearY]`` that give its
    world transform ``world`` under ``parent``'s (None: the root), as 4.3's
    ``updateLocalTransform`` takes them back for each inherit mode. Both transforms are six
    plain floats ``(a, b, worldX, c, d, worldY)`` (a :class:`~.constraints.pose_bone.PoseBone`'s ``m``)."""
    a, b, wx, c, d, wy = world
    if parent is None:
        rotation, sx, sy, shx, shy = _decompose(a, b, c, d, 0.0)
        return [wx, wy, rotation, sx, sy, shx, shy]
    pa, pb, pwx, pc, pd, pwy = parent
    pad = pa * pd - pb * pc
    pid = float_divide(1.0, pad)  # a parent scaled to nothing: infinite, as the runtime divides
    ia, ib, ic, id_ = pd * pid, pb * pid, pc * pid, pa * pid
    dx, dy = wx - pwx, wy - pwy
    x, y = dx * ia - dy * ib, dy * id_ - dx * ic
    if inherit in ("noScale", "noScaleOrReflection"):
        tx, ty = pd * a - pb * c, pa * c - pc * a
        if pad < 0:
            tx, ty = -tx, -ty
        rotation = _atan2_deg(ty, tx)
        r = rotation * DEG_RAD
        cos, sin = math.cos(r), math.sin(r)
        za, zc = pa * cos + pb * sin, pc * cos + pd * sin
        s = float_divide(1.0, math.sqrt(za * za + zc * zc))
        za, zc = za * s, zc * s
        si = -1 if inherit == "noScale" and pad < 0 else 1
        sx, sy, shx, shy = _decompose_sheared(za * a + zc * c, za * b + zc * d, (za * c - zc * a) * si,
                                              (za * d - zc * b) * si)
        return [x, y, rotation, sx, sy, shx, shy]
    if inherit == "onlyTranslation":
        m = (a, b, c, d, 0.0)
    elif inherit == "noRotationOrReflection":
        s, det = float_divide(1.0, pa * pa + pc * pc), float_divide(1.0, abs(pad))
        m = ((pa * a + pc * c) * s, (pa * b + pc * d) * s, (pa * c - pc * a) * det, (pa * d - pc * b) * det,
             _atan2_deg(pc, pa))
    else:
        m = (ia * a - ib * c, ia * b - ib * d, id_ * c - ic * a, id_ * d - ic * b, 0.0)
    rotation, sx, sy, shx, shy = _decompose(*m)
    return [x, y, rotation, sx, sy, shx, shy]


# -- the constraint ---------------------------------------------------------------------------
def mapping_43(data: dict) -> list[tuple[int, float, list[tuple[int, float, float, float]]]]:
    """The constraint's property mapping as spine-core 4.3 reads it: per source property (its
    index in :data:`PROPERTIES`), its offset and its targets ``(index, offset, max, scale)``
    (defaults 0, 1, 1), in the JSON's order; a source property without targets is left out.
    Raises :class:`Unmapped` for a property name the runtime refuses."""
    props = data.get("properties")
    out = []
    for name, entry in (props.items() if isinstance(props, dict) else ()):
        if name not in PROPERTIES:
            raise Unmapped(f"reads the unknown property {name!r}")
        entry = entry if isinstance(entry, dict) else {}
        targets = []
        to = entry.get("to")
        for to_name, t in (to.items() if isinstance(to, dict) else ()):
            if to_name not in PROPERTIES:
                raise Unmapped(f"writes the unknown property {to_name!r}")
            t = t if isinstance(t, dict) else {}
            targets.append((PROPERTIES.index(to_name), _num(t, "offset", 0), _num(t, "max", 1), _num(t, "scale", 1)))
        if targets:
            out.append((PROPERTIES.index(name), _num(entry, "offset", 0), targets))
    return out


def mixes_43(data: dict, mapping) -> list[float]:
    """The six mixes (:data:`MIXES` order) of a 4.3 transform constraint's current values
    ``data``: keyed by an animation, or the setup values with 4.3's defaults (0 where no
    mapping writes the property)."""
    written = {i for _, _, targets in mapping for i, *_ in targets}

    def setup(i: int, default: float) -> float:
        return _num(data, MIXES[i], default) if i in written else 0.0
    rotate, x = setup(0, 1), setup(1, 1)
    y = setup(2, x)
    scale_x = setup(3, 1)
    return [rotate, x, y, scale_x, setup(4, scale_x), setup(5, 1)]


def source_value_43(i: int, source, local: bool, offsets: list[float]) -> float:
    """Source property ``i`` (local values or world transform), the constraint's offset added."""
    if local:
        applied = source.applied
        return (applied[2], applied[0], applied[1], applied[3], applied[4], applied[6])[i] + offsets[i]
    a, b, wx, c, d, wy = source.m
    if i == 0:
        value = math.atan2(c, a) * RAD_DEG + (offsets[0] if a * d - b * c > 0 else -offsets[0])
        return value + 360 if value < 0 else value
    if i == 1:
        return offsets[1] * a + offsets[2] * b + wx
    if i == 2:
        return offsets[1] * c + offsets[2] * d + wy
    if i == 3:
        return math.sqrt(a * a + c * c) + offsets[3]
    if i == 4:
        return math.sqrt(b * b + d * d) + offsets[4]
    return (math.atan2(d, b) - math.atan2(c, a)) * RAD_DEG - 90 + offsets[5]


def _to_local(i: int, values: list[float], value: float, mix: float, additive: bool) -> None:
    """Target property ``i`` of the local values ``[x, y, rotation, scaleX, scaleY, shearX,
    shearY]`` moved towards (or by, ``additive``) ``value``."""
    if i == 0:
        values[2] += (value if additive else value - values[2]) * mix
    elif i in (1, 2):
        k = i - 1
        values[k] += (value if additive else value - values[k]) * mix
    elif i in (3, 4):
        k = i
        if additive:
            values[k] *= 1 + (value - 1) * mix
        elif values[k] != 0:
            values[k] += (value - values[k]) * mix
    else:
        if not additive:
            value -= values[6]
        values[6] += value * mix


def _to_world(i: int, m: list[float], value: float, mix: float, additive: bool) -> None:
    """Target property ``i`` of the world transform ``[a, b, c, d, worldX, worldY]`` moved
    towards (or by, ``additive``) ``value``."""
    a, b, c, d, wx, wy = m
    if i == 0:
        value *= DEG_RAD
        if not additive:
            value -= math.atan2(c, a)
        value = wrap_pi(value) * mix
        cos, sin = math.cos(value), math.sin(value)
        m[:4] = [cos * a - sin * c, cos * b - sin * d, sin * a + cos * c, sin * b + cos * d]
    elif i == 1:
        m[4] = wx + (value if additive else value - wx) * mix
    elif i == 2:
        m[5] = wy + (value if additive else value - wy) * mix
    elif i in (3, 4):
        p, q = (0, 2) if i == 3 else (1, 3)
        if additive:
            s = 1 + (value - 1) * mix
        else:
            s = math.sqrt(m[p] * m[p] + m[q] * m[q])
            if s == 0:
                return
            s = 1 + (value - s) * mix / s
        m[p], m[q] = m[p] * s, m[q] * s
    else:
        by = math.atan2(d, b)
        value = (value + 90) * DEG_RAD
        if additive:
            value -= PI / 2
        else:
            value = wrap_pi(value - (by - math.atan2(c, a)))
        value = by + value * mix
        s = math.sqrt(b * b + d * d)
        m[1], m[3] = math.cos(value) * s, math.sin(value) * s


def transform_apply_43(data: dict, source, bones: list) -> bool:
    """Apply a 4.3 transform constraint with current values ``data`` to ``bones``
    (:class:`~.constraints.pose_bone.PoseBone`, 4.3), reading ``source``; False when the runtime returns
    first (every mix 0). Raises :class:`Unmapped` for a mapping the runtime refuses."""
    mapping = mapping_43(data)
    mixes = mixes_43(data, mapping)
    if not any(mixes):
        return False
    local_source, local_target = data.get("localSource") is True, data.get("localTarget") is True
    additive, clamp = data.get("additive") is True, data.get("clamp") is True
    offsets = [_num(data, k, 0) for k in _OFFSETS]
    if local_source:
        source.validate_local()
    for bone in bones:
        if local_target:
            bone.modify_local()
            values = list(bone.applied)
        else:
            bone.modify_world()
            a, b, wx, c, d, wy = bone.m
            m = [a, b, c, d, wx, wy]
        for i, from_offset, targets in mapping:
            value = source_value_43(i, source, local_source, offsets) - from_offset
            for j, to_offset, to_max, scale in targets:
                if mixes[j] == 0:
                    continue
                v = to_offset + value * scale
                if clamp:
                    low, high = (to_offset, to_max) if to_offset < to_max else (to_max, to_offset)
                    v = min(max(v, low), high)
                if local_target:
                    _to_local(j, values, v, mixes[j], additive)
                else:
                    _to_world(j, m, v, mixes[j], additive)
        if local_target:
            bone.applied = values   # its world is computed when the update cache reaches it
        else:
            bone.world = np.array([[m[0], m[1], m[4]], [m[2], m[3], m[5]]])
            bone.update_applied()
    return True
