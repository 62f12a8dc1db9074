"""IK constraints, one bone and two bones (mix, bend direction, compress, stretch, uniform,
softness), as the runtimes 3.8 to 4.3 turn and scale their bones towards the target.
"""

from __future__ import annotations

import math

from ..transform import PI, RAD_DEG, float_divide
from .pose_bone import PoseBone, _wrap180


def _stretched_y(sy: float, s: float, scale_y: str) -> float:
    """A stretched bone's y scale: kept (``"none"``), scaled alike (``"uniform"``; 4.2's
    ``uniform``), or divided to keep its area (``"volume"``, 4.3; eased below a factor 0.7)."""
    if scale_y == "uniform":
        return sy * s
    if scale_y == "volume":
        return sy / (0.25 + 0.642857 * s if s < 0.7 else s)
    return sy


def ik_one(bone: PoseBone, tx_world: float, ty_world: float, compress: bool, stretch: bool, scale_y: str,
           alpha: float, family: str) -> None:
    """One-bone IK: turn (and with compress/stretch, scale) ``bone`` to point at the target;
    ``scale_y`` as :func:`_stretched_y`."""
    if family == "3.8":
        bone.ensure_applied()
    if bone.v43:
        bone.modify_local()
    parent = bone.parent
    pa, pb, pwx, pc, pd, pwy = parent.m
    ax, ay, arot, asx, asy, ashx, ashy = bone.applied
    _, _, bwx, _, _, bwy = bone.m
    rotation_ik = -ashx - arot
    if bone.inherit == "onlyTranslation":
        tx, ty = tx_world - bwx, ty_world - bwy
    else:
        if bone.inherit == "noRotationOrReflection":
            den = pa * pa + pc * pc
            if family in ("4.1", "4.2"):
                den = max(0.0001, den)
            s = float_divide(abs(pa * pd - pb * pc), den)  # 3.8, 4.0: NaN under a parent scaled to 0
            pb, pd = -pc * s, pa * s
            rotation_ik += math.atan2(pc, pa) * RAD_DEG
        x, y = tx_world - pwx, ty_world - pwy
        d = pa * pd - pb * pc
        if family in ("4.1", "4.2") and abs(d) <= 0.0001:
            tx = ty = 0.0
        else:  # 3.8, 4.0: a parent scaled to 0 makes the bone NaN there, as in the runtime
            tx, ty = float_divide(x * pd - y * pb, d) - ax, float_divide(y * pa - x * pc, d) - ay
    rotation_ik += math.atan2(ty, tx) * RAD_DEG
    if asx < 0:
        rotation_ik += 180
    rotation_ik = _wrap180(rotation_ik)
    sx, sy = asx, asy
    if compress or stretch:
        if bone.inherit in ("noScale", "noScaleOrReflection"):
            tx, ty = tx_world - bwx, ty_world - bwy
        b = bone.length * sx
        if family == "4.2":
            dd = tx * tx + ty * ty
            hit = b > 0.0001 and ((compress and dd < b * b) or (stretch and dd > b * b))
            dist = math.sqrt(dd)
        else:  # 3.8-4.1 guard only the stretch case against a zero length
            dist = math.hypot(tx, ty)
            hit = (compress and dist < b) or (stretch and dist > b and b > 0.0001)
        if hit:
            s = (dist / b - 1) * alpha + 1
            sx *= s
            sy = _stretched_y(sy, s, scale_y)
    bone.update_with((ax, ay, arot + rotation_ik * alpha, sx, sy, ashx, ashy))


def ik_two(parent: PoseBone, child: PoseBone, tx_world: float, ty_world: float, bend: int, stretch: bool,
           scale_y: str, softness: float, alpha: float, family: str) -> None:
    """Two-bone IK: turn ``parent`` and ``child`` so the child's tip reaches the target."""
    if family == "3.8":
        if alpha == 0:
            child.update_with(child.local)
            return
        parent.ensure_applied()
        child.ensure_applied()
    elif family == "4.2" and (parent.inherit != "normal" or child.inherit != "normal"):
        return
    if parent.v43:
        parent.modify_local()
        child.modify_local()
    px, py, prot, psx, psy = parent.applied[:5]
    sx, sy = psx, psy
    psx, psy, csx, os1, os2, s2 = _ik_two_signs(psx, psy, child.applied[3])
    u = abs(psx - psy) <= 0.0001
    cx, cy, cwx, cwy = _ik_two_child_position(parent, child, u and not (stretch and family != "3.8"))
    a, b, ppwx, c, d, ppwy = parent.parent.m
    det = a * d - b * c
    if family in ("4.1", "4.2"):
        inv = 0.0 if abs(det) <= 0.0001 else 1 / det
    else:  # 3.8, 4.0: a grandparent scaled to nothing makes these bones NaN there, as in the runtime
        inv = float_divide(1.0, det)
    x, y = cwx - ppwx, cwy - ppwy
    dx, dy = (x * d - y * b) * inv - px, (y * a - x * c) * inv - py
    l1, l2 = math.hypot(dx, dy), child.length * csx
    if l1 < 0.0001:
        ik_one(parent, tx_world, ty_world, False, stretch, "none", alpha, family)
        ca = child.applied
        child.update_with((cx, cy, 0.0, ca[3], ca[4], ca[5], ca[6]))
        return
    x, y = tx_world - ppwx, ty_world - ppwy
    tx, ty = (x * d - y * b) * inv - px, (y * a - x * c) * inv - py
    dd = tx * tx + ty * ty
    if softness != 0:
        tx, ty, dd = _ik_two_soften(tx, ty, dd, softness * (psx * (csx + 1) * 0.5), l1, l2 * psx)
    if u:
        a1, a2, scale = _ik_two_uniform(l1, l2 * psx, tx, ty, dd, bend, stretch, alpha)
        sx *= scale
        if family != "3.8" and scale != 1:
            sy = _stretched_y(sy, scale, scale_y)
    else:
        a1, a2 = _ik_two_nonuniform(l1, l2, psx, psy, tx, ty, dd, bend, family)
    os = math.atan2(cy, cx) * s2
    a1 = _wrap180((a1 - os) * RAD_DEG + os1 - prot)
    parent.update_with((px, py, prot + a1 * alpha, sx, sy if family != "3.8" else parent.applied[4], 0.0, 0.0))
    ca = child.applied
    crot = ca[2]
    a2 = _wrap180(((a2 + os) * RAD_DEG - ca[5]) * s2 + os2 - crot)
    child.update_with((cx, cy, crot + a2 * alpha, ca[3], ca[4], ca[5], ca[6]))


def _ik_two_signs(psx: float, psy: float, csx: float) -> tuple[float, float, float, float, float, int]:
    """The parent's and child's scales made positive, with the turns and sign that undo it:
    ``(psx, psy, csx, os1, os2, s2)``."""
    if psx < 0:
        psx, os1, s2 = -psx, 180.0, -1
    else:
        os1, s2 = 0.0, 1
    if psy < 0:
        psy, s2 = -psy, -s2
    if csx < 0:
        csx, os2 = -csx, 180.0
    else:
        os2 = 0.0
    return psx, psy, csx, os1, os2, s2


def _ik_two_child_position(parent: PoseBone, child: PoseBone, with_y: bool) -> tuple[float, float, float, float]:
    """The child's local ``(cx, cy)`` and world ``(cwx, cwy)`` position; its local y counts only
    with ``with_y`` (uniform parent scale, and no stretch after 3.8)."""
    cx = child.applied[0]
    a, b, pwx, c, d, pwy = parent.m
    if not with_y:
        return cx, 0.0, a * cx + pwx, c * cx + pwy
    cy = child.applied[1]
    return cx, cy, a * cx + b * cy + pwx, c * cx + d * cy + pwy


def _ik_two_soften(tx: float, ty: float, dd: float, softness: float, l1: float, l2: float
                   ) -> tuple[float, float, float]:
    """Softness: the target pulled back towards the parent as the chain nears full reach;
    the new ``(tx, ty)`` and its squared distance. ``softness`` and ``l2`` are scaled already."""
    td = math.sqrt(dd)
    sd = td - l1 - l2 + softness
    if sd > 0:
        p = min(1.0, sd / (softness * 2)) - 1
        p = (sd - softness * (1 - p * p)) / td
        tx -= p * tx
        ty -= p * ty
        dd = tx * tx + ty * ty
    return tx, ty, dd


def _ik_two_uniform(l1: float, l2: float, tx: float, ty: float, dd: float, bend: int, stretch: bool,
                    alpha: float) -> tuple[float, float, float]:
    """Two-bone IK angles ``(a1, a2)`` (radians) when the parent's scale is uniform (the law of
    cosines), and the parent's stretch factor (1 unless stretched to reach the target)."""
    scale = 1.0
    cos = (dd - l1 * l1 - l2 * l2) / (2 * l1 * l2)
    if cos < -1:
        cos, a2 = -1.0, math.pi * bend
    elif cos > 1:
        cos, a2 = 1.0, 0.0
        if stretch:
            scale = (math.sqrt(dd) / (l1 + l2) - 1) * alpha + 1
    else:
        a2 = math.acos(cos) * bend
    a = l1 + l2 * cos
    b = l2 * math.sin(a2)
    return math.atan2(ty * a - tx * b, tx * a + ty * b), a2, scale


def _ik_two_nonuniform(l1, l2, psx, psy, tx, ty, dd, bend, family) -> tuple[float, float]:
    """Two-bone IK angles when the parent's scale is not uniform (an ellipse meets a circle)."""
    a, b = psx * l2, psy * l2
    aa, bb, ta = a * a, b * b, math.atan2(ty, tx)
    c = bb * l1 * l1 + aa * dd - aa * bb
    c1, c2 = -2 * bb * l1, bb - aa
    d = c1 * c1 - 4 * c2 * c
    if d >= 0:
        q = math.sqrt(d)
        if c1 < 0:
            q = -q
        q = -(c1 + q) * 0.5
        r0, r1 = q / c2, c / q
        r = r0 if abs(r0) < abs(r1) else r1
        if dd - r * r >= 0:
            y = math.sqrt(dd - r * r) * bend
            return ta - math.atan2(y, r), math.atan2(y / psy, (r - l1) / psx)
    min_angle, min_x, min_y = PI, l1 - a, 0.0
    max_angle, max_x, max_y = 0.0, l1 + a, 0.0
    min_dist, max_dist = min_x * min_x, max_x * max_x
    c = -a * l1 / (aa - bb)
    if -1 <= c <= 1:
        c = math.acos(c)
        x, y = a * math.cos(c) + l1, b * math.sin(c)
        d = x * x + y * y
        if d < min_dist:
            min_angle, min_dist, min_x, min_y = c, d, x, y
        if d > max_dist:
            max_angle, max_dist, max_x, max_y = c, d, x, y
    if dd <= (min_dist + max_dist) * 0.5:
        return ta - math.atan2(min_y * bend, min_x), min_angle * bend
    return ta - math.atan2(max_y * bend, max_x), max_angle * bend
