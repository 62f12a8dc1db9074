"""Transform constraints (world or local, absolute or relative) as 3.8 to 4.2 pull their bones'
transforms towards the target's; 4.3's property-mapping form is :mod:`spinemesh.rig.transform43`.

Named apart from :mod:`spinemesh.rig.transform`, which is a bone's own world transform.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..transform import PI, _num, wrap_pi, wrap_turns
from .pose_bone import RAD, PoseBone


@dataclass
class TransformMix:
    """A transform constraint's setup values (3.x ``rotateMix``... become the 4.x six mixes)."""

    rotate: float
    x: float
    y: float
    scale_x: float
    scale_y: float
    shear_y: float
    offset: tuple[float, float, float, float, float, float]  # rotation, x, y, scaleX, scaleY, shearY
    local: bool
    relative: bool

    @classmethod
    def from_json(cls, c: dict, family: str | None) -> TransformMix:
        """Read the setup values; ``family`` None tells 3.x from 4.x keys by their names."""
        three = family == "3.8" if family else any(
            k in c for k in ("rotateMix", "translateMix", "scaleMix", "shearMix"))
        if three:
            r, t, s, sh = (_num(c, k, 1) for k in ("rotateMix", "translateMix", "scaleMix", "shearMix"))
            mixes = (r, t, t, s, s, sh)
        else:
            mix_x, mix_sx = _num(c, "mixX", 1), _num(c, "mixScaleX", 1)
            mixes = (_num(c, "mixRotate", 1), mix_x, _num(c, "mixY", mix_x), mix_sx,
                     _num(c, "mixScaleY", mix_sx), _num(c, "mixShearY", 1))
        offset = tuple(_num(c, k, 0) for k in ("rotation", "x", "y", "scaleX", "scaleY", "shearY"))
        return cls(*mixes, offset, bool(c.get("local", False)), bool(c.get("relative", False)))

    def moves_nothing(self, family: str) -> bool:
        """The runtime's early return (4.0 tests mixScaleX twice instead of mixScaleY)."""
        if family == "3.8":
            return False
        scale_y = self.scale_x if family == "4.0" else self.scale_y
        return not any((self.rotate, self.x, self.y, self.scale_x, scale_y, self.shear_y))


def transform_apply(mix: TransformMix, target: PoseBone, bones: list[PoseBone], family: str) -> bool:
    """Apply a transform constraint to ``bones`` (the runtime's four variants); False when the
    runtime returns first (every mix 0)."""
    if mix.moves_nothing(family):
        return False
    if mix.local:
        _transform_local(mix, target, bones, family)
    else:
        _transform_world(mix, target, bones, family)
    return True


def _transform_world(mix: TransformMix, target: PoseBone, bones: list[PoseBone], family: str) -> None:
    ta, tb, twx, tc, td, twy = target.m
    reflect = RAD if ta * td - tb * tc > 0 else -RAD
    off_rot, off_x, off_y, off_sx, off_sy, off_shear = mix.offset
    off_rot, off_shear = off_rot * reflect, off_shear * reflect
    # 3.8 tests scale and shear mixes with > 0 (and scale against 1e-5), 4.x with != 0.
    scale_on = (lambda m: m > 0) if family == "3.8" else (lambda m: m != 0)
    for bone in bones:
        a, b, wx, c, d, wy = bone.m
        modified = False
        if mix.rotate != 0:
            if mix.relative:
                r = wrap_pi(math.atan2(tc, ta) + off_rot)
            else:
                r = wrap_pi(math.atan2(tc, ta) - math.atan2(c, a) + off_rot)
            r *= mix.rotate
            cos, sin = math.cos(r), math.sin(r)
            a, b, c, d = cos * a - sin * c, cos * b - sin * d, sin * a + cos * c, sin * b + cos * d
            modified = True
        if mix.x != 0 or mix.y != 0:
            px = ta * off_x + tb * off_y + twx
            py = tc * off_x + td * off_y + twy
            if mix.relative:
                wx, wy = wx + px * mix.x, wy + py * mix.y
            else:
                wx, wy = wx + (px - wx) * mix.x, wy + (py - wy) * mix.y
            modified = True
        for axis, (m, off) in enumerate(((mix.scale_x, off_sx), (mix.scale_y, off_sy))):
            if not scale_on(m):
                continue
            t_len = math.hypot(ta, tc) if axis == 0 else math.hypot(tb, td)
            if mix.relative:
                s = (t_len - 1 + off) * m + 1
            else:
                s = math.hypot(a, c) if axis == 0 else math.hypot(b, d)
                if (s > 0.00001) if family == "3.8" else (s != 0):
                    s = (s + (t_len - s + off) * m) / s
            if axis == 0:
                a, c = a * s, c * s
            else:
                b, d = b * s, d * s
            modified = True
        if mix.shear_y > 0:
            if mix.relative:
                r = wrap_pi(math.atan2(td, tb) - math.atan2(tc, ta))
                r = math.atan2(d, b) + (r - PI / 2 + off_shear) * mix.shear_y
            else:
                by = math.atan2(d, b)
                r = wrap_pi(math.atan2(td, tb) - math.atan2(tc, ta) - (by - math.atan2(c, a)))
                r = by + (r + off_shear) * mix.shear_y
            s = math.hypot(b, d)
            b, d = math.cos(r) * s, math.sin(r) * s
            modified = True
        bone.set_world((a, b, wx, c, d, wy))
        if family == "3.8":
            if modified:
                bone.applied_valid = False
        else:
            bone.update_applied()


def _transform_local(mix: TransformMix, target: PoseBone, bones: list[PoseBone], family: str) -> None:
    off_rot, off_x, off_y, off_sx, off_sy, off_shear = mix.offset
    if family == "3.8":
        target.ensure_applied()
    t = target.applied
    for bone in bones:
        if family == "3.8":
            bone.ensure_applied()
        x, y, rotation, scale_x, scale_y, shear_x, shear_y = bone.applied
        if mix.relative:
            if family == "3.8":
                rotation += (t[2] + off_rot) * mix.rotate if mix.rotate != 0 else 0.0
                if mix.x != 0:
                    x, y = x + (t[0] + off_x) * mix.x, y + (t[1] + off_y) * mix.y
                if mix.scale_x > 0:
                    if scale_x > 0.00001:
                        scale_x *= (t[3] - 1 + off_sx) * mix.scale_x + 1
                    if scale_y > 0.00001:
                        scale_y *= (t[4] - 1 + off_sy) * mix.scale_y + 1
                if mix.shear_y > 0:
                    shear_y += (t[6] + off_shear) * mix.shear_y
            else:
                rotation += (t[2] + off_rot) * mix.rotate
                x += (t[0] + off_x) * mix.x
                y += (t[1] + off_y) * mix.y
                scale_x *= (t[3] - 1 + off_sx) * mix.scale_x + 1
                scale_y *= (t[4] - 1 + off_sy) * mix.scale_y + 1
                shear_y += (t[6] + off_shear) * mix.shear_y
        else:
            wrap = wrap_turns if family != "4.2" else (lambda r: r)
            if mix.rotate != 0:
                rotation += wrap(t[2] - rotation + off_rot) * mix.rotate
            if family != "3.8" or mix.x != 0:
                x += (t[0] - x + off_x) * mix.x
                y += (t[1] - y + off_y) * mix.y
            # The runtimes divide the mixed scale by the bone's own scale here (kept as they do).
            if family == "3.8":
                if mix.scale_x > 0:
                    if scale_x > 0.00001:
                        scale_x = (scale_x + (t[3] - scale_x + off_sx) * mix.scale_x) / scale_x
                    if scale_y > 0.00001:
                        scale_y = (scale_y + (t[4] - scale_y + off_sy) * mix.scale_y) / scale_y
                # 3.8 writes the mixed shear into the bone's local shear, not into this pose.
            else:
                if mix.scale_x != 0 and scale_x != 0:
                    scale_x = (scale_x + (t[3] - scale_x + off_sx) * mix.scale_x) / scale_x
                if mix.scale_y != 0 and scale_y != 0:
                    scale_y = (scale_y + (t[4] - scale_y + off_sy) * mix.scale_y) / scale_y
                if mix.shear_y != 0:
                    shear_y += wrap(t[6] - shear_y + off_shear) * mix.shear_y
        bone.update_with((x, y, rotation, scale_x, scale_y, shear_x, shear_y))
