"""Animation poses sampled as the official Spine runtimes compute them.

An animation is evaluated at a time the way a game's ``AnimationState`` plays it on one
looping track: bone timelines (rotate, translate, scale, shear, 4.x split x/y timelines,
4.2 inherit), constraint timelines (IK, transform and path mixes), slot attachment and
colour timelines, deform, draw order and 4.1+ sequence timelines, with stepped, linear and
Bezier curves in the 3.x and 4.x layouts. Bones then take their world transforms through
the runtime's update cache with IK, transform and path constraints
(:mod:`spinemesh.rig.constraints`), and every drawn region and mesh attachment (weighted or
not, linked meshes, skins) gets its world vertices.

Works on documents from :func:`spinemesh.skeleton.load_skeleton` (``.json`` and ``.skel``,
3.8 to 4.2 reproduced; other versions pose bones without constraints). Physics constraints
(4.2) are stepped as the runtime steps them, replaying the game loop from time 0 (a pose
then costs one bone update per 1/60 s); ``pose(..., physics=False)`` skips that and flags
the bones physics moves in :attr:`Pose.exact`.

Sampling many times of one animation is cheap: :class:`Sampler` prepares the skeleton once
and each animation's timelines once.

Example
-------
>>> from spinemesh.anim import Sampler, sample_pose, atlas_regions
>>> from spinemesh.atlas import read_atlas
>>> from spinemesh.skeleton import load_skeleton
>>> doc = load_skeleton("spineboy-pro.json")                        # doctest: +SKIP
>>> sampler = Sampler(doc, regions=atlas_regions(read_atlas("spineboy.atlas")))  # doctest: +SKIP
>>> pose = sampler.pose("run", 0.5)                                 # doctest: +SKIP
>>> pose.bone("hip")           # [[a, b, worldX], [c, d, worldY]]   # doctest: +SKIP
>>> for slot in pose.slots:    # drawn attachments in draw order    # doctest: +SKIP
...     slot.slot, slot.attachment, slot.vertices.shape, slot.color
>>> sample_pose(doc, "run", 0.5).to_dump()["bones"]["hip"]          # doctest: +SKIP
"""

from __future__ import annotations

from .attachments import RegionGeometry
from .pose import (
    POSE_ERRORS,
    DrawnSlot,
    Pose,
    Sampler,
    animation_time,
    atlas_regions,
    same_motion,
)

__all__ = ["POSE_ERRORS", "DrawnSlot", "Pose", "RegionGeometry", "Sampler", "animation_time", "atlas_regions",
           "same_motion", "sample_pose"]


def sample_pose(document: dict, animation: str | None, time: float, skin: str | None = None,
                atlas=None) -> Pose:
    """One pose of ``animation`` at track time ``time`` (seconds, looping).

    For many poses of one skeleton, make one :class:`Sampler` and call its ``pose``.

    Parameters
    ----------
    document : dict
        A skeleton document (:func:`spinemesh.skeleton.load_skeleton`).
    animation : str or None
        The animation's name; None for the setup pose.
    time : float
        Track time in seconds; a looping track reaches it in 1/60 s steps, as the harness does.
    skin : str, optional
        The skin shown (default: the default skin only).
    atlas : Atlas or list of Atlas, optional
        The atlas(es) the skeleton draws from; region quads follow their regions' trimming.

    Returns
    -------
    Pose

    Raises
    ------
    KeyError
        When the skeleton has no animation called ``animation``.
    """
    regions = atlas_regions(atlas) if atlas is not None else None
    return Sampler(document, skin, regions).pose(animation, time)
