"""The setup pose with its constraints applied, as the official runtimes 3.8 to 4.3 compute it.

A game that loads a skeleton sets it to the setup pose and calls ``updateWorldTransform``
once: the runtime walks an *update cache*, a list of bones and constraints sorted once per
skeleton, in which every constraint comes after the bones it reads and every bone a
constraint moves is updated again after it. This module builds that list the way each
runtime family builds it (3.8, 4.0, 4.1, 4.2 differ in details noted where they matter),
then plays it once: bones take their world transform from their parent; IK constraints
(one and two bones: mix, bend direction, compress, stretch, uniform, softness) turn and
scale their bones towards the target; transform constraints (world or local, absolute or
relative) pull their bones' transforms towards the target's; path constraints (position,
spacing and rotate modes, constant speed or not, open or closed paths) lay their bones along
the target slot's path.

4.3 skeletons are posed in the family :func:`posing_family` names, by :func:`setup_pose` and
:class:`spinemesh.anim.Sampler` alike: 4.3 transform constraints map properties
(:mod:`.transform43`), and 4.3 bones take their local values back from a changed world transform
lazily, as 4.3 does.

Each bone carries an *exact* flag. A 3.8 path constraint the 3.8 runtimes lay apart
(:func:`lays_apart_38`: the official one, which this module follows, and pixi-spine's port)
leaves its bones not exact in :func:`setup_pose`, the pose bindings are made in (the sampler's
poses are the official runtime's, exact). A constraint only some skins activate, a 4.3 skeleton with a constraint :func:`posing_family` does not solve,
a slider without its player (the sampler's: :func:`setup_pose` has none), or one older than 3.8
(no runtime to check against) leaves the bones it moves not
exact, with the reason, and so does any constraint that reads a bone that is not exact;
children of a bone that is not exact are not exact. Physics constraints (4.2, 4.3) leave the
setup pose as it is. The math follows the public runtime sources (EsotericSoftware
spine-runtimes, spine-ts); the implementation is ours.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import SpineMeshError
from ..skeleton import iter_skins
from ..skeleton_check import is_int
from ..skeleton_version import doc_major_minor
from .binding import deformed, parse_vertices, setup_world
from .transform import (
    DEG_RAD,
    INHERIT_MODES,
    PI,
    RAD_DEG,
    _num,
    float_divide,
    inherit_mode,
    local_values,
    world_numbers,
    wrap_pi,
    wrap_turns,
)
from .transform43 import PROPERTIES, Unmapped, local_from_world_43, transform_apply_43

#: Runtime families whose setup pose is reproduced, by the skeleton's ``spine`` version prefix.
FAMILIES = ("3.8", "4.0", "4.1", "4.2")

RAD = DEG_RAD


def runtime_family(doc: dict) -> str | None:
    """``"3.8"``, ``"4.0"``, ``"4.1"`` or ``"4.2"`` from ``skeleton.spine``'s leading numbers
    (the runtime a game of that version loads it with); None for others."""
    known = doc_major_minor(doc)  # "4.1-from-4.2.33": a 4.2 project exported for 4.1
    family = "%d.%d" % known if known else None
    return family if family in FAMILIES else None


def is_43(doc: dict) -> bool:
    """Whether ``skeleton.spine`` says 4.3 (one ``constraints`` list, 4.3's bones and sliders)."""
    return doc_major_minor(doc) == (4, 3)


#: The timelines of a 4.3 slider's animation that are played (bone transforms; events change nothing).
SLIDER_TIMELINES = {"rotate", "translate", "translatex", "translatey", "scale", "scalex", "scaley", "shear",
                    "shearx", "sheary"}


def slider_played(doc: dict, c: dict) -> bool:
    """Whether a 4.3 slider is played (by :class:`spinemesh.anim.pose.SliderPlayer`): its animation
    poses bones only (no slot, deform, draw order, constraint or inherit timeline), and a driving
    bone reads a known property."""
    anim = (doc.get("animations") or {}).get(c.get("animation"))
    if not isinstance(anim, dict) or set(anim) - {"bones", "events"}:
        return False
    bones = anim.get("bones") or {}
    if not isinstance(bones, dict) or any(not isinstance(t, dict) or set(t) - SLIDER_TIMELINES
                                          for t in bones.values()):
        return False
    return c.get("bone") is None or c.get("property") in PROPERTIES


def posing_family(doc: dict) -> str | None:
    """The runtime family whose update cache poses ``doc``, for the setup pose
    (:func:`setup_pose`) and every animated pose (:class:`spinemesh.anim.Sampler`) alike.

    3.8 to 4.2: :func:`runtime_family`. 4.3: ``"4.2"`` when its constraints are IK, transform,
    path, physics and sliders (IK posed as 4.2 does, the same math, checked against spine-core
    4.3; transform constraints in 4.3's property-mapping form, :mod:`.transform43`; physics as
    4.3 steps it, :class:`~.physics.PhysicsSettings` ``lagged``; path constraints as 4.2 with
    4.3's changes; sliders that :func:`slider_played` plays); None otherwise (constraints not
    solved: the bones they move are not exact).

    Examples
    --------
    >>> posing_family({"skeleton": {"spine": "4.3.23"}, "constraints": [{"type": "ik"}]})
    '4.2'
    >>> posing_family({"skeleton": {"spine": "4.3.23"}, "constraints": [{"type": "unknown"}]}) is None
    True
    """
    if not is_43(doc):
        return runtime_family(doc)
    items = doc.get("constraints")
    items = [c for c in items if isinstance(c, dict)] if isinstance(items, list) else []
    if not all(slider_played(doc, c) for c in items if c.get("type") == "slider"):
        return None
    return "4.2" if {c.get("type") for c in items} <= {"ik", "physics", "transform", "path", "slider"} else None


def constraints_of(doc: dict, kind: str) -> list[dict]:
    """Constraints of one kind: the ``ik``/``transform``/``path``/``physics`` lists (3.x-4.2),
    or the entries of 4.3's single ``constraints`` list whose ``type`` is ``kind``."""
    out = [c for c in doc.get(kind, []) or [] if isinstance(c, dict)]
    out += [c for c in doc.get("constraints", []) or [] if isinstance(c, dict) and c.get("type") == kind]
    return out


def path_slot(c: dict) -> str:
    """The slot whose path a path constraint follows: ``target`` (3.x-4.2), ``slot`` (4.3)."""
    return str(c["target"] if "target" in c else c.get("slot"))


@dataclass(eq=False)
class PoseBone:
    """One bone as the runtime holds it while it computes the pose.

    ``local`` is the setup pose (x, y, rotation, scaleX, scaleY, shearX, shearY); ``applied``
    the values its world transform was last computed from; ``m`` is the world transform's six
    numbers ``(a, b, worldX, c, d, worldY)``, plain floats, and :attr:`world` the same as an
    array, (2, 3) as in :mod:`.transform`. ``applied_exact`` says whether ``applied`` is
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
        Returns the world transform's six numbers (:func:`.transform.world_numbers`)."""
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


# -- IK ------------------------------------------------------------------------------------
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


# -- transform constraints -------------------------------------------------------------------
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


# -- path constraints (4.0-4.2) ---------------------------------------------------------------
#: Below this setup length a bone has no direction of its own for path spacing.
_EPSILON = 0.00001
_NONE, _BEFORE, _AFTER = -1, -2, -3


def path_world_vertices(att: dict, slot_bone: PoseBone, bones: list[PoseBone],
                        deform: list[float] | None = None) -> list[float] | None:
    """A path attachment's vertices in world space, flat ``[x0, y0, x1, y1, ...]``, or None when
    its vertices do not parse. Weighted when ``vertices`` is longer than ``2 * vertexCount``.
    ``deform``: an animation's deform of it (the runtime's layout: positions when unweighted,
    offsets per bone influence when weighted), used instead of the setup values."""
    count = att.get("vertexCount")
    verts = att.get("vertices")
    if not is_int(count) or count <= 0 or not isinstance(verts, list):
        return None
    try:  # the mesh reader's layout; a path has no uvs, only its vertex count
        mesh = parse_vertices({"uvs": [0.0] * (2 * count), "vertices": verts}, len(bones))
    except SpineMeshError:
        return None
    if deform is not None:
        mesh = deformed(mesh, deform)
    world = setup_world(mesh, [b.world for b in bones], slot_bone.index)
    return [float(v) for v in world.reshape(-1)]


def _curve_position(p, x1, y1, cx1, cy1, cx2, cy2, x2, y2, tangents, family) -> tuple[float, float, float | None]:
    """Point (and with ``tangents`` its direction, radians) at parameter ``p`` of a cubic Bezier.

    At the very start 4.x returns the first point and its handle's direction; 3.8 evaluates
    the curve a little further (p = 1e-4) and takes the tangent there."""
    if p == 0 or math.isnan(p):
        if family == "3.8":
            p = 1e-4
        else:
            return x1, y1, math.atan2(cy1 - y1, cx1 - x1)
    tt, u = p * p, 1 - p
    ttt, uu = tt * p, u * u
    uuu, ut = uu * u, u * p
    ut3 = ut * 3
    uut3, utt3 = u * ut3, ut3 * p
    x = x1 * uuu + cx1 * uut3 + cx2 * utt3 + x2 * ttt
    y = y1 * uuu + cy1 * uut3 + cy2 * utt3 + y2 * ttt
    if not tangents:
        return x, y, None
    if p < 0.001 and family != "3.8":
        return x, y, math.atan2(cy1 - y1, cx1 - x1)
    return x, y, math.atan2(y - (y1 * uu + cy1 * ut * 2 + cy2 * tt), x - (x1 * uu + cx1 * ut * 2 + cx2 * tt))


def _beyond(p: float, x1: float, y1: float, x2: float, y2: float, at_end: bool) -> tuple[float, float, float]:
    """A position ``p`` past either end of an open path, along its first or last segment."""
    r = math.atan2(y2 - y1, x2 - x1)
    x, y = (x2, y2) if at_end else (x1, y1)
    return x + p * math.cos(r), y + p * math.sin(r), r


def _put(out: list, o: int, xyr: tuple) -> None:
    out[o], out[o + 1] = xyr[0], xyr[1]
    if xyr[2] is not None:
        out[o + 2] = xyr[2]


def _seek(lengths, start: int, p: float) -> tuple[int, float]:
    """The index of the first cumulative length at or past ``p`` from ``start``, and ``p``
    made relative to that piece (0..1)."""
    i = start
    while i < len(lengths) - 1 and p > lengths[i]:
        i += 1
    if i == 0:
        return i, p / lengths[i]
    prev = lengths[i - 1]
    return i, (p - prev) / (lengths[i] - prev)


def path_positions(att: dict, world: list[float], spaces: list[float], tangents: bool, position: float,
                   position_mode: str, spacing_mode: str, family: str, v43: bool = False) -> list[float]:
    """``computeWorldPositions``: ``[x, y, r]`` per space along the path, flat, plus two.

    A path whose ``constantSpeed`` is off places its points by the curve lengths the editor
    stored; otherwise the lengths are measured here along the world vertices, as the runtime
    does, and each curve is walked in ten segments of about equal length (4.3, ``v43``: on a
    closed path, each point's segment sought from the curve's first)."""
    out = [0.0] * (len(spaces) * 3 + 2)
    if not att.get("constantSpeed", True):
        return _positions_by_stored_lengths(att, world, spaces, tangents, position, position_mode, spacing_mode,
                                            family, out)
    return _positions_at_constant_speed(att, world, spaces, tangents, position, position_mode, spacing_mode,
                                        family, out, v43)


def _start_and_multiplier(position: float, position_mode: str, spacing_mode: str, path_length: float,
                          spaces_count: int) -> tuple[float, float]:
    """The path position in path units, and the factor that turns spaces into path units."""
    if position_mode == "percent":
        position *= path_length
    multiplier = {"percent": path_length, "proportional": path_length / spaces_count}.get(spacing_mode, 1)
    return position, multiplier


def _on_path(spaces: list[float], multiplier: float, position: float, path_length: float, closed: bool,
             first: list[float], last: list[float], out: list[float]):
    """The runtime's walk over the spaces: yields ``(i, o, p, space)`` for each point that falls
    on the path (``p`` its distance along it, wrapped on a closed path; ``o`` its offset in
    ``out``). A point before or past the ends of an open path is written to ``out`` here, along
    the line through the first or last two points (``first``, ``last``: ``[x1, y1, x2, y2]``)."""
    for i in range(len(spaces)):
        o = 3 * i
        space = spaces[i] * multiplier
        position += space
        p = position
        if closed:
            p = math.fmod(p, path_length)
            if p < 0:
                p += path_length
        elif p < 0:
            _put(out, o, _beyond(p, *first, at_end=False))
            continue
        elif p > path_length:
            _put(out, o, _beyond(p - path_length, *last, at_end=True))
            continue
        yield i, o, p, space


def _positions_by_stored_lengths(att: dict, world: list[float], spaces: list[float], tangents: bool,
                                 position: float, position_mode: str, spacing_mode: str, family: str,
                                 out: list[float]) -> list[float]:
    """:func:`path_positions` with ``constantSpeed`` off: the attachment's ``lengths``."""
    closed = bool(att.get("closed", False))
    vertices_length = len(world)
    curve_count = vertices_length // 6
    lengths = [float(v) for v in att.get("lengths", [])]
    curve_count -= 1 if closed else 2
    path_length = lengths[curve_count]
    position, multiplier = _start_and_multiplier(position, position_mode, spacing_mode, path_length, len(spaces))
    w = world
    curve = 0
    for i, o, p, space in _on_path(spaces, multiplier, position, path_length, closed, w[2:6],
                                   w[vertices_length - 6:vertices_length - 2], out):
        curve, p = _seek(lengths, 0 if closed else curve, p)
        if closed and curve == curve_count:
            pts = w[vertices_length - 4:vertices_length] + w[0:4]
        else:
            pts = w[curve * 6 + 2:curve * 6 + 10]
        _put(out, o, _curve_position(p, *pts, tangents or (i > 0 and space == 0), family))
    return out


def _positions_at_constant_speed(att: dict, world: list[float], spaces: list[float], tangents: bool,
                                 position: float, position_mode: str, spacing_mode: str, family: str,
                                 out: list[float], v43: bool = False) -> list[float]:
    """:func:`path_positions` with ``constantSpeed`` on: lengths measured along the world vertices."""
    closed = bool(att.get("closed", False))
    vertices_length = len(world)
    curve_count = vertices_length // 6
    if closed:
        vertices_length += 2
        w = world[2:] + world[0:2]
        w = w + w[0:2]
    else:
        curve_count -= 1
        vertices_length -= 4
        w = world[2:2 + vertices_length]
    curves, path_length = _curve_lengths(w, curve_count)
    position, multiplier = _start_and_multiplier(position, position_mode, spacing_mode, path_length, len(spaces))
    segments: list[float] = []
    curve_length = 0.0
    curve = segment = 0
    prev_curve = _NONE
    pts = None
    for i, o, p, space in _on_path(spaces, multiplier, position, path_length, closed, w[0:4],
                                   w[vertices_length - 4:vertices_length], out):
        curve, p = _seek(curves, 0 if closed else curve, p)
        if curve != prev_curve:
            prev_curve = curve
            pts = w[curve * 6:curve * 6 + 8]
            segments = _segment_lengths(pts)
            curve_length = segments[9]
            segment = 0
        p *= curve_length
        segment, frac = _seek(segments, 0 if closed and v43 else segment, p)
        p = frac if segment == 0 else segment + frac
        _put(out, o, _curve_position(p * 0.1, *pts, tangents or (i > 0 and space == 0), family))
    return out


def _curve_lengths(w: list[float], curve_count: int) -> tuple[list[float], float]:
    """Cumulative lengths of the path's curves, each estimated from four forward differences
    as the runtime does, and the whole path's length (``w``: the curves' points, flat)."""
    curves = []
    path_length = 0.0
    x1, y1 = w[0], w[1]
    for i in range(curve_count):
        cx1, cy1, cx2, cy2, x2, y2 = w[2 + 6 * i:8 + 6 * i]
        tmpx, tmpy = (x1 - cx1 * 2 + cx2) * 0.1875, (y1 - cy1 * 2 + cy2) * 0.1875
        dddfx, dddfy = ((cx1 - cx2) * 3 - x1 + x2) * 0.09375, ((cy1 - cy2) * 3 - y1 + y2) * 0.09375
        ddfx, ddfy = tmpx * 2 + dddfx, tmpy * 2 + dddfy
        dfx = (cx1 - x1) * 0.75 + tmpx + dddfx * 0.16666667
        dfy = (cy1 - y1) * 0.75 + tmpy + dddfy * 0.16666667
        path_length += math.sqrt(dfx * dfx + dfy * dfy)
        dfx += ddfx
        dfy += ddfy
        ddfx += dddfx
        ddfy += dddfy
        path_length += math.sqrt(dfx * dfx + dfy * dfy)
        dfx += ddfx
        dfy += ddfy
        path_length += math.sqrt(dfx * dfx + dfy * dfy)
        dfx += ddfx + dddfx
        dfy += ddfy + dddfy
        path_length += math.sqrt(dfx * dfx + dfy * dfy)
        curves.append(path_length)
        x1, y1 = x2, y2
    return curves, path_length


def _segment_lengths(pts: list[float]) -> list[float]:
    """Cumulative lengths of one curve's ten segments, by forward differences as the runtime
    does (``pts``: its four points, flat)."""
    x1, y1, cx1, cy1, cx2, cy2, x2, y2 = pts
    segments = [0.0] * 10
    tmpx, tmpy = (x1 - cx1 * 2 + cx2) * 0.03, (y1 - cy1 * 2 + cy2) * 0.03
    dddfx, dddfy = ((cx1 - cx2) * 3 - x1 + x2) * 0.006, ((cy1 - cy2) * 3 - y1 + y2) * 0.006
    ddfx, ddfy = tmpx * 2 + dddfx, tmpy * 2 + dddfy
    dfx = (cx1 - x1) * 0.3 + tmpx + dddfx * 0.16666667
    dfy = (cy1 - y1) * 0.3 + tmpy + dddfy * 0.16666667
    curve_length = math.sqrt(dfx * dfx + dfy * dfy)
    segments[0] = curve_length
    for ii in range(1, 8):
        dfx += ddfx
        dfy += ddfy
        ddfx += dddfx
        ddfy += dddfy
        curve_length += math.sqrt(dfx * dfx + dfy * dfy)
        segments[ii] = curve_length
    dfx += ddfx
    dfy += ddfy
    curve_length += math.sqrt(dfx * dfx + dfy * dfy)
    segments[8] = curve_length
    dfx += ddfx + dddfx
    dfy += ddfy + dddfy
    curve_length += math.sqrt(dfx * dfx + dfy * dfy)
    segments[9] = curve_length
    return segments


def path_apply(d: dict, att: dict, world: list[float], target_bone: PoseBone, bones: list[PoseBone],
               family: str) -> bool:
    """A path constraint's update: bones placed along the path, turned along it; False when
    every mix is 0 (the runtime returns first). 3.8 reads ``rotateMix``/``translateMix`` and
    gives a bone shorter than the epsilon no space (4.x gives it the spacing)."""
    mixes = _path_mixes(d, family)
    if mixes is None:
        return False
    rotate_mode, spacing_mode = d.get("rotateMode", "tangent"), d.get("spacingMode", "length")
    tangents, scale = rotate_mode == "tangent", rotate_mode == "chainScale"
    v43 = bones[0].v43
    spaces, lengths = _path_spaces(bones, _num(d, "spacing", 0), spacing_mode, tangents, scale, family)
    positions = path_positions(att, world, spaces, tangents, _num(d, "position", 0),
                               d.get("positionMode", "percent"), spacing_mode, family, v43)
    offset = _num(d, "rotation", 0)
    if offset == 0:
        tip = rotate_mode == "chain"
    else:
        tip = False
        pa, pb, _, pc, pd, _ = target_bone.m
        offset *= RAD if pa * pd - pb * pc > 0 else -RAD
    _lay_bones(bones, positions, spaces, lengths, mixes, tangents, scale, tip, offset, family)
    return True


def _path_mixes(d: dict, family: str) -> tuple[float, float, float] | None:
    """A path constraint's ``(rotate, x, y)`` mixes; None when the runtime would do nothing
    (3.8: rotate and translate mixes not above 0; 4.x: all three 0)."""
    if family == "3.8":
        mix_rotate, mix_x = _num(d, "rotateMix", 1), _num(d, "translateMix", 1)
        mix_y = mix_x
        if mix_rotate <= 0 and mix_x <= 0:
            return None
    else:
        mix_rotate, mix_x = _num(d, "mixRotate", 1), _num(d, "mixX", 1)
        mix_y = _num(d, "mixY", mix_x)
        if mix_rotate == 0 and mix_x == 0 and mix_y == 0:
            return None
    return mix_rotate, mix_x, mix_y


def _path_spaces(bones: list[PoseBone], spacing: float, spacing_mode: str, tangents: bool, scale: bool,
                 family: str) -> tuple[list[float], list[float]]:
    """The spaces between the bones along the path (one more than the bones unless the rotate
    mode is tangent) and each bone's world length (for chain scale), by the spacing mode."""
    count = len(bones)
    spaces_count = count if tangents else count + 1
    spaces = [0.0] * spaces_count
    lengths = [0.0] * count
    if family == "3.8" and spacing_mode == "percent":
        # 3.8 (since 3.7): a percent spacing is the spacing, whatever the bones' scale; in chain
        # scale, a bone shorter than the epsilon is given none
        for i in range(spaces_count - 1):
            short = bones[i].length < _EPSILON
            if scale and not short:
                a, _, _, c, _, _ = bones[i].m
                lengths[i] = math.hypot(bones[i].length * a, bones[i].length * c)
            spaces[i + 1] = 0.0 if short and scale else spacing
    elif spacing_mode == "percent":
        for i in range(spaces_count - 1) if scale else ():
            a, _, _, c, _, _ = bones[i].m
            short = family != "4.2" and bones[i].length < _EPSILON  # 4.0-4.1 give short bones no length
            lengths[i] = 0.0 if short else math.hypot(bones[i].length * a, bones[i].length * c)
        spaces[1:] = [spacing] * (spaces_count - 1)
    else:
        total = 0.0
        for i in range(spaces_count - 1):
            bone = bones[i]
            setup = bone.length
            if setup < _EPSILON:
                lengths[i] = 0.0
                spaces[i + 1] = 0.0 if family == "3.8" else spacing
                continue
            a, _, _, c, _, _ = bone.m
            length = math.hypot(setup * a, setup * c)
            lengths[i] = length
            if spacing_mode == "proportional" and family != "3.8":
                spaces[i + 1] = length
                total += length
            else:
                # 4.3 gives a bone no negative length spacing
                ahead = (max(0.0, setup + spacing) if bone.v43 else setup + spacing) if spacing_mode == "length" \
                    else spacing
                spaces[i + 1] = ahead * length / setup
        if spacing_mode == "proportional" and total > 0:
            k = spaces_count / total * spacing
            spaces[1:] = [v * k for v in spaces[1:]]
    return spaces, lengths


def _lay_bones(bones: list[PoseBone], positions: list[float], spaces: list[float], lengths: list[float],
               mixes: tuple[float, float, float], tangents: bool, scale: bool, tip: bool, offset: float,
               family: str) -> None:
    """Each bone moved to its point on the path, scaled (chain scale) and turned along it, by the mixes."""
    mix_rotate, mix_x, mix_y = mixes
    bone_x, bone_y = positions[0], positions[1]
    for i, bone in enumerate(bones):
        p = 3 * (i + 1)
        if bone.v43:
            bone.modify_world()
        a, b, wx, c, dd, wy = bone.m
        wx += (bone_x - wx) * mix_x
        wy += (bone_y - wy) * mix_y
        x, y = positions[p], positions[p + 1]
        dx, dy = x - bone_x, y - bone_y
        if scale and lengths[i] != 0:
            s = (math.hypot(dx, dy) / lengths[i] - 1) * mix_rotate + 1
            a, c = a * s, c * s
        bone_x, bone_y = x, y
        if mix_rotate > 0:
            if tangents:
                r = positions[p - 1]
            elif spaces[i + 1] == 0:
                r = positions[p + 2]
            else:
                r = math.atan2(dy, dx)
            r -= math.atan2(c, a)
            if tip:
                cos, sin = math.cos(r), math.sin(r)
                bone_x += (bone.length * (cos * a - sin * c) - dx) * mix_rotate
                bone_y += (bone.length * (sin * a + cos * c) - dy) * mix_rotate
            else:
                r += offset
            r = wrap_pi(r) * mix_rotate
            cos, sin = math.cos(r), math.sin(r)
            a, b, c, dd = cos * a - sin * c, cos * b - sin * dd, sin * a + cos * c, sin * b + cos * dd
        bone.world = np.array([[a, b, wx], [c, dd, wy]])
        if family == "3.8":
            bone.applied_valid = False
        else:
            bone.update_applied()


# -- the update cache -------------------------------------------------------------------------
@dataclass
class _Constraint:
    kind: str                 # "ik", "transform", "path", "physics"
    name: str
    order: int
    data: dict
    bones: list[PoseBone]
    target: PoseBone | None   # the target bone (IK, transform), the target slot's bone (path)
    active: bool = True
    path: dict | None = None  # path: the target slot's setup attachment when it is a path
    reads: list[PoseBone] = field(default_factory=list)  # path: bones its vertices follow, sorted first
    path_deform: list[float] | None = None  # path: the deform an animation gives its attachment
    physics: object | None = None  # physics: its state between frames (rig.physics.PhysicsState)
    slider: object | None = None   # 4.3 slider: what applies its animation (spinemesh.anim sets it)
    v43: bool = False         # from 4.3's single list (a transform constraint maps properties)
    #: transform: its mixes read from the data last applied, kept with that very dict (the setup
    #: values, most frames: the same dict until a timeline keys them)
    mix_read: tuple = field(default=(None, None), compare=False, repr=False)

    def label(self) -> str:
        return f"{self.kind if self.kind != 'ik' else 'IK'} constraint {self.name!r}"


def slider_bones(doc: dict, c: dict) -> list[str]:
    """The bones a 4.3 slider poses: those its animation has bone timelines for, in order."""
    anim = (doc.get("animations") or {}).get(c.get("animation"))
    by_bone = anim.get("bones") if isinstance(anim, dict) else None
    return [str(n) for n, tls in (by_bone.items() if isinstance(by_bone, dict) else ())
            if isinstance(tls, dict) and any(isinstance(keys, list) and keys for keys in tls.values())]


def _read_constraints(doc: dict, by_name: dict[str, PoseBone]) -> list[_Constraint]:
    """Every IK, transform, path, physics and (4.3) slider constraint (document order within
    each kind); one that names a missing bone is left out (a runtime refuses such a skeleton).
    A slider's bones are those its animation poses, its target the bone that drives it, if any."""
    out = []
    for kind in ("ik", "transform", "path", "physics", "slider"):
        for c in constraints_of(doc, kind):
            names = c.get("bones") if kind not in ("physics", "slider") else [c.get("bone")]
            if kind == "slider":
                names = slider_bones(doc, c)
            names = names if isinstance(names, list) else []
            bones = [by_name.get(str(n)) for n in names]
            # 4.3 names a transform constraint's target bone "source" (what it reads).
            target = by_name.get(str(c.get("target", c.get("source")))) if kind in ("ik", "transform") else None
            if kind == "slider" and c.get("bone") is not None:
                target = by_name.get(str(c.get("bone")))
                if target is None:
                    continue
            if any(b is None for b in bones) or not bones or (kind in ("ik", "transform") and target is None):
                continue
            order = c.get("order", 0)
            order = order if is_int(order) else 0
            v43 = isinstance(doc.get("constraints"), list)
            if v43:  # 4.3: one list, in update order
                order = next(i for i, x in enumerate(doc["constraints"]) if x is c)
            out.append(_Constraint(kind, str(c.get("name")), order, c, bones, target, v43=v43))
    return out


class _Cache:
    """The runtime's update cache: ``sortBone``, ``sortReset`` and each constraint's sort."""

    def __init__(self, family: str):
        self.family = family
        self.items: list = []
        self.reset: list[PoseBone] = []   # 3.8: bones whose applied values are reset first

    def sort_bone(self, bone: PoseBone) -> None:
        if bone.sorted or not bone.active:
            return
        if bone.parent is not None:
            self.sort_bone(bone.parent)
        bone.sorted = True
        self.items.append(bone)

    def sort_reset(self, bones: list[PoseBone]) -> None:
        for bone in bones:
            if not bone.active:
                continue
            if bone.sorted:
                self.sort_reset(bone.children)
            bone.sorted = False

    def _in_cache(self, bone: PoseBone) -> bool:
        return any(item is bone for item in self.items)

    def sort(self, c: _Constraint) -> None:
        if c.kind == "ik":
            self.sort_bone(c.target)
            parent = c.bones[0]
            self.sort_bone(parent)
            if len(c.bones) > 1:
                child = c.bones[-1]
                if self.family == "3.8":
                    if not self._in_cache(child):
                        self.reset.append(child)
                else:
                    self.sort_bone(child)
            self.items.append(c)
            self.sort_reset(parent.children)
            c.bones[-1].sorted = True
        elif c.kind == "transform" and c.v43:
            # 4.3: a local source is read as animated, not posed first; bones changed in their
            # local values are posed after the constraint.
            world_target = c.data.get("localTarget") is not True
            if c.data.get("localSource") is not True:
                self.sort_bone(c.target)
            if world_target:
                for bone in c.bones:
                    self.sort_bone(bone)
            self.items.append(c)
            for bone in c.bones:
                self.sort_reset(bone.children)
            for bone in c.bones:
                bone.sorted = world_target
        elif c.kind == "transform":
            self.sort_bone(c.target)
            for bone in c.bones:
                if c.data.get("local", False):
                    if bone.parent is not None:
                        self.sort_bone(bone.parent)
                    if self.family == "3.8":
                        if not self._in_cache(bone):
                            self.reset.append(bone)
                    else:
                        self.sort_bone(bone)
                else:
                    self.sort_bone(bone)
            self._push_and_reset(c)
        elif c.kind == "path":
            for bone in c.reads:  # the bones every path attachment of the slot follows
                self.sort_bone(bone)
            for bone in c.bones:
                self.sort_bone(bone)
            self._push_and_reset(c)
        elif c.kind == "slider":
            # 4.3: the driving bone posed first (unless read as animated); the bones its
            # animation poses are posed again after it
            if c.target is not None and c.data.get("local") is not True:
                self.sort_bone(c.target)
            self.items.append(c)
            for bone in c.bones:
                bone.sorted = False
                self.sort_reset(bone.children)
        else:  # physics (4.2)
            self.sort_bone(c.bones[0])
            self.items.append(c)
            self.sort_reset(c.bones[0].children)
            c.bones[0].sorted = True

    def _push_and_reset(self, c: _Constraint) -> None:
        self.items.append(c)
        for bone in c.bones:
            self.sort_reset(bone.children)
        for bone in c.bones:
            bone.sorted = True


def _inputs_exact(c: _Constraint, where: str = "in the setup pose") -> tuple[bool, str]:
    """Whether every bone the constraint reads is exact, else the reason."""
    read = ([c.target] if c.target is not None else []) + c.reads
    for bone in c.bones:
        read += [bone] + ([bone.parent] if bone.parent is not None else [])
    for bone in read:
        if bone is not None and not bone.exact:
            return False, f"moved {where} by the {c.label()}, which reads {bone.name!r}: {bone.why}"
    return True, ""


def _mark(bones: list[PoseBone], why: str) -> None:
    for bone in bones:
        bone.exact = bone.applied_exact = False
        bone.why = why


def _run(c: _Constraint, family: str, skeleton: list[PoseBone], where: str = "in the setup pose") -> None:
    """One constraint's update in the cache (``skeleton``: every bone, by index)."""
    if c.kind == "physics":
        # The setup pose resets physics, which leaves the bone as it is; an animation steps it
        # (``c.physics``, set by spinemesh.anim) frame after frame.
        if c.physics is not None:
            bone = c.bones[0]
            try:
                c.physics.update(bone, c.data)
            except (ValueError, OverflowError):  # springs driven past what a float holds (an angle of NaN)
                bone.set_world((math.nan,) * 6)
            if not bone.finite():  # the runtimes draw such a bone nowhere: flagged, those below it too
                _mark([bone], f"moved {where} by the {c.label()}, whose springs diverge (not a finite number)")
        return
    ok, why = _inputs_exact(c, where)
    try:
        if not _apply(c, family, skeleton):
            return
    except (ZeroDivisionError, ValueError, OverflowError, IndexError):
        # A degenerate pose (a zero scale, a zero-length path) where the runtime divides by zero.
        ok, why = False, f"moved {where} by the {c.label()}, degenerate there"
    except _Unsolved as e:
        ok, why = False, f"moved {where} by the {c.label()} ({e})"
    if ok and not all(b.finite() for b in c.bones):
        ok, why = False, f"moved {where} by the {c.label()}, not finite there"
    if not ok:
        _mark(c.bones, why)
    else:
        for bone in c.bones:
            bone.applied_exact = True
            bone.exact = True


class _Unsolved(Exception):
    """A constraint this module does not apply (the reason is the message)."""


def _apply(c: _Constraint, family: str, skeleton: list[PoseBone]) -> bool:
    """Apply one IK, transform or path constraint to its bones' transforms; False when the
    runtime returns without touching them (mixes 0, no path attachment in the setup pose)."""
    d = c.data
    if c.kind == "slider":
        if c.slider is None:
            raise _Unsolved("sliders are played by spinemesh.anim's sampler only")
        return c.slider.update(c)
    if c.kind == "path":
        if c.path is None:
            return False
        world = path_world_vertices(c.path, c.target, skeleton, c.path_deform)
        if world is None or len(world) < 8:
            raise _Unsolved("its path does not parse")
        return path_apply(d, c.path, world, c.target, c.bones, family)
    if c.kind == "ik":
        mix = _num(d, "mix", 1)
        if mix == 0 and family != "3.8":
            return False
        scale_y = "uniform" if d.get("uniform", False) else "none"
        if c.v43:  # 4.3 names how a stretch scales y: "uniform" (4.2's uniform) or "volume"
            scale_y = d.get("scaleY") if d.get("scaleY") in ("uniform", "volume") else "none"
        tx, ty = c.target.m[2], c.target.m[5]
        if len(c.bones) == 1 and c.bones[0].parent is not None:
            ik_one(c.bones[0], tx, ty, bool(d.get("compress", False)), bool(d.get("stretch", False)),
                   scale_y, mix, family)
        elif len(c.bones) == 2 and c.bones[0].parent is not None and c.bones[1].parent is c.bones[0]:
            # the runtimes solve in the space of the first bone's parent (the root, for a chain under it)
            bend = 1 if d.get("bendPositive", True) else -1
            ik_two(c.bones[0], c.bones[1], tx, ty, bend, bool(d.get("stretch", False)),
                   scale_y, _num(d, "softness", 0), mix, family)
        else:
            raise _Unsolved("a chain it cannot solve")
        return True
    if c.v43:
        try:
            return transform_apply_43(d, c.target, c.bones)
        except Unmapped as e:
            raise _Unsolved(str(e)) from None
    read, mix = c.mix_read
    if d is not read:
        mix = TransformMix.from_json(d, family)
        c.mix_read = (d, mix)
    return transform_apply(mix, c.target, c.bones, family)


def _moves_something(c: _Constraint, family: str | None) -> bool:
    """Whether the constraint changes its bones in the setup pose (mix 0 leaves them)."""
    if c.kind == "ik":
        return _num(c.data, "mix", 1) != 0
    if c.kind == "transform":
        return not TransformMix.from_json(c.data, family).moves_nothing("4.2")
    if c.kind == "path":
        if any(k in c.data for k in ("rotateMix", "translateMix")):  # 3.x names
            return _num(c.data, "rotateMix", 1) != 0 or _num(c.data, "translateMix", 1) != 0
        mix_x = _num(c.data, "mixX", 1)
        return any(m != 0 for m in (_num(c.data, "mixRotate", 1), mix_x, _num(c.data, "mixY", mix_x)))
    return c.kind == "slider"


def setup_pose(doc: dict) -> list[PoseBone]:
    """Every bone's setup-pose world transform with the constraints applied, in document order.

    Parameters
    ----------
    doc : dict
        A skeleton document (JSON layout; binary skeletons as :func:`spinemesh.skeleton.load_skeleton`
        reads them).

    Returns
    -------
    list of PoseBone
        ``world`` (2, 3) per bone; ``exact`` False, with ``why``, for bones whose setup transform
        is not reproduced (see the module's docstring). Bones only some skins activate are not
        posed by the runtime without that skin: they are computed from their parent, as if the
        skin were set, and never moved by a constraint here.
    """
    return _solve(doc)[0]


@dataclass(eq=False)
class Rig:
    """A skeleton's bones and constraints with the runtime's update cache, sorted once.

    ``family`` is None for versions whose constraints are not solved (bones then follow their
    parents only). Pose it with :func:`update_world` after setting each bone's ``local`` values
    (and, for an animation, its ``inherit`` mode and the constraints' ``data``); the cache stays
    valid for every pose of one skin.
    """

    family: str | None
    bones: list[PoseBone]
    constraints: list[_Constraint]
    items: list
    doc: dict = field(repr=False, default_factory=dict)
    where: str = "in the setup pose"   # how bones' reasons name the pose (an animation sets its own)


def skin_names(skin: str | tuple[str, ...] | None) -> list[str]:
    """The skins ``skin`` stands for, the first looked in first: none, one, or several combined
    (a tuple: as a game combines them with ``Skin.addSkin``, the first listed added last, so that
    its attachments win)."""
    if skin is None:
        return []
    return [skin] if isinstance(skin, str) else [str(s) for s in skin]


def _skin_entry(doc: dict, skin: str | tuple[str, ...] | None) -> dict:
    """The skin's own JSON object (3.8+: ``bones`` and constraint name lists), or ``{}``; for
    several skins (:func:`skin_names`) their lists joined, as a combined skin holds them."""
    if skin is None or not isinstance(doc.get("skins"), list):
        return {}
    entries = [next((s for s in doc["skins"] if isinstance(s, dict) and s.get("name") == name), {})
               for name in skin_names(skin)]
    if len(entries) == 1:
        return entries[0]
    return {kind: [n for e in entries for n in (e.get(kind) if isinstance(e.get(kind), list) else [])]
            for kind in ("bones", "ik", "transform", "path", "physics", "slider")}


def build_rig(doc: dict, skin: str | tuple[str, ...] | None = None, family: str | None = None) -> Rig:
    """The skeleton's bones (setup local values) and its update cache, as ``Skeleton.updateCache``
    sorts it with ``skin`` set (None: no skin, as :func:`setup_pose` poses it; a tuple: those
    skins combined, :func:`skin_names`).

    A bone only some skins need is active when ``skin`` lists it (and so are its parents); a
    constraint only some skins need, when ``skin`` lists it and its target is active.
    ``family`` overrides the runtime family read from the document.
    """
    family = family or runtime_family(doc)
    four_three = is_43(doc)
    nodes = [b for b in doc.get("bones", []) if isinstance(b, dict)]
    index = {str(b.get("name")): i for i, b in enumerate(nodes)}
    bones: list[PoseBone] = []
    for i, node in enumerate(nodes):
        p = index.get(node.get("parent")) if node.get("parent") is not None else None
        if p is not None and p >= i:
            p = None  # malformed order: treat as a root, and do not trust it
        parent = bones[p] if p is not None else None
        mode = inherit_mode(node)
        bone = PoseBone(i, str(node.get("name")), parent, mode if mode in INHERIT_MODES else "normal",
                        _num(node, "length", 0), local_values(node), family or "4.2")
        bone.active = node.get("skin") is not True
        bone.applied = list(bone.local)
        if four_three:
            bone.flat, bone.v43 = 1e-10, True
        if parent is not None:
            parent.children.append(bone)
        bones.append(bone)
    by_name = {b.name: b for b in bones}
    entry = _skin_entry(doc, skin)
    for name in entry.get("bones") or []:
        bone = by_name.get(str(name))
        while bone is not None:
            bone.active = True
            bone = bone.parent
    listed = {(kind, str(n)) for kind in ("ik", "transform", "path", "physics", "slider")
              for n in entry.get(kind) or []}
    constraints = _read_constraints(doc, by_name)
    if family is None:
        return Rig(None, bones, constraints, [], doc)

    # Constraints only some skins activate (or aiming at a bone only some skins activate) are
    # not in the cache of a skeleton without that skin.
    for c in constraints:
        needed = c.data.get("skin") is True and (c.kind, c.name) not in listed
        reads = [c.target] if c.target is not None else []
        if c.kind == "physics":
            reads = c.bones[:1]
        elif c.kind == "slider":
            reads = []  # active whatever its bone (an inactive one leaves it still, each update)
        c.active = all(b.active for b in reads) and not needed
        if c.kind == "path":
            _read_path_target(c, doc, by_name, bones, skin)
            c.active = not needed and c.target is not None and c.target.active
    for bone in bones:
        bone.sorted = not bone.active
    cache = _Cache(family)
    kinds = ("ik", "transform", "path") + (("physics",) if family == "4.2" else ())
    kinds += ("slider",) if four_three else ()
    for i in range(sum(1 for c in constraints if c.kind in kinds)):
        for kind in kinds:
            c = next((c for c in constraints if c.kind == kind and c.order == i), None)
            if c is not None:
                if c.active:
                    cache.sort(c)
                break
    for bone in bones:
        cache.sort_bone(bone)
    return Rig(family, bones, constraints, cache.items, doc)


def update_world(rig: Rig) -> None:
    """``updateWorldTransform``: every active bone's world transform from its ``local`` values,
    the constraints in the cache applied (their current ``data``), as the runtime does.

    Bones start exact; a constraint not reproduced marks the bones it moves (see the module's
    docstring). Versions whose constraints are not solved pose bones from their parents only.
    """
    for bone in rig.bones:
        bone.applied = list(bone.local)
        bone.applied_valid = bone.applied_exact = bone.exact = True
        bone.world_now = bone.local_stale = False
        bone.why = ""
    if rig.family is None:
        _without_constraints(rig.bones, rig.constraints, rig.doc, rig.where)
        return
    for item in rig.items:
        if isinstance(item, PoseBone):
            item.update()
        else:
            _run(item, rig.family, rig.bones, rig.where)


def _solve(doc: dict) -> tuple[list[PoseBone], list[_Constraint]]:
    """:func:`setup_pose`'s bones, and the constraints read (``active`` as in the runtime's cache)."""
    rig = build_rig(doc, family=posing_family(doc))
    bones, constraints, family = rig.bones, rig.constraints, rig.family
    if family is None:
        return _without_constraints(bones, constraints, doc), constraints
    update_world(rig)
    active = {id(c) for c in constraints if c.active}
    for bone in bones:
        if not bone.active:  # not posed by a runtime without its skin: from its parent
            bone.update_with(bone.local)
            bone.exact = bone.parent is None or bone.parent.exact
            if not bone.exact:
                bone.why = f"below {bone.parent.name!r}: {bone.parent.why}"
    for c in constraints:
        if id(c) not in active and _moves_something(c, family):
            _mark(c.bones, f"moved by the {c.label()}, which only some skins activate")
    if family == "3.8":
        # Posed as the official 3.8 runtime poses them, but not bound: the 3.8 runtimes in use
        # lay them apart (pixi-spine's port, the one the proofs play, otherwise), and a binding
        # is proved in a runtime before it is written.
        changed = True
        while changed:  # and the bones below them, and those of constraints that read them
            changed = False
            for c in constraints:
                if not c.active or not any(b.exact for b in c.bones):
                    continue
                if c.kind == "path" and lays_apart_38(c.data):
                    why = (f"moved by the {c.label()} (3.8 chain paths: the 3.8 runtimes lay its bones apart, "
                           "so nothing is bound to them)")
                else:
                    ok, why = _inputs_exact(c)
                    if ok:
                        continue
                _mark([b for b in c.bones if b.exact], why)
                changed = True
            _propagate(bones)
    _propagate(bones)
    return bones, constraints


def lays_apart_38(path: dict) -> bool:
    """Whether the 3.8 runtimes lay a 3.8 path constraint's bones apart (``path``: its JSON):
    the official one as this module does, pixi-spine's 3.8 port never turning bones in a chain
    mode to the next point and spacing them as before 3.7 (a fixed spacing not scaled by the
    bone, a percent one in chain scale scaled)."""
    rotate, spacing = path.get("rotateMode", "tangent"), path.get("spacingMode", "length")
    return ((rotate != "tangent" and _num(path, "rotateMix", 1) > 0) or spacing == "fixed"
            or (spacing == "percent" and rotate == "chainScale"))


def _read_path_target(c: _Constraint, doc: dict, by_name: dict[str, PoseBone], bones: list[PoseBone],
                      skin: str | tuple[str, ...] | None = None) -> None:
    """A path constraint's target slot: its bone, its setup attachment when that is a path of
    the default skin (the only skin of a skeleton without one), and the bones that every path
    attachment of the slot in any skin follows (the runtime sorts them before the constraint)."""
    slots = [s for s in doc.get("slots", []) if isinstance(s, dict)]
    slot = next((s for s in slots if s.get("name") == path_slot(c.data)), None)
    c.target = by_name.get(str(slot.get("bone"))) if slot else None
    if c.target is None:
        return
    skins = list(iter_skins(doc))
    setup_name = slot.get("attachment")
    default = next((atts for name, atts in skins if name == "default"), {})
    setup = (default.get(slot["name"]) or {}).get(setup_name) if setup_name is not None else None
    c.path = setup if isinstance(setup, dict) and setup.get("type") == "path" else None
    ordered = [atts.get(slot["name"]) or {} for wanted in skin_names(skin) for name, atts in skins if name == wanted]
    ordered += [atts.get(slot["name"]) or {} for name, atts in skins if name == "default"]
    ordered += [atts.get(slot["name"]) or {} for _, atts in skins] + [{"": c.path} if c.path else {}]
    for attachments in ordered:
        for att in attachments.values() if isinstance(attachments, dict) else ():
            if not isinstance(att, dict) or att.get("type") != "path":
                continue
            count = att.get("vertexCount")
            verts = att.get("vertices") if isinstance(att.get("vertices"), list) else []
            if isinstance(count, int) and len(verts) != 2 * count:  # weighted: its bones
                if not 0 <= count <= len(verts):  # more vertices than numbers: unreadable, and unallocated
                    continue
                try:
                    mesh = parse_vertices({"uvs": [0.0] * (2 * count), "vertices": verts}, len(bones))
                except SpineMeshError:
                    continue  # the constraint marks its bones when it cannot read its path
                c.reads += [bones[b] for b in mesh.bones()]
            else:
                c.reads.append(c.target)


def _propagate(bones: list[PoseBone]) -> None:
    """A bone below one that is not exact is not exact either (parents come first)."""
    for bone in bones:
        if bone.exact and bone.parent is not None and not bone.parent.exact:
            bone.exact, bone.why = False, f"below {bone.parent.name!r}: {bone.parent.why}"


def _without_constraints(bones: list[PoseBone], constraints: list[_Constraint], doc: dict,
                         where: str = "in the setup pose") -> list[PoseBone]:
    """Versions whose runtime is not reproduced: bones from their parents, and every bone a
    constraint moves in the setup pose (and those below it) not exact."""
    version = (doc.get("skeleton") or {}).get("spine")
    four_three = bool(doc.get("constraints"))
    if is_43(doc):  # posing_family solves 4.3 but for what it does not play
        why = ("4.3 constraints are solved where each is an IK, transform, path, physics or slider "
               "constraint whose animation poses bones only; this skeleton has another")
    else:
        why = f"constraints are solved for 3.8-4.3 skeletons; this one is {version or 'of an unknown version'}"
    for bone in bones:
        bone.update_with(bone.local)
    for c in constraints:
        moves = True if (four_three and c.kind == "transform") else _moves_something(c, None)
        if c.kind != "physics" and moves:
            for bone in c.bones:
                if bone.exact:
                    bone.exact = False
                    bone.why = f"moved {where} by the {c.label()} ({why})"
    _propagate(bones)
    return bones


def solved_constraints(doc: dict) -> dict[str, list[str]]:
    """IK, transform and path constraints this module applies that move bones in the setup pose
    of ``doc`` (a mix not 0, active without a skin; not 3.8 paths :func:`lays_apart_38`), by name,
    with the names of the bones they move; empty for versions other than 3.8 to 4.2 (those the
    runtime tool plays)."""
    family = runtime_family(doc)
    if family is None:
        return {}
    _, constraints = _solve(doc)
    return {c.name: [b.name for b in c.bones] for c in constraints
            if c.kind in ("ik", "transform", "path") and c.active and _moves_something(c, family)
            and not (family == "3.8" and c.kind == "path" and lays_apart_38(c.data))}
