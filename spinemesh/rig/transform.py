"""A bone's world transform from its local values, as the official runtimes compute it.

The world transform of a bone is the affine map from its local space to the skeleton's:
``world = M[:, :2] @ local + M[:, 2]``, with ``M = [[a, b, worldX], [c, d, worldY]]`` as the
runtimes name them. It is computed the way the official runtimes compute it for every
version this package reads (3.5 to 4.3): local rotation, scale and shear, then the parent's
transform, filtered by the bone's inherit mode (called transform mode before 4.2). The
skeleton itself sits at the origin with scale 1, as it does when a game loads it.

The bottom of :mod:`spinemesh.rig`'s bones: :mod:`.constraints` poses bones with these
transforms, and :mod:`.bones` reads a skeleton's bones from that pose.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from math import cos, sin

import numpy as np

from ..skeleton_check import is_number

#: The runtimes' pi (spine-ts, spine-csharp, ... define it as 3.1415927) and the degree
#: conversions made with it. A bone at 90 degrees then has ``cos = -2.3e-8``, not ``6e-17``:
#: tiny, but a fully stretched two-bone IK (``acos`` near 1) turns it into 0.01 degrees.
#: The runtimes use the exact pi in a few places; those keep ``math.pi``.
PI = 3.1415927
PI2 = PI * 2
DEG_RAD = PI / 180
RAD_DEG = 180 / PI

#: Inherit modes (4.2: ``inherit``; 3.x-4.1: ``transform``): the same five names everywhere.
INHERIT_MODES = ("normal", "onlyTranslation", "noRotationOrReflection", "noScale", "noScaleOrReflection")


def _num(node: dict, key: str, default: float) -> float:
    """A bone's or constraint's number ``node[key]``; ``default`` when missing or not a finite number."""
    value = node.get(key, default)
    if not is_number(value) or not math.isfinite(value):
        return float(default)
    return float(value)


def _cos_sin(degrees: float) -> tuple[float, float]:
    r = degrees * DEG_RAD
    return math.cos(r), math.sin(r)


def inherit_mode(node: dict) -> str:
    """The bone's inherit mode from either key (4.2+ ``inherit``, older ``transform``)."""
    mode = node.get("inherit", node.get("transform", "normal"))
    if mode not in INHERIT_MODES:
        # 3.4 and older: inheritRotation / inheritScale flags.
        rot, scale = node.get("inheritRotation", True), node.get("inheritScale", True)
        mode = {(True, True): "normal", (False, True): "noRotationOrReflection",
                (True, False): "noScale", (False, False): "onlyTranslation"}[(bool(rot), bool(scale))]
    return mode


def local_values(node: dict) -> tuple[float, ...]:
    """``(x, y, rotation, scaleX, scaleY, shearX, shearY)`` of a bone's setup pose, with defaults."""
    return (_num(node, "x", 0), _num(node, "y", 0), _num(node, "rotation", 0), _num(node, "scaleX", 1),
            _num(node, "scaleY", 1), _num(node, "shearX", 0), _num(node, "shearY", 0))


def world_from_local(values: Sequence[float], mode: str, parent: np.ndarray | None,
                     flat: float = 0.0001) -> np.ndarray:
    """A bone's world transform, shape (2, 3), from its local values and its parent's world
    transform (shape (2, 3), or None for the root): :func:`world_numbers` as an array."""
    numbers = world_numbers(values, mode, None if parent is None else tuple(parent.ravel().tolist()), flat)
    return np.array(numbers).reshape(2, 3)  # flat, then shaped: cheaper


def world_numbers(values: Sequence[float], mode: str, parent: tuple[float, ...] | None,
                  flat: float = 0.0001) -> tuple[float, float, float, float, float, float]:
    """A bone's world transform ``(a, b, worldX, c, d, worldY)``, plain floats, from its local
    values and its parent's world transform.

    Follows the runtimes' ``Bone.updateWorldTransformWith`` for each inherit mode, with the
    skeleton at the origin and scale 1 (the runtimes divide and multiply by the skeleton's
    scale, which is then a no-op). The formulas are the same in 3.8 to 4.2 at that scale.

    Parameters
    ----------
    values : sequence of 7 floats
        ``(x, y, rotation, scaleX, scaleY, shearX, shearY)``, degrees for the angles.
    mode : str
        One of :data:`INHERIT_MODES`.
    parent : tuple of 6 floats, or None
        The parent's world transform as the same six numbers ``(a, b, worldX, c, d, worldY)``
        (plain floats: unpacked faster than an array); None for the root.
    flat : float
        ``noRotationOrReflection``: below this squared length of the parent's x axis, its
        rotation is read from its y axis (3.8 to 4.2: 0.0001; 4.3: 1e-10).
    """
    x, y, rot, sx, sy, shear_x, shear_y = values
    # _cos_sin written out: this runs for every bone at every step of every pose
    r = (rot + shear_x) * DEG_RAD
    cx, snx = cos(r), sin(r)
    r = (rot + 90 + shear_y) * DEG_RAD
    cy, sny = cos(r), sin(r)
    la, lb, lc, ld = cx * sx, cy * sy, snx * sx, sny * sy
    if parent is None:
        return la, lb, x, lc, ld, y
    pa, pb, wx, pc, pd, wy = parent
    world_x, world_y = pa * x + pb * y + wx, pc * x + pd * y + wy
    if mode == "normal":  # the most common: returned at once
        return pa * la + pb * lc, pa * lb + pb * ld, world_x, pc * la + pd * lc, pc * lb + pd * ld, world_y
    if mode == "onlyTranslation":
        m = (la, lb, lc, ld)
    elif mode == "noRotationOrReflection":
        s = pa * pa + pc * pc
        if s > flat:
            s = abs(pa * pd - pb * pc) / s
            pb, pd = pc * s, pa * s
            prx = math.atan2(pc, pa) * RAD_DEG
        else:
            pa = pc = 0.0
            prx = 90 - math.atan2(pd, pb) * RAD_DEG
        cx, snx = _cos_sin(rot + shear_x - prx)
        cy, sny = _cos_sin(rot + shear_y - prx + 90)
        la, lb, lc, ld = cx * sx, cy * sy, snx * sx, sny * sy
        m = (pa * la - pb * lc, pa * lb - pb * ld, pc * la + pd * lc, pc * lb + pd * ld)
    else:  # noScale, noScaleOrReflection
        cr, sr = _cos_sin(rot)
        za, zc = pa * cr + pb * sr, pc * cr + pd * sr
        s = math.hypot(za, zc)
        if s > 0.00001:
            s = 1 / s
        za, zc = za * s, zc * s
        s = math.hypot(za, zc)
        if mode == "noScale" and pa * pd - pb * pc < 0:
            s = -s
        # Math.PI here in every runtime (3.8 to 4.2), where 4.2's updateAppliedTransform uses 3.1415927
        r = math.pi / 2 + math.atan2(zc, za)
        zb, zd = math.cos(r) * s, math.sin(r) * s
        cx, snx = _cos_sin(shear_x)
        cy, sny = _cos_sin(90 + shear_y)
        la, lb, lc, ld = cx * sx, cy * sy, snx * sx, sny * sy
        m = (za * la + zb * lc, za * lb + zb * ld, zc * la + zd * lc, zc * lb + zd * ld)
    return m[0], m[1], world_x, m[2], m[3], world_y


def world_transform(node: dict, parent: np.ndarray | None) -> np.ndarray:
    """The setup-pose world transform of one bone from its JSON, shape (2, 3), ignoring constraints.

    Parameters
    ----------
    node : dict
        The bone's JSON (``x``, ``y``, ``rotation``, ``scaleX``, ``scaleY``, ``shearX``,
        ``shearY``, ``inherit``/``transform``).
    parent : ndarray, shape (2, 3), or None
        The parent's world transform; None for the root.
    """
    return world_from_local(local_values(node), inherit_mode(node), parent)


def wrap_pi(r: float) -> float:
    """An angle difference in radians brought within [-pi, pi] by one turn, as the runtimes'
    constraints wrap it (a difference of two ``atan2``, so one turn is always enough)."""
    if r > PI:
        return r - PI2
    if r < -PI:
        return r + PI2
    return r


def wrap_turns(degrees: float) -> float:
    """An angle brought near [-180, 180] by whole turns, as spine-ts 3.8 to 4.1 write it:
    ``degrees - (16384 - ((16384.499999999996 - degrees / 360) | 0)) * 360`` (3.x rotate keys, the
    shorter way round; 3.8-4.1 local transform constraints).

    JavaScript's ``| 0`` keeps a whole number's low 32 bits (ToInt32): past 2**31 turns (about
    7.7e11 degrees) it wraps, and the angle is left far from [-180, 180] as the runtime leaves
    it; a number that is not finite counts as 0 there.

    Examples
    --------
    >>> wrap_turns(370.0), wrap_turns(-190.0)
    (10.0, 170.0)
    >>> wrap_turns(1e12)  # ToInt32 wrapped: the runtime's number, not 1e12 - 2777777778 turns
    1546188226840.0
    """
    return degrees - (16384 - js_int32(16384.499999999996 - degrees / 360)) * 360


def js_int32(x: float) -> int:
    """JavaScript's ``x | 0`` (ToInt32): truncated towards 0, its low 32 bits as a signed
    number; 0 for NaN and the infinities."""
    if not math.isfinite(x):
        return 0
    n = int(x) & 0xFFFFFFFF
    return n - (1 << 32) if n & 0x80000000 else n


def float_divide(a: float, b: float) -> float:
    """``a / b`` as the runtimes' floats divide: by zero, an infinity signed as IEEE 754 signs
    it (NaN for 0 / 0), where Python raises.

    Examples
    --------
    >>> float_divide(1.0, -0.0), float_divide(6.0, 3.0)
    (-inf, 2.0)
    """
    if b != 0 or math.isnan(b):
        return a / b
    if a == 0 or math.isnan(a):
        return math.nan
    return math.copysign(math.inf, a) * math.copysign(1.0, b)
