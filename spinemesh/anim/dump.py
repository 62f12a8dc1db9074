"""Poses in the layout of the official-runtime harness's dump, and how far two dumps differ.

The layout (``poses``: ``label``, ``anim``, ``time``, ``bones``, ``attachments``) is the one
the project's runtime harness writes, so a pose written by ``spinemesh pose`` can be compared
with the official runtime's number by number (:func:`pose_errors`).
"""

from __future__ import annotations

import math

import numpy as np

from .pose import POSE_ERRORS, Sampler, _clean, steps_of, summed


def js_number(value: float) -> str:
    """A number as JavaScript writes it (``1`` not ``1.0``): the harness's pose labels."""
    v = float(value)
    return str(int(v)) if v.is_integer() and abs(v) < 1e21 else repr(v)


def dump(sampler: Sampler, animation: str | None, times: list[float], skeleton_file: str = "",
         fps: float = 60.0, step=None) -> dict:
    """The setup pose, then ``animation`` at each of ``times``, in the harness's dump layout.

    ``step()``, when given, is called after each pose (a progress bar). A number that is not
    finite (a degenerate pose) is written as null. As the harness does, one skeleton plays
    every pose: its clock (which physics steps by) runs on from pose to pose. Every pose is
    held in memory: ``spinemesh pose`` writes :func:`dump_head`, then :func:`dump_poses` one by
    one, as a stream of the same text.

    Returns
    -------
    dict
        ``input`` (skeleton, skin, fps), ``skeleton`` (bones, slots, skins, animations with
        durations) and ``poses``, each with ``label``, ``anim``, ``time``, ``bones``
        (name -> ``[a, b, c, d, worldX, worldY]``), ``attachments`` (drawn slots in draw order)
        and, beyond the harness's layout, ``inexact`` (bone -> why its transform is not the
        runtime's; empty when every bone is reproduced) and ``inactive`` (bones the skin does
        not use, which the runtime leaves unposed; here they follow their parents).
    """
    poses = list(dump_poses(sampler, animation, times, fps, step))
    return {**dump_head(sampler, skeleton_file, fps), "poses": poses}


def dump_head(sampler: Sampler, skeleton_file: str = "", fps: float = 60.0) -> dict:
    """What the dump holds before its ``poses`` (see :func:`dump`): ``input`` and ``skeleton``."""
    return {
        "input": {"skeleton": skeleton_file, "skin": sampler.skin, "fps": fps},
        "skeleton": {
            "fileVersion": str((sampler.doc.get("skeleton") or {}).get("spine", "")),
            "bones": len(sampler.bone_names), "slots": len(sampler.slot_names),
            "skins": list(sampler.skins),
            "animations": [{"name": n, "duration": _duration(sampler, n)} for n in sampler.animation_names()],
        },
    }


def dump_labels(animation: str | None, times: list[float]) -> list[tuple[str, str | None, float]]:
    """The poses a dump holds, ``(label, animation, time)``: the setup pose, then ``animation``
    at each of ``times`` once (a time given twice is one pose)."""
    poses = [("setup", None, 0.0)]
    seen = {"setup"}
    for t in times if animation is not None else ():
        label = f"{animation}@{js_number(t)}"
        if label not in seen:
            seen.add(label)
            poses.append((label, animation, float(t)))
    return poses


def dump_poses(sampler: Sampler, animation: str | None, times: list[float], fps: float = 60.0, step=None):
    """The entries of the dump's ``poses`` (see :func:`dump`), made one at a time as they are asked for.

    Yields
    ------
    dict
        One pose: ``label``, ``anim``, ``time``, ``bones``, ``attachments``, ``inexact``, ``inactive``.
    """
    clock = 0.0
    for label, anim, t in dump_labels(animation, times):
        pose = sampler.pose(anim, t, fps=fps, clock=clock)
        if anim is not None:
            clock = advance_clock(clock, t, fps)
        entry = {"label": label, "anim": anim, "time": t, **pose.to_dump()}
        entry["inexact"] = dict(pose.why)
        entry["inactive"] = [n for n, a in zip(pose.bones, pose.active) if not a]
        yield entry
        if step is not None:
            step()


def _duration(sampler: Sampler, name: str) -> float | None:
    """An animation's duration as the dump lists it; None for one that cannot be read (that
    animation alone is refused when it is posed, never the others)."""
    try:
        return _clean(round(sampler.duration(name), 6))
    except POSE_ERRORS:
        return None


def advance_clock(clock: float, time: float, fps: float = 60.0) -> float:
    """The skeleton's clock after a pose at ``time`` played from ``clock`` (step by step, as
    ``Skeleton.update`` adds each step)."""
    steps, dt = steps_of(time, fps)
    return summed(clock, dt, steps)


def pose_errors(ours: dict, theirs: dict, skip_bones: set[str] = frozenset()) -> dict:
    """How far one of our poses is from the runtime's (both in the dump layout).

    Parameters
    ----------
    ours, theirs : dict
        One entry of ``poses`` each.
    skip_bones : set of str
        Bones not compared, nor the attachments they draw: those our pose flags not exact
        (``inexact``), for example a physics constraint's. Attachments our pose flags not
        exact (``"exact": false``: weighted to such a bone) are not compared either.

    Returns
    -------
    dict
        ``bone``: the largest difference of any of a bone's ``a, b, c, d, worldX, worldY``;
        ``vertex``: the largest difference of an attachment's world vertex, or of the clipping
        polygon that applies to it (world units);
        ``worst_bone``, ``worst_slot``: where; ``problems``: differences that are not numbers
        (a slot drawn by one side only, another attachment, another draw order).
    """
    bone_err, worst_bone = 0.0, None
    for name, m in theirs["bones"].items():
        if name in skip_bones or name not in ours["bones"]:
            continue
        a, b = np.asarray(m, float), np.asarray(ours["bones"][name], float)
        e = float(np.max(np.abs(a - b))) if len(a) == len(b) else math.inf
        if e > bone_err:
            bone_err, worst_bone = e, name
    problems: list[str] = []
    mine = {a["slot"]: a for a in ours["attachments"]}
    # The slot's bone, from either side (the 4.3 harness does not write it).
    bone_of = {**{a["slot"]: a.get("bone") for a in theirs["attachments"]},
               **{a["slot"]: a.get("bone") for a in ours["attachments"]}}
    order_ours = [a["slot"] for a in ours["attachments"] if bone_of[a["slot"]] not in skip_bones]
    order_theirs = [a["slot"] for a in theirs["attachments"] if bone_of[a["slot"]] not in skip_bones]
    if order_ours != order_theirs:
        only = sorted(set(order_ours) ^ set(order_theirs))
        problems.append(f"drawn slots differ: {only[:5]}" if only else "draw order differs")
    vertex_err, worst_slot = 0.0, None
    for a in theirs["attachments"]:
        b = mine.get(a["slot"])
        if bone_of[a["slot"]] in skip_bones or b is None or b.get("exact") is False:
            continue
        if b["attachment"] != a["attachment"] or len(b["vertices"]) != len(a["vertices"]):
            problems.append(f"slot {a['slot']!r}: {b['attachment']!r} drawn, the runtime draws {a['attachment']!r}")
            continue
        e = float(np.max(np.abs(np.asarray(a["vertices"], float) - np.asarray(b["vertices"], float)), initial=0))
        if "clip" in a and "clip" in b:  # the clipping polygon that applies, world vertices too
            ca, cb = a["clip"] or [], b["clip"] or []
            if len(ca) != len(cb):
                problems.append(f"slot {a['slot']!r}: clipped {'here' if cb else 'in the runtime'} only")
            elif ca:
                e = max(e, float(np.max(np.abs(np.asarray(ca, float) - np.asarray(cb, float)))))
        if e > vertex_err:
            vertex_err, worst_slot = e, a["slot"]
        if "color" not in a:
            continue
        c = float(np.max(np.abs(np.asarray(a["color"], float) - np.asarray(b["color"], float))))
        if c > 2e-3:
            problems.append(f"slot {a['slot']!r}: colour {b['color']} here, {a['color']} in the runtime")
    return {"bone": bone_err, "vertex": vertex_err, "worst_bone": worst_bone, "worst_slot": worst_slot,
            "problems": problems}
