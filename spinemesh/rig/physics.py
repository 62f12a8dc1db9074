"""Physics constraints (4.2 and 4.3), stepped as the official runtimes step them.

A physics constraint keeps state from frame to frame: how far its bone lags behind where the
animation puts it (x, y, rotation, scale offsets) and how fast those offsets change. Each
``updateWorldTransform`` with physics on, the skeleton's clock has advanced; the constraint
adds the bone's movement since the last frame (times ``inertia``, at most ``limit`` per
second) to the offsets, then integrates springs pulling them back (``strength``), slowed by
``damping``, pushed by ``wind`` and ``gravity``, in fixed steps of ``1 / fps`` seconds (time
left over carries to the next frame), and moves the bone by the offsets times ``mix``.

4.3 steps the same springs, and shows the bone *between* two steps: each update keeps how far
the last steps moved each offset (its *lag*) and draws the offset minus the lag times the part
of a step not yet elapsed (``1 - remaining / step``, at least 0), so that a frame shorter than a
step no longer shows the offset jump. Its defaults differ too (``inertia`` 0.5, ``damping``
0.85), and a ``scaleY`` mode carries the x scale to y (``uniform``) or its inverse (``volume``).

:mod:`spinemesh.anim` replays a game loop from time 0 to reproduce a pose: a pose with
physics depends on every frame before it. The math follows the public runtime source
(spine-ts 4.2, spine-core 4.3 ``PhysicsConstraint``); the implementation is ours.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .transform import PI2, _num

RESET, UPDATE, POSE = "reset", "update", "pose"


def damping_power(damping: float, exponent: float) -> float:
    """``damping ** exponent`` as the runtimes' ``pow`` gives it: NaN for a negative damping and a
    fractional exponent (a step of 1/45 s: Python gives a complex number, which no comparison
    takes), an infinity where the power overflows (Python raises). Springs so damped diverge, and
    the bones they move are flagged.

    Examples
    --------
    >>> damping_power(0.25, 0.5), damping_power(-2.0, 2.0)
    (0.5, 4.0)
    >>> damping_power(-0.5, 4 / 3), damping_power(-1e9, 61.0)
    (nan, -inf)
    """
    if damping < 0 and not float(exponent).is_integer():
        return math.nan
    try:
        return damping ** exponent
    except OverflowError:
        return -math.inf if damping < 0 and exponent % 2 == 1 else math.inf


@dataclass
class PhysicsSettings:
    """The constraint's fixed data: which properties it moves, by how much, and its stepping."""

    x: float
    y: float
    rotate: float
    scale_x: float
    shear_x: float
    limit: float
    step: float
    reference_scale: float
    lagged: bool = False          # 4.3: the bone shown between steps (see the module's docstring)
    scale_y: str = "none"         # 4.3: "none", "uniform" or "volume"

    @classmethod
    def from_json(cls, c: dict, skeleton: dict, four_three: bool = False) -> PhysicsSettings:
        """The settings of constraint ``c`` of a skeleton whose ``skeleton`` entry is given;
        ``four_three``: read as spine-core 4.3 reads them."""
        fps = _num(c, "fps", 60)
        mode = c.get("scaleY") if four_three else None
        return cls(_num(c, "x", 0), _num(c, "y", 0), _num(c, "rotate", 0), _num(c, "scaleX", 0),
                   _num(c, "shearX", 0), _num(c, "limit", 5000), 1 / fps if fps > 0 else 1 / 60,
                   _num(skeleton, "referenceScale", 100), four_three,
                   mode if mode in ("uniform", "volume") else "none")


class _Values:
    """The constraint's current values (setup or animated), as the runtime holds them."""

    def __init__(self, data: dict, four_three: bool = False):
        self.mix = _num(data, "mix", 1)
        # The JSON's defaults: 4.3 changed inertia's and damping's
        self.inertia, self.strength = _num(data, "inertia", 0.5 if four_three else 1), _num(data, "strength", 100)
        self.damping = _num(data, "damping", 0.85 if four_three else 1)
        mass = _num(data, "mass", 1)
        self.mass_inverse = 1 / mass if mass != 0 else 0.0
        self.wind, self.gravity = _num(data, "wind", 0), _num(data, "gravity", 0)


class PhysicsState:
    """One physics constraint's state between frames, and its update.

    The sampler sets ``clock`` (the skeleton's time, seconds) and ``mode`` (``"reset"``,
    ``"update"`` or ``"pose"``) before each ``updateWorldTransform``; :meth:`update` is what the
    update cache runs for the constraint, with its current values (``inertia``, ``strength``,
    ``damping``, ``mass``, ``wind``, ``gravity``, ``mix``: setup or animated) in ``data``.
    """

    def __init__(self, settings: PhysicsSettings):
        self.s = settings
        #: the constraint's values read from the data last given (the setup's, most steps), kept
        #: with that very dict: each step hands the same one until a timeline keys the values
        self._read: tuple[dict | None, _Values | None] = (None, None)
        self.clock = 0.0
        self.mode = RESET
        self.ux = self.uy = self.cx = self.cy = self.tx = self.ty = 0.0
        self.reset()

    def reset(self) -> None:
        """Forget the motion: the next update starts from where the bone is."""
        self.remaining = 0.0
        self.last_time = self.clock
        self.fresh = True
        self.x_offset = self.x_velocity = self.y_offset = self.y_velocity = 0.0
        self.rotate_offset = self.rotate_velocity = self.scale_offset = self.scale_velocity = 0.0
        # 4.3: how far the last steps of an update moved each offset (0 in 4.2, which has none)
        self.x_lag = self.y_lag = self.rotate_lag = self.scale_lag = 0.0

    def update(self, bone, data: dict) -> None:
        """Move ``bone`` (a :class:`~.constraints.pose_bone.PoseBone`) by the constraint, as ``update(physics)``."""
        s = self.s
        read, v = self._read
        if data is not read:
            v = _Values(data, s.lagged)
            self._read = (data, v)
        if v.mix == 0:
            return
        if s.lagged:
            self._update_lagged(bone, v)
            return
        a, b, wx, c, d, wy = bone.m
        if self.mode == RESET:
            self.reset()
        if self.mode in (RESET, UPDATE):
            delta = self._advance(wx, wy)
            if delta is not None:
                limit = s.limit * delta
                left, wx, wy, damped = self._translate(wx, wy, limit, v)
                if s.rotate > 0 or s.shear_x > 0 or s.scale_x > 0:
                    left = self._rotate(a, c, wx, wy, limit, bone.length, v, damped)
                self.remaining = left
            self.cx, self.cy = wx, wy
        else:  # pose: the offsets as they are
            if s.x > 0:
                wx += self.x_offset * v.mix * s.x
            if s.y > 0:
                wy += self.y_offset * v.mix * s.y
        self._finish(bone, a, b, c, d, wx, wy, v.mix, 0.0)

    def _advance(self, wx: float, wy: float) -> float | None:
        """The skeleton's clock since the last update added to the time left to step; that
        advance in seconds, or None at the first update (the bone at ``wx, wy`` kept as where
        it was, nothing stepped)."""
        delta = max(self.clock - self.last_time, 0.0)
        self.remaining += delta
        self.last_time = self.clock
        if self.fresh:
            self.fresh = False
            self.ux, self.uy = wx, wy
            return None
        return delta

    def _finish(self, bone, a, b, c, d, wx, wy, mix: float, z: float) -> None:
        """The bone turned and scaled by the offsets (less their lags times ``z``), kept."""
        a, b, c, d = self._turn_and_scale(a, b, c, d, mix, z)
        if self.mode != POSE:
            self.tx, self.ty = bone.length * a, bone.length * c
        bone.set_world((a, b, wx, c, d, wy))
        bone.update_applied()

    def _update_lagged(self, bone, v: _Values) -> None:
        """4.3's update: the same springs, the bone drawn between the last two steps."""
        s = self.s
        bone.modify_world()
        a, b, wx, c, d, wy = bone.m
        t, z = s.step, 0.0
        move_x, move_y = s.x > 0, s.y > 0
        turn, scale = s.rotate > 0 or s.shear_x > 0, s.scale_x > 0
        if self.mode == RESET:
            self.reset()
        if self.mode in (RESET, UPDATE):
            before = self.remaining  # the time left over from the last update, for the lags it left
            delta = self._advance(wx, wy)
            if delta is not None:
                limit = s.limit * delta
                left, damped = self.remaining, -1.0
                if move_x or move_y:
                    left, damped = self._translate_lagged(wx, wy, limit, v)
                    z = max(0.0, 1 - left / t)
                    if move_x:
                        wx += (self.x_offset - self.x_lag * z) * v.mix * s.x
                    if move_y:
                        wy += (self.y_offset - self.y_lag * z) * v.mix * s.y
                if turn or scale:
                    left = self._rotate_lagged(a, c, wx, wy, limit, bone.length, v, damped, before)
                    z = max(0.0, 1 - left / t)
                self.remaining = left
            self.cx, self.cy = wx, wy
        else:  # pose: the offsets as they are
            z = max(0.0, 1 - self.remaining / t)
            if move_x:
                wx += (self.x_offset - self.x_lag * z) * v.mix * s.x
            if move_y:
                wy += (self.y_offset - self.y_lag * z) * v.mix * s.y
        self._finish(bone, a, b, c, d, wx, wy, v.mix, z)

    def _translate_lagged(self, bx: float, by: float, limit: float, v: _Values) -> tuple[float, float]:
        """4.3: the bone's movement added to the x/y offsets, the springs stepped and their lags
        kept; returns the time left over and the damping used (-1 when not computed)."""
        left, damped = self.remaining, -1.0
        self._follow_xy(bx, by, limit, v)
        if left >= self.s.step:
            x0, y0 = self.x_offset, self.y_offset
            left, damped = self._step_xy(left, v)
            self.x_lag, self.y_lag = self.x_offset - x0, self.y_offset - y0
        return left, damped

    def _rotate_lagged(self, a_: float, c_: float, wx: float, wy: float, limit: float, length: float,
                       v: _Values, damped: float, before: float) -> float:
        """4.3: the bone's turn added to the rotation and scale offsets (measured against the
        bone as last drawn: the lags of the update before, ``before`` s of a step left then),
        the springs stepped and their lags kept; returns the time left over."""
        s = self.s
        t = s.step
        turn, scale, ca, dx, dy = self._turn_inputs(a_, c_, wx, wy, limit)
        mr = 0.0
        shown_before = max(0.0, 1 - before / t)
        if turn:
            mr = (s.rotate + s.shear_x) * v.mix
            lag = self.rotate_lag * shown_before
            r = math.atan2(dy + self.ty, dx + self.tx) - ca - (self.rotate_offset - lag) * mr
            self.rotate_offset += (r - math.ceil(r * (1 / PI2) - 0.5) * PI2) * v.inertia
            r = (self.rotate_offset - lag) * mr + ca
            c, sn = math.cos(r), math.sin(r)
            if scale:
                r = length * math.hypot(a_, c_)
                if r > 0:
                    self.scale_offset += (dx * c + dy * sn) * v.inertia / r
        else:
            c, sn = math.cos(ca), math.sin(ca)
            r = length * math.hypot(a_, c_) - self.scale_lag * shown_before
            if r > 0:
                self.scale_offset += (dx * c + dy * sn) * v.inertia / r
        left = self.remaining
        if left >= t:
            r0, s0 = self.rotate_offset, self.scale_offset
            left = self._step_turn_scale(left, v, damped, turn, scale, c, sn, mr, ca, length)
            self.rotate_lag, self.scale_lag = self.rotate_offset - r0, self.scale_offset - s0
        return left

    def _translate(self, bx: float, by: float, limit: float, v: _Values) -> tuple[float, float, float, float]:
        """The bone's movement since the last frame added to the x/y offsets, the springs
        stepped; returns the time left over, the bone's moved position and the damping used
        (-1 when not computed)."""
        s = self.s
        a, damped = self.remaining, -1.0
        move_x, move_y = s.x > 0, s.y > 0
        if not (move_x or move_y):
            return a, bx, by, damped
        self._follow_xy(bx, by, limit, v)
        if a >= s.step:
            a, damped = self._step_xy(a, v)
        if move_x:
            bx += self.x_offset * v.mix * s.x
        if move_y:
            by += self.y_offset * v.mix * s.y
        return a, bx, by, damped

    def _follow_xy(self, bx: float, by: float, limit: float, v: _Values) -> None:
        """The bone's movement since the last frame (at most ``limit`` a side) added to the x/y
        offsets, by the inertia; the bone's position kept for the next frame."""
        s = self.s
        if s.x > 0:
            u = (self.ux - bx) * v.inertia
            self.x_offset += limit if u > limit else -limit if u < -limit else u
            self.ux = bx
        if s.y > 0:
            u = (self.uy - by) * v.inertia
            self.y_offset += limit if u > limit else -limit if u < -limit else u
            self.uy = by

    def _step_xy(self, left: float, v: _Values) -> tuple[float, float]:
        """The x/y springs stepped while a whole step of the ``left`` seconds (at least one) is
        left; returns the time left over and the damping used."""
        s = self.s
        t = s.step
        damped = damping_power(v.damping, 60 * t)
        m, w, g = v.mass_inverse * t, v.wind * s.reference_scale, v.gravity * s.reference_scale
        while True:
            if s.x > 0:
                self.x_velocity += (w - self.x_offset * v.strength) * m
                self.x_offset += self.x_velocity * t
                self.x_velocity *= damped
            if s.y > 0:
                self.y_velocity -= (g + self.y_offset * v.strength) * m
                self.y_offset += self.y_velocity * t
                self.y_velocity *= damped
            left -= t
            if left < t:
                return left, damped

    def _step_turn_scale(self, left: float, v: _Values, damped: float, turn: bool, scale: bool, c: float,
                         sn: float, mr: float, ca: float, length: float) -> float:
        """The rotation and scale springs stepped while a whole step of the ``left`` seconds (at
        least one) is left, ``c``, ``sn`` the cosine and sine of the bone's turn as it is drawn
        (``mr`` the offset's mix, ``ca`` the bone's own angle); returns the time left over."""
        s = self.s
        t = s.step
        if damped == -1:
            damped = damping_power(v.damping, 60 * t)
        m, h = v.mass_inverse * t, length / s.reference_scale
        while True:
            left -= t
            if scale:
                self.scale_velocity += (v.wind * c - v.gravity * sn - self.scale_offset * v.strength) * m
                self.scale_offset += self.scale_velocity * t
                self.scale_velocity *= damped
            if turn:
                self.rotate_velocity -= ((v.wind * sn + v.gravity * c) * h + self.rotate_offset * v.strength) * m
                self.rotate_offset += self.rotate_velocity * t
                self.rotate_velocity *= damped
                if left < t:
                    return left
                r = self.rotate_offset * mr + ca
                c, sn = math.cos(r), math.sin(r)
            elif left < t:
                return left

    def _turn_inputs(self, a_: float, c_: float, wx: float, wy: float,
                     limit: float) -> tuple[bool, bool, float, float, float]:
        """What the rotation and scale springs start from: whether they move (``turn``,
        ``scale``), the bone's angle ``ca`` (``a_``, ``c_`` its world x axis) and how far it
        moved since the last update (at most ``limit`` a side)."""
        s = self.s
        return (s.rotate > 0 or s.shear_x > 0, s.scale_x > 0, math.atan2(c_, a_),
                min(max(self.cx - wx, -limit), limit), min(max(self.cy - wy, -limit), limit))

    def _rotate(self, a_: float, c_: float, wx: float, wy: float, limit: float, length: float, v: _Values,
                damped: float) -> float:
        """The bone's turn since the last frame added to the rotation and scale offsets, the
        springs stepped; returns the time left over."""
        s = self.s
        turn, scale, ca, dx, dy = self._turn_inputs(a_, c_, wx, wy, limit)
        mr = 0.0
        if turn:
            mr = (s.rotate + s.shear_x) * v.mix
            r = math.atan2(dy + self.ty, dx + self.tx) - ca - self.rotate_offset * mr
            self.rotate_offset += (r - math.ceil(r * (1 / PI2) - 0.5) * PI2) * v.inertia
            r = self.rotate_offset * mr + ca
        else:
            r = ca
        c, sn = math.cos(r), math.sin(r)
        if scale:
            r = length * math.hypot(a_, c_)
            if r > 0:
                self.scale_offset += (dx * c + dy * sn) * v.inertia / r
        a = self.remaining
        if a >= s.step:
            a = self._step_turn_scale(a, v, damped, turn, scale, c, sn, mr, ca, length)
        return a

    def _turn_and_scale(self, a, b, c, d, mix, z):
        s = self.s
        if s.rotate > 0 or s.shear_x > 0:
            # 4.2 has no lags (0): the offset itself
            o = (self.rotate_offset - self.rotate_lag * z) * mix
            if s.shear_x > 0:
                r = 0.0
                if s.rotate > 0:
                    r = o * s.rotate
                    sn, cs = math.sin(r), math.cos(r)
                    b, d = cs * b - sn * d, sn * b + cs * d
                r += o * s.shear_x
                sn, cs = math.sin(r), math.cos(r)
                a, c = cs * a - sn * c, sn * a + cs * c
            else:
                o *= s.rotate
                sn, cs = math.sin(o), math.cos(o)
                a, c = cs * a - sn * c, sn * a + cs * c
                b, d = cs * b - sn * d, sn * b + cs * d
        if s.scale_x > 0:
            k = 1 + (self.scale_offset - self.scale_lag * z) * mix * s.scale_x
            a, c = a * k, c * k
            if s.scale_y == "uniform":
                b, d = b * k, d * k
            elif s.scale_y == "volume":
                k = abs(k)
                k = 1 / k if k >= 0.7 else 4 - 3.67347 * k
                b, d = b * k, d * k
        return a, b, c, d
