"""``spinemesh upgrade --weights auto``: upgraded meshes bound and weighted in the same run.

Each mesh the upgrade just made gets the ``auto`` bones of ``spinemesh weights`` (the learned
choice, :mod:`.learned`, with the habits of the project's artist-weighted meshes), chosen as for
art no artist chose to weight (:func:`upgrade_choice`: more than one bone only where the model
finds a bone besides the slot's likely), the rig-aware vertices for them (:mod:`.topology`,
within the vertex budget), then weights and an exact setup-pose binding (:mod:`.document`). A
mesh that cannot be weighted (its slot's bone is moved by a constraint in the setup pose, say)
stays the unweighted mesh the upgrade made, without the added vertices, and the report says why.

:class:`BendingRegions` tells which region attachments may bend: the same choice gives the box
of their art more than one bone. ``upgrade`` meshes those even where the keep rule
(:mod:`spinemesh.mesher.worth`) would keep them for saving too few pixels: a mesh that bends
with the skeleton is worth having for that alone (asked only of the regions the rule kept,
:mod:`spinemesh.upgrade.bending`). The art decides: a mesh made only to bend
whose own triangles do not get more than one bone is put back as the region it was, before any
weights are solved; so is one whose weights leave all but one bone out.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ..errors import SpineMeshError
from ..skeleton import AttachmentRef, iter_attachments
from .binding import parse_vertices, setup_world
from .choice import Choice
from .document import Outcome, Rig, WeightOptions, build_rig, choose, weight_mesh
from .learned import boxes_meet, reach_limits, share_project_habits
from .topology import add_rig_vertices

#: A region's image corners (u, v), 0..1 over the original image, and the quad's two triangles.
QUAD_UV = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
QUAD_TRIANGLES = np.array([[0, 1, 2], [0, 2, 3]])


@dataclass
class BendingRegions:
    """Which region attachments of one skeleton may bend, from its setup pose.

    A region *may bend* when :func:`upgrade_choice` for the box around its art (the texels a
    mesh must cover, :func:`spinemesh.upgrade.plan.art_box`), placed where the region draws it in
    the setup pose, gives more than one bone. Only regions whose slot bone's setup transform is
    exact are considered (nothing is bound otherwise). The box, not the art's outline: the
    outline is known only once meshed, and the bone choice on the mesh
    (:func:`weight_upgraded`) settles it then (testing the outline here cost the planning 212 s
    on a corpus skeleton of 494 bones, for the ~7% of regions that the keep rule keeps at all).
    The box, not the whole quad: where the image has transparent margins the quad reaches bones
    the art does not, and such a region was meshed only to be put back (70 of 106 on the 4.2
    examples).

    Attributes
    ----------
    rig : Rig
        The skeleton's rig (:func:`.document.build_rig`), built once and reused to weight.
    boxes : ndarray, shape (B, 2, 2)
        Each bone segment's bounding box (min, max), world units: a region whose box, grown by
        the candidates' reach (:func:`.learned.reach_limits`), meets no other bone's cannot
        bend, and is rejected without the choice.
    """

    rig: Rig
    boxes: np.ndarray

    @classmethod
    def of(cls, rig: Rig) -> "BendingRegions":
        segs = np.stack([b.segment() for b in rig.bones]) if rig.bones else np.zeros((0, 2, 2))
        return cls(rig, np.stack([segs.min(axis=1), segs.max(axis=1)], axis=1))

    def world(self, ref: AttachmentRef, uv: np.ndarray) -> np.ndarray | None:
        """Setup-pose world positions (N, 2) of image points ``uv`` (N, 2) of a region attachment.

        None when its slot has no bone or the bone's setup transform is not exact.

        Raises
        ------
        SpineMeshError
            When the region's placement (``x``, ``y``, ``rotation``, ``scaleX`` ...) is not numbers.
        """
        from ..attachment_geometry import region_quad_transform

        slot_bone = self.rig.slot_bone.get(ref.slot)
        if slot_bone is None or not self.rig.bones[slot_bone].exact:
            return None
        a = region_quad_transform(ref.attachment)
        m = self.rig.bones[slot_bone].world
        local = uv @ a[:, :2].T + a[:, 2]
        return local @ m[:, :2].T + m[:, 2]

    def choice(self, ref: AttachmentRef, uv: np.ndarray = QUAD_UV,
               triangles: np.ndarray = QUAD_TRIANGLES, explain: bool = True) -> Choice | None:
        """The :func:`upgrade_choice` of the art ``uv``/``triangles`` of a region (default: its
        whole quad; ``explain=False``: its bones without their reasons).

        None when the region cannot be weighted (see :meth:`world`) or no bone but its slot
        bone comes within the candidates' reach of its box.
        """
        world = self.world(ref, uv)
        if world is None or len(triangles) == 0:
            return None
        slot_bone = self.rig.slot_bone[ref.slot]
        lo, hi = world.min(axis=0), world.max(axis=0)
        limit = reach_limits(self.rig.bones, slot_bone, float(np.linalg.norm(hi - lo)))
        meets = boxes_meet(self.boxes[:, 0], self.boxes[:, 1], lo, hi, limit)
        meets[slot_bone] = False
        if not meets.any():  # no other bone is a candidate
            return None
        return upgrade_choice(self.rig, ref, world, triangles, explain)

    def bends(self, ref: AttachmentRef, uv: np.ndarray = QUAD_UV, triangles: np.ndarray = QUAD_TRIANGLES) -> bool:
        """Whether the art (default: the whole quad) gets more than one bone."""
        try:
            choice = self.choice(ref, uv, triangles, explain=False)  # counted, not explained
        except SpineMeshError:
            return False  # a region placed by non-numbers is not weighted either
        return choice is not None and len(choice.bones) > 1


def upgrade_choice(rig: Rig, ref: AttachmentRef, world: np.ndarray, triangles: np.ndarray,
                   explain: bool = True) -> Choice:
    """The bones an upgraded mesh is bound to: the ``auto`` choice of ``spinemesh weights``, for
    art no artist chose to weight (``unweighted``, :func:`.learned.choose_learned`).

    The learned choice was fitted on meshes that artists weighted, nearly all of them (95%) to
    several bones, and its set stage learned that: on the attachments artists left rigid it binds
    several bones three times in four. So an upgraded mesh is bound to more than one bone only
    where the per-bone model finds a bone besides the slot's likely; measured project-held-out,
    that bends fewer of the attachments artists left rigid than the rule does and more of the
    meshes artists bent (``docs/guide/bones.md``, *While upgrading*).

    Parameters
    ----------
    rig : Rig
        The skeleton's rig, with the project's habits (:func:`.learned.share_project_habits`).
    ref : AttachmentRef
        The attachment (its slot has a bone).
    world : ndarray, shape (N, 2)
        Its setup-pose vertices, world units.
    triangles : ndarray, shape (T, 3)
        Its triangles, indices into ``world``.
    explain : bool
        False: the bones alone, without the reasons for them and for the bones left out.
    """
    # guarded (.drift.guard) where the rig can sample the animations: unguarded, a slash effect
    # was bound to a shoe's bone and dragged across the body as she kicked (docs/guide/bones.md,
    # "Bones that would carry the art away")
    return choose(rig, ref, None, world, triangles, "auto", unweighted=True, explain=explain)


def _local_segments(rig, bone_ids: list[int], slot_bone: int) -> np.ndarray:
    """Bone segments in the slot bone's space, shape (B, 2, 2)."""
    m = rig.bones[slot_bone].world
    inv = np.linalg.inv(m[:, :2])
    segs = np.stack([rig.bones[b].segment() for b in bone_ids])
    return (segs - m[:, 2]) @ inv.T


def weight_upgraded(doc: dict, targets, max_vertices: int | None = None, rig: Rig | None = None,
                    on_mesh: Callable[[], None] | None = None) -> None:
    """Bind and weight every mesh the upgrade made in ``doc`` (targets with status ``meshed``).

    Sets each target's ``weights`` (a report entry: status, reason, bones and why, bones left
    out) and, when vertices were added, its ``vertices`` and ``triangles`` counts. A target
    meshed only because it bends (its ``overruled`` holds the keep rule's reason) that is not
    weighted to more than one bone is put back as its region (``region``), kept with that reason.
    ``rig`` is :func:`.document.build_rig` of ``doc`` when the caller has it already, with the
    project's habits (:func:`.learned.share_project_habits`; else those of ``doc`` alone);
    ``on_mesh`` is called once per mesh treated (for progress bars).
    """
    by_place = {(t.skin, t.slot, t.name): t for t in targets if t.status == "meshed"}
    if not by_place:
        return
    if rig is None:
        rig = build_rig(doc)
        share_project_habits([(doc, rig)])
    options = WeightOptions(bones="auto")
    for ref in iter_attachments(doc):
        t = by_place.get((ref.skin, ref.slot, ref.name))
        if t is None or ref.type != "mesh":
            continue
        if on_mesh is not None:
            on_mesh()
        # a shallow copy: the weighting replaces the attachment's lists (``vertices``, ``uvs``,
        # ``triangles``), never changes one in place
        before = dict(ref.attachment)
        outcome = Outcome(t.skeleton, ref.skin, ref.slot, ref.name)
        added, choice = 0, None
        try:
            slot_bone = rig.slot_bone.get(ref.slot)
            if slot_bone is not None and rig.bones[slot_bone].exact:
                mesh = parse_vertices(ref.attachment, len(rig.bones))
                world = setup_world(mesh, rig.worlds, slot_bone)
                tris = np.asarray(ref.attachment["triangles"], int).reshape(-1, 3)
                choice = upgrade_choice(rig, ref, world, tris)
                if t.overruled and len(choice.bones) < 2:
                    # meshed only to bend, but no other bone is likely for its art: no weights to solve
                    outcome.status, outcome.reason = "skipped", "no bone but its slot's is likely for its art"
                    t.weights = {"status": outcome.status, "reason": outcome.reason, "bones": {},
                                 "left_out": {rig.bones[b].name: w for b, w in choice.left_out.items()},
                                 "added_vertices": 0}
                    _settle_bending(ref, t, outcome)
                    continue
                if len(choice.bones) > 1:
                    index = {b: i for i, b in enumerate(choice.bones)}
                    parents = [index.get(rig.bones[b].parent) for b in choice.bones]
                    added = add_rig_vertices(ref.attachment, _local_segments(rig, choice.bones, slot_bone),
                                             parents, max_vertices)
            # the bones the vertices were added for: the added vertices lie on the same art
            weight_mesh(rig, ref, options, outcome, choice)
        except SpineMeshError as e:
            outcome.status, outcome.reason = "failed", str(e)
        if outcome.status != "weighted":
            ref.attachment.clear()
            ref.attachment.update(before)
            added = 0
        elif added:
            t.vertices += added
            t.triangles = len(ref.attachment["triangles"]) // 3
        t.weights = {"status": outcome.status, "reason": outcome.reason, "bones": outcome.bones,
                     "left_out": outcome.left_out, "added_vertices": added}
        if t.overruled:
            _settle_bending(ref, t, outcome)


#: Most meshes one job of :func:`weight_apart` weighs: several jobs per skeleton keep every
#: worker busy when one skeleton holds most of a project's meshes; each job carries its
#: skeleton's rig and attachments, so not much fewer.
MESHES_PER_JOB = 24


def weighting_jobs(doc: dict, targets, max_vertices: int | None, rig: Rig) -> list[tuple]:
    """The jobs of :func:`weight_apart` that together do what :func:`weight_upgraded` does to
    ``doc`` and ``targets``, at most :data:`MESHES_PER_JOB` meshes each.

    A job holds the document without its animations (the rig already read what the weighting
    needs of them), the targets it weighs, ``max_vertices`` and the rig.
    """
    meshed = [t for t in targets if t.status == "meshed"]
    light = {k: v for k, v in doc.items() if k != "animations"}
    # the choices made before meshing stay here: not the meshes'; the motion goes as its sampled
    # frames (.drift.Motion), so that the workers guard as this process would
    rig = dataclasses.replace(rig, choices={})
    return [(light, meshed[s:s + MESHES_PER_JOB], max_vertices, rig) for s in range(0, len(meshed), MESHES_PER_JOB)]


def weight_apart(job: tuple) -> list[tuple[dict, dict]]:
    """:func:`weight_upgraded` of one job of :func:`weighting_jobs`, on a worker process: for each
    of its targets, in order, the attachment as it ends (weighted, left unweighted or put back
    as its region) and the target's fields (:func:`put_back_weighted` puts both in place)."""
    doc, targets, max_vertices, rig = job
    weight_upgraded(doc, targets, max_vertices, rig)
    places = {(t.skin, t.slot, t.name) for t in targets}
    attachments = {(ref.skin, ref.slot, ref.name): ref.attachment for ref in iter_attachments(doc)
                   if (ref.skin, ref.slot, ref.name) in places}
    return [(attachments[(t.skin, t.slot, t.name)], dict(t.__dict__)) for t in targets]


def put_back_weighted(doc: dict, targets, weighted: list[tuple[dict, dict]]) -> None:
    """Put what :func:`weight_apart` returned for ``targets`` (the job's, in its order) into
    ``doc`` and the targets, in place: each attachment's own dict keeps its place among its siblings."""
    by_place = {(t.skin, t.slot, t.name): (t, w) for t, w in zip(targets, weighted)}
    for ref in iter_attachments(doc):
        found = by_place.get((ref.skin, ref.slot, ref.name))
        if found is None:
            continue
        t, (attachment, fields) = found
        ref.attachment.clear()
        ref.attachment.update(attachment)
        t.__dict__.update(fields)


def _settle_bending(ref: AttachmentRef, t, outcome: Outcome) -> None:
    """A target meshed only because it would bend: kept meshed when it bends, else its region again."""
    bends = outcome.status == "weighted" and len(outcome.bones) > 1
    t.weights["meshed_to_bend"] = bends
    if bends:
        t.reason = (f"meshed because it bends over {len(outcome.bones)} bones; without --weights auto it would "
                    f"stay a region: {t.overruled}")
        return
    why = (f"its mesh was weighted to {len(outcome.bones)} bone" if outcome.status == "weighted"
           else outcome.reason if outcome.status == "skipped" else f"its mesh was not weighted: {outcome.reason}")
    ref.attachment.clear()
    ref.attachment.update(t.region)
    t.status = "kept"
    t.reason = f"{t.overruled} (its region may bend, but {why})"
    t.vertices = t.triangles = 0
    t.coverage = t.waste = None
    t.weights["added_vertices"] = 0
