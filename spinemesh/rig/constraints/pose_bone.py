"""A bone as the runtime's update cache poses it (:class:`PoseBone`): its local values, its
world transform, and what the runtime keeps between updates.

Separate because every constraint kind (:mod:`.ik`, :mod:`.transform_constraint`, :mod:`.path`)
and the solver move these bones, and none of them owns it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..transform import DEG_RAD, PI, RAD_DEG, float_divide, world_numbers
from ..transform43 import local_from_world_43

RAD = DEG_RAD


@dataclass(eq=False)
class PoseBone:
    """One bone as the runtime holds it while it computes the pose.

    ``local`` is the setup pose (x, y, rotation, scaleX, scaleY, shearX, shearY); ``applied``
    the values its world transform was last computed from; ``m`` is the world transform's six
    numbers ``(a, b, worldX, c, d, worldY)``, plain floats, and :attr:`world` the same as an
    array, (2, 3) as in :mod:`..transform`. ``applied_exact`` says whether ``applied`` is
    reproduced exactly (False once a constraint we do not reproduce has moved the bone).
    """

    index: int
    name: str
    parent: PoseBone | None
    inherit: str
    length: float
    local: tuple[float, ...]
    family: str
    applied: list[float] = field(default_factory=list)
    #: the world transform, what the update reads and writes: a tuple of six floats, which Python
    #: unpacks faster than it reads an array's (every bone, every step of every pose)
    m: tuple[float, ...] = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0)
    _world: np.ndarray | None = field(default=None, init=False, repr=False)   # m as an array, once read
    applied_valid: bool = True        # 3.8 recomputes applied values from the world lazily
    flat: float = 0.0001              # world_numbers's threshold (4.3: 1e-10)
    applied_exact: bool = True
    exact: bool = True
    why: str = ""
    active: bool = True
    sorted: bool = False
    children: list[PoseBone] = field(default_factory=list)
    #: 4.3 computes a bone's world transform once per update unless a constraint resets it:
    #: ``world_now`` (its world is this update's), ``local_stale`` (a constraint changed its
    #: world, its applied values are not yet taken back from it). Both unused before 4.3.
    v43: bool = False
    world_now: bool = False
    local_stale: bool = False

    @property
    def world(self) -> np.ndarray:
        """The world transform, shape (2, 3): :attr:`m` as an array, made when first read after
        ``m`` changes (most steps of a pose read none) and read-only (assign it to change it)."""
        w = self._world
        if w is None:
            w = self._world = np.array(self.m).reshape(2, 3)
            w.flags.writeable = False
        return w

    @world.setter
    def world(self, value) -> None:
        self.set_world(tuple(np.asarray(value, float).ravel().tolist()))  # plain floats, as world_numbers gives

    def set_world(self, numbers: tuple[float, ...]) -> None:
        """The world transform set to ``numbers``, ``(a, b, worldX, c, d, worldY)``, plain floats
        (as :attr:`m` holds them; the array :attr:`world` is made again when next read)."""
        self.m, self._world = numbers, None

    # -- the runtime's Bone methods ------------------------------------------------------
    def update_with(self, values) -> tuple[float, ...]:
        """``updateWorldTransformWith``: world from ``values``, which become the applied values.
        Returns the world transform's six numbers (:func:`..transform.world_numbers`)."""
        # the update cache's step passes the applied values themselves, floats already: not copied
        self.applied = applied = values if values is self.applied else list(map(float, values))
        self.applied_valid = True
        parent = self.parent
        self.m = numbers = world_numbers(applied, self.inherit, None if parent is None else parent.m, self.flat)
        self._world = None
        self.world_now = True
        return numbers

    def update(self) -> None:
        """The cache step: 3.8 recomputes from the local values, 4.x from the applied ones
        (4.3: only where this update has not computed it yet)."""
        if self.v43:
            if self.world_now:
                return
            if self.local_stale:
                self.update_applied()
        try:
            if self.family == "3.8":
                numbers = self.update_with(self.local)
                self.applied_exact = True
            else:
                numbers = self.update_with(self.applied)
            a, b, x, c, d, y = numbers  # finite(), from the numbers at hand
            isfinite = math.isfinite
            finite = isfinite(a) and isfinite(b) and isfinite(x) and isfinite(c) and isfinite(d) and isfinite(y)
        except (ValueError, OverflowError):  # an infinite angle left by a degenerate constraint
            self.set_world((math.nan,) * 6)
            finite = False
        parent_ok = self.parent is None or self.parent.exact
        self.exact = parent_ok and self.applied_exact and finite
        if not parent_ok:
            self.why = f"below {self.parent.name!r}: {self.parent.why}"
        elif not self.exact and self.applied_exact:
            self.why = "its setup transform is not finite"

    def finite(self) -> bool:
        a, b, x, c, d, y = self.m
        isfinite = math.isfinite
        return isfinite(a) and isfinite(b) and isfinite(x) and isfinite(c) and isfinite(d) and isfinite(y)

    def ensure_applied(self) -> None:
        """3.8: ``if (!appliedValid) updateAppliedTransform()``."""
        if not self.applied_valid:
            self.update_applied()

    # -- 4.3: a bone's local and world values kept in step lazily -----------------------
    def modify_world(self) -> None:
        """4.3 ``modifyWorld``: a constraint is about to change the world transform."""
        self.local_stale = self.world_now = True
        self._reset_children()

    def modify_local(self) -> None:
        """4.3 ``modifyLocal``: a constraint is about to change the applied values (the world
        transform is then computed again when the update cache reaches the bone)."""
        if self.local_stale:
            self.update_applied()
        self.world_now = False
        self._reset_children()

    def validate_local(self) -> None:
        """4.3 ``validateLocalTransform``: the applied values, taken back from a changed world."""
        if self.local_stale:
            self.update_applied()

    def _reset_children(self) -> None:
        for child in self.children:
            if child.world_now:
                if child.local_stale:
                    child.update_applied()
                child.world_now = False
                child._reset_children()

    def update_applied(self) -> None:
        """``updateAppliedTransform``: local values that give the current world transform."""
        if self.v43:
            self.applied = local_from_world_43(self.m, self.inherit, None if self.parent is None else self.parent.m)
            self.local_stale, self.world_now = False, True
            return
        self.applied_valid = True
        a, b, wx, c, d, wy = self.m
        if self.parent is None:
            self.applied = [wx, wy, math.atan2(c, a) * RAD_DEG, math.hypot(a, c), math.hypot(b, d), 0.0,
                            math.atan2(a * b + c * d, a * d - b * c) * RAD_DEG]
            return
        pa, pb, pwx, pc, pd, pwy = self.parent.m
        # A parent scaled to 0 on an axis: the runtimes' floats divide by its zero determinant
        # and go on (infinite local values, which only a constraint reading them would use);
        # Python's would stop the pose where the game's world transform is exact.
        pid = float_divide(1.0, pa * pd - pb * pc)
        ia, ib, ic, id_ = pd * pid, pb * pid, pc * pid, pa * pid
        dx, dy = wx - pwx, wy - pwy
        ax, ay = dx * ia - dy * ib, dy * id_ - dx * ic
        if self.family == "4.2" and self.inherit == "onlyTranslation":
            ra, rb, rc, rd = a, b, c, d
        else:
            if self.family == "4.2" and self.inherit == "noRotationOrReflection":
                s = float_divide(abs(pa * pd - pb * pc), pa * pa + pc * pc)
                pb, pd = -pc * s, pa * s
                pid = float_divide(1.0, pa * pd - pb * pc)
                ia, ib = pd * pid, pb * pid
            elif self.family == "4.2" and self.inherit in ("noScale", "noScaleOrReflection"):
                cos, sin = math.cos(self.local[2] * RAD), math.sin(self.local[2] * RAD)
                pa, pc = pa * cos + pb * sin, pc * cos + pd * sin
                s = math.hypot(pa, pc)
                if s > 0.00001:
                    s = 1 / s
                pa, pc = pa * s, pc * s
                s = math.hypot(pa, pc)
                if self.inherit == "noScale" and pid < 0:
                    s = -s
                # MathUtils.PI here (4.2), where updateWorldTransform uses Math.PI (rig.transform)
                r = PI / 2 + math.atan2(pc, pa)
                pb, pd = math.cos(r) * s, math.sin(r) * s
                pid = float_divide(1.0, pa * pd - pb * pc)
                ia, ib, ic, id_ = pd * pid, pb * pid, pc * pid, pa * pid
            ra, rb = ia * a - ib * c, ia * b - ib * d
            rc, rd = id_ * c - ic * a, id_ * d - ic * b
        scale_x = math.hypot(ra, rc)
        if scale_x > 0.0001:
            det = ra * rd - rb * rc
            scale_y = det / scale_x
            # 4.2 fixed the sign of the recovered shear; 3.8-4.1 return it negated.
            shear_y = math.atan2(ra * rb + rc * rd, det) * RAD_DEG * (-1 if self.family == "4.2" else 1)
            rotation = math.atan2(rc, ra) * RAD_DEG
        else:
            scale_x, scale_y, shear_y = 0.0, math.hypot(rb, rd), 0.0
            rotation = 90 - math.atan2(rd, rb) * RAD_DEG
        self.applied = [ax, ay, rotation, scale_x, scale_y, 0.0, shear_y]


def _wrap180(degrees: float) -> float:
    if degrees > 180:
        return degrees - 360
    if degrees < -180:
        return degrees + 360
    return degrees
