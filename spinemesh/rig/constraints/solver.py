"""The update cache: a skeleton's bones and constraints sorted once as each runtime family sorts
them, then played (:func:`update_world`); the setup pose (:func:`setup_pose`), and which bones
come out exact.

The one loop every constraint kind is applied in (:func:`_apply` calls :mod:`.ik`,
:mod:`.transform_constraint` and :mod:`.path`); physics is stepped by :mod:`spinemesh.rig.physics`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from ...errors import SpineMeshError
from ...skeleton import iter_skins
from ...skeleton_check import is_int
from ..binding import parse_vertices
from ..transform import INHERIT_MODES, _num, inherit_mode, local_values
from ..transform43 import Unmapped, transform_apply_43
from .families import constraints_of, is_43, path_slot, posing_family, runtime_family
from .ik import ik_one, ik_two
from .path import path_apply, path_world_vertices
from .pose_bone import PoseBone
from .transform_constraint import TransformMix, transform_apply


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
