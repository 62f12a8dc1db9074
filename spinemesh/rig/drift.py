"""How far each bone would carry a mesh's art from where its slot's bone carries it.

A bone bound to a mesh moves its art the way the bone moves. Over the skeleton's own
animations, a bone of the same part (a forearm under an upper arm) carries the art near where
the slot's bone carries it, bending it; a bone that flips, folds or belongs to another part (a
paper-fold's other leaves, a weapon, an effect) carries it far away. :func:`drifts` measures
that for each bone: the art made rigid on the bone against the art rigid on the slot's bone, a
few frames of every animation, in units of the art's size. The animations are known when a
project is weighted, so this is no peeking at an answer: it is what the game will play.
"""

from __future__ import annotations

import numpy as np

#: The slot's bone tells where the art goes only when its segment lies within this share of the
#: art's diagonal of it (the learned choice's reach, :data:`.learned.REACH`): a weighted mesh's
#: slot often hangs on the root or on a bone elsewhere, which its vertices do not follow.
SLOT_NEAR = 0.25

def follows_slot(bones, slot_bone: int, world: np.ndarray, triangles: np.ndarray, near: float = SLOT_NEAR) -> bool:
    """Whether the slot's bone can stand for where the art goes: not the root (it moves the
    whole skeleton) and its segment within ``near`` times the art's diagonal of the art.

    ``bones``: the rig's bones (:func:`.bones.skeleton_bones`); ``world`` (N, 2) and
    ``triangles`` (T, 3): the art's setup-pose vertices and triangles.
    """
    from .choice import distance_to_art

    bone = bones[slot_bone]
    if bone.parent is None:
        return False
    a, b = np.asarray(bone.segment(), float).reshape(2, 2)
    points = a + np.linspace(0.0, 1.0, 17)[:, None] * (b - a)
    diag = float(np.linalg.norm(np.ptp(world, axis=0)))
    return bool(distance_to_art(points, world, triangles).min() <= near * diag)


def _rigid(points: np.ndarray, setup: np.ndarray, frames: np.ndarray) -> np.ndarray:
    """``points`` (N, 2) rigid on a bone with setup transform ``setup`` (2, 3), in each of its
    ``frames`` (F, 2, 3): shape (F, N, 2)."""
    inv = np.linalg.inv(np.vstack([setup, [0.0, 0.0, 1.0]]))[:2]
    local = points @ inv[:, :2].T + inv[:, 2]
    return np.einsum("fij,nj->fni", frames[..., :2], local) + frames[:, None, :, 2]


def drifts(world: np.ndarray, setup: np.ndarray, frames: np.ndarray, slot_bone: int,
           bones) -> dict[int, float]:
    """How far each of ``bones`` would carry the art from where the slot's bone carries it.

    For each frame, the mean distance between the art's vertices rigid on the bone and rigid on
    the slot's bone; then the largest over the frames, divided by the art's bounding-box
    diagonal. 0 for the slot's bone and for a bone moving with it.

    Parameters
    ----------
    world : ndarray, shape (N, 2)
        The art's setup-pose vertices, world units.
    setup : ndarray, shape (B, 2, 3)
        Every bone's setup world transform.
    frames : ndarray, shape (F, B, 2, 3)
        Every bone's world transform in the sampled frames (:func:`spinemesh.anim.bone_worlds.sampled_bone_worlds`).
    slot_bone : int
        The slot's bone.
    bones : iterable of int
        The bones measured.

    Returns
    -------
    dict of int to float
        Per bone, the largest mean drift over the frames in art diagonals; 0 for all when no
        frame was sampled; a bone whose setup transform cannot be inverted (scaled to nothing)
        is infinitely far.

    Examples
    --------
    >>> setup = np.array([[[1.0, 0, 0], [0, 1, 0]], [[1.0, 0, 10], [0, 1, 0]]])
    >>> turned = np.array([[[1.0, 0, 0], [0, 1, 0]], [[-1.0, 0, 10], [0, -1, 0]]])  # bone 1 flips
    >>> art = np.array([[9.0, -1], [11, -1], [11, 1], [9, 1]])            # centred on bone 1
    >>> drifts(art, setup, turned[None], 0, [0, 1])
    {0: 0.0, 1: 1.0}
    """
    world = np.asarray(world, float)
    frames = np.asarray(frames, float)
    out = {}
    if not len(frames) or not len(world):
        return {int(b): 0.0 for b in bones}
    diag = max(float(np.linalg.norm(np.ptp(world, axis=0))), 1e-9)
    try:
        on_slot = _rigid(world, setup[slot_bone], frames[:, slot_bone])
    except np.linalg.LinAlgError:
        return {int(b): 0.0 for b in bones}  # nothing to measure against
    for b in bones:
        b = int(b)
        if b == slot_bone:
            out[b] = 0.0
            continue
        try:
            moved = _rigid(world, setup[b], frames[:, b])
        except np.linalg.LinAlgError:
            out[b] = float("inf")
            continue
        out[b] = float(np.linalg.norm(moved - on_slot, axis=2).mean(axis=1).max() / diag)
    return out


def guarded(choice, drift: dict[int, float], slot_bone: int, limit: float, add_slot: bool = False,
            slot_bindable: bool = True):
    """``choice`` (a :class:`.choice.Choice`) without the bones that would carry the art more
    than ``limit`` art diagonals from where the slot's bone carries it (``drift``, from
    :func:`drifts`); each left out says so.

    When every bone chosen is left out, or (``add_slot``) when any is, the slot's bone is bound
    (where it can be: ``slot_bindable``): it is where the art is drawn without weights.
    """
    from .choice import Choice

    far = {b for b in choice.bones if b != slot_bone and drift.get(b, 0.0) > limit}
    if not far:
        return choice
    left_out = dict(choice.left_out)
    for b in far:
        left_out[b] = (f"would carry the art {drift[b]:.2f} of its size away from where the slot's bone "
                       f"carries it in the animations (more than {limit:g})")
    why = {b: w for b, w in choice.why.items() if b not in far}
    bones = [b for b in choice.bones if b not in far]
    if slot_bindable and slot_bone not in bones and (add_slot or not bones):
        why[slot_bone] = "slot bone (the bones chosen would carry the art away from it)"
        bones = sorted(bones + [slot_bone])
    return Choice(bones, why, left_out)


#: A chosen bone is left out when it would carry the art farther than this many art diagonals
#: from where the slot's bone carries it (:func:`drifts`). Chosen on repository folds of the
#: offline replay: each of the five folds' best limit on the other four was 1, 0.5, 1, 0.75 and
#: 0.75; their median, a little below where the slot-bone sum ratio turns worse again (1.5).
DRIFT_LIMIT = 0.75


class Motion:
    """A skeleton's sampled animations, sampled when first asked for by ``sample(doc, said=[])`` (the
    weights command passes :func:`spinemesh.anim.bone_worlds.sampled_bone_worlds`: the sampler sits
    above the rig, so it is handed down); without ``sample`` there is nothing to guard by.

    Kept on the rig (:class:`.document.Rig`). Sent to another process it carries the sampled
    transforms, not the document: sampled before it goes, so that the receiver guards exactly as
    the sender would (``upgrade``'s workers guard as its main process does).
    """

    def __init__(self, doc: dict | None, sample=None):
        self._doc = doc if sample is not None else None
        self._sample = sample
        self._frames: np.ndarray | None = None
        #: what the sampler said of the animations it read (a 4.x curve the runtimes play apart,
        #: sampled linear), one line each without the skeleton's name: :meth:`said_lines`
        self.said: list[str] = []
        #: whether a choice asked for :attr:`frames` here (a copy sent to a worker starts without:
        #: the sender samples them to send them, whether or not a choice will need them)
        self.asked = False

    @property
    def frames(self) -> np.ndarray:
        """Every bone's world transform in each sampled frame, shape (F, B, 2, 3)."""
        self.asked = True
        return self._sampled()

    def _sampled(self) -> np.ndarray:
        """:attr:`frames`, sampled on the first call, without counting as asked for."""
        if self._frames is None:
            if self._doc is not None:
                self._frames = self._sample(self._doc, said=self.said)
            else:
                self._frames = np.zeros((0, 0, 2, 3))
            self._doc = self._sample = None
        return self._frames

    def said_lines(self, skeleton: str) -> list[str]:
        """:attr:`said`, each line begun by ``skeleton``, the first
        :data:`~spinemesh.words.MAX_UNUSABLE_SAID` then how many more: nothing when the animations
        were never sampled (no choice needed them)."""
        from ..words import unusable_said

        return unusable_said(self.said, skeleton, "{problem}", "{more} more curves the runtimes play apart")

    def __getstate__(self):
        return {"_doc": None, "_sample": None, "_frames": self._sampled(), "said": self.said, "asked": False}


def guard(choice, bones, slot_bone: int, world: np.ndarray, triangles: np.ndarray, motion: Motion | None,
          limit: float = DRIFT_LIMIT):
    """``choice`` without the bones that would carry the art far from its slot's bone in the
    animations (:func:`guarded`, the slot's bone bound in their place), where the slot's bone
    stands for where the art goes (:func:`follows_slot`); else ``choice`` as it is.

    Samples the animations (``motion``) only for a choice that binds a bone besides the slot's.
    """
    if motion is None or not any(b != slot_bone for b in choice.bones):
        return choice
    if not follows_slot(bones, slot_bone, world, triangles):
        return choice
    frames = motion.frames
    if not len(frames):
        return choice
    setup = np.stack([b.world for b in bones])
    drift = drifts(world, setup, frames, slot_bone, [b for b in choice.bones if b != slot_bone])
    return guarded(choice, drift, slot_bone, limit, add_slot=True, slot_bindable=bones[slot_bone].exact)
