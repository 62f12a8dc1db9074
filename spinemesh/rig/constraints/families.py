"""Which runtime family poses a skeleton (3.8 to 4.2, and 4.3 posed as 4.2 where its constraints
allow), and a skeleton's constraints of one kind, whichever list of its version holds them.

Separate because the solver, the animation sampler (:mod:`spinemesh.anim.pose`) and the bone
choice read these without solving anything.
"""

from __future__ import annotations

from ...skeleton_version import doc_major_minor
from ..transform43 import PROPERTIES

#: Runtime families whose setup pose is reproduced, by the skeleton's ``spine`` version prefix.
FAMILIES = ("3.8", "4.0", "4.1", "4.2")


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
    (:func:`.solver.setup_pose`) and every animated pose (:class:`spinemesh.anim.Sampler`) alike.

    3.8 to 4.2: :func:`runtime_family`. 4.3: ``"4.2"`` when its constraints are IK, transform,
    path, physics and sliders (IK posed as 4.2 does, the same math, checked against spine-core
    4.3; transform constraints in 4.3's property-mapping form, :mod:`..transform43`; physics as
    4.3 steps it, :class:`~..physics.PhysicsSettings` ``lagged``; path constraints as 4.2 with
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
