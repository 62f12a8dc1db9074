"""Every bone's world transform over a few frames of each of a skeleton's animations.

What the bone choice's motion guard measures drift on (:mod:`spinemesh.rig.drift`): the
animations are known when a project is weighted, so sampling them is no peeking at an answer.
"""

from __future__ import annotations

import numpy as np

from .curves import unplayable_said
from .pose import POSE_ERRORS, Sampler

#: Frames sampled per animation, evenly spaced inside it (1/6, 1/2 and 5/6 of its duration).
FRAMES_PER_ANIMATION = 3

#: How a curve the runtimes play apart is read where the animations are sampled for the bones.
SAMPLED_LINEAR = "sampled linear where the bones are chosen"

#: Most animations sampled per skeleton (evenly spread over them): the cost stays bounded on a
#: skeleton with hundreds of animations.
MOST_ANIMATIONS = 40


def sampled_bone_worlds(doc: dict, frames: int = FRAMES_PER_ANIMATION,
                        most: int = MOST_ANIMATIONS, said: list | None = None) -> np.ndarray:
    """Every bone's world transform in ``frames`` frames of each animation of ``doc``.

    Posed with :class:`spinemesh.anim.Sampler` (constraints applied, physics not stepped: the
    bones it moves keep the animation's pose), default skin. An animation that cannot be read
    or posed, or a frame with a non-finite transform, is left out.

    Parameters
    ----------
    doc : dict
        A skeleton document (:func:`spinemesh.skeleton.load_skeleton`).
    frames : int
        Frames per animation, at ``(k + 0.5) / frames`` of its duration.
    most : int
        Most animations sampled, evenly spread over the skeleton's.
    said : list of str, optional
        Gets one line per 4.x curve of the animations sampled that the runtimes play apart or
        not at all (:func:`spinemesh.anim.curves.curve_4_playable`, as ``pose`` says it): sampled
        linear, as ``pose`` poses it.

    Returns
    -------
    ndarray, shape (F, B, 2, 3)
        ``[[a, b, worldX], [c, d, worldY]]`` per frame and bone; F may be 0.
    """
    try:
        sampler = Sampler(doc)
    except POSE_ERRORS:
        return np.zeros((0, 0, 2, 3))
    names = sampler.animation_names()
    if len(names) > most:
        names = [names[int(k)] for k in np.linspace(0, len(names) - 1, most).round()]
    out = []
    for name in names:
        try:
            duration = sampler.duration(name)
            poses = [sampler.bone_worlds(name, duration * (k + 0.5) / frames) for k in range(frames)]
        except POSE_ERRORS:
            continue
        if said is not None:
            said += [unplayable_said(name, u, SAMPLED_LINEAR) for u in sampler.animation(name)[0].unplayable]
        out += [w for w in poses if np.isfinite(w).all()]
    bones = len(sampler.bone_names)
    return np.stack(out) if out else np.zeros((0, bones, 2, 3))
