"""Bones of a skeleton document and their world transforms in the setup pose.

A bone's world transform (:mod:`.transform`) is computed the way the official runtimes
compute it for every version this package reads (3.5 to 4.3; 3.5 computes it as 3.6 does).

IK, transform and path constraints move their bones after this computation, even in the
setup pose (unless all their mixes are 0): :mod:`.constraints` applies them as the runtimes
3.8-4.2 do.
Bones whose setup world transform it does not reproduce, and everything below them, are
marked *not exact*, and nothing is bound to them.
"""

from __future__ import annotations

import operator
from dataclasses import dataclass, field

import numpy as np

from .constraints.families import constraints_of
from .constraints.solver import setup_pose


@dataclass
class Bone:
    """One bone's setup data and its setup-pose world transform.

    ``world`` has shape (2, 3); ``exact`` is False, with ``why``, when the runtime's setup
    world transform cannot be reproduced (a constraint moves the bone or an ancestor).
    """

    index: int
    name: str
    parent: int | None
    length: float
    world: np.ndarray
    exact: bool = True
    why: str = ""
    skin_required: bool = False
    target_of: str = ""              # a constraint that aims at this bone (a control bone)
    children: list[int] = field(default_factory=list)
    _segment: np.ndarray | None = field(default=None, init=False, repr=False, compare=False)
    _span: float | None = field(default=None, init=False, repr=False, compare=False)

    def segment(self) -> np.ndarray:
        """The bone's segment in world space, shape (2, 2): origin, then origin + length along local x.

        Computed once (read-only): the bone choice asks for it of every bone near each mesh, a
        few million times on a particle rig of 800 bones.
        """
        if self._segment is None:
            origin = self.world[:, 2]
            self._segment = np.array([origin, origin + self.world[:, 0] * self.length])
            self._segment.flags.writeable = False
        return self._segment

    def span(self) -> float:
        """The length of the bone's segment in world space (its length times its world scale)."""
        if self._span is None:
            seg = self.segment()
            self._span = float(np.linalg.norm(seg[1] - seg[0]))
        return self._span

    def invertible(self) -> bool:
        return abs(float(np.linalg.det(self.world[:, :2]))) > 1e-9


#: The bones :func:`bone_segments` stacked last (a tuple of them) and their segments, as one
#: tuple replaced whole (threads of one worker read it: a reader sees one list's or another's).
_STACKED: list = [((), None)]


def bone_segments(bones) -> np.ndarray:
    """Every bone's :meth:`Bone.segment`, stacked: shape (len(bones), 2, 2), read-only.

    The bone choices ask for them three times for each mesh: the last bones' are kept. The bones
    themselves are held and compared one by one, by identity (12 µs for 800 bones; stacking them
    takes 300 µs), so a list changed in place (a bone replaced, one added) or a new list at the
    old one's address is never taken for the last.
    """
    last, out = _STACKED[0]
    if out is not None and len(last) == len(bones) and all(map(operator.is_, last, bones)):
        return out
    held = tuple(bones)
    out = np.stack([bone.segment() for bone in held]).reshape(-1, 2, 2)
    out.flags.writeable = False
    _STACKED[0] = (held, out)
    return out


def _constraint_targets(doc: dict, index: dict[str, int]) -> dict[int, str]:
    """Bones that IK, transform or path constraints aim at, with the constraint's name."""
    out: dict[int, str] = {}
    for kind in ("ik", "transform", "path"):
        for c in constraints_of(doc, kind):
            if c.get("target") in index:
                out.setdefault(index[c["target"]], f"{kind} constraint {c.get('name')!r}")
    return out


def skeleton_bones(doc: dict) -> list[Bone]:
    """Every bone of ``doc`` with its setup-pose world transform, in document order.

    Bones come parents first (the format requires it). The setup pose is the runtime's,
    constraints applied (:func:`.constraints.solver.setup_pose`); a bone whose transform that module
    does not reproduce, and every bone below it, is marked not exact with the reason; so is a
    bone whose transform is not invertible (a zero scale), which nothing can be bound to.
    """
    nodes = [b for b in doc.get("bones", []) if isinstance(b, dict)]
    index = {str(b.get("name")): i for i, b in enumerate(nodes)}
    targets = _constraint_targets(doc, index)
    bones: list[Bone] = []
    for posed in setup_pose(doc):
        i = posed.index
        p = posed.parent.index if posed.parent is not None else None
        bone = Bone(i, posed.name, p, posed.length, posed.world, posed.exact, posed.why)
        bone.skin_required = nodes[i].get("skin") is True
        bone.target_of = targets.get(i, "")
        if p is not None:
            bones[p].children.append(i)
        if bone.exact and not bone.invertible():
            bone.exact, bone.why = False, "zero scale: its transform cannot be inverted"
        bones.append(bone)
    return bones
