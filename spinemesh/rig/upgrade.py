"""``spinemesh upgrade --weights auto``: upgraded meshes bound and weighted in the same run.

Each mesh the upgrade just made gets the ``auto`` bones (:mod:`.choice`), the rig-aware
vertices for them (:mod:`.topology`, within the vertex budget), then weights and an exact
setup-pose binding (:mod:`.document`). A mesh that cannot be weighted (its slot's bone is
moved by a constraint in the setup pose, say) stays the unweighted mesh the upgrade made,
without the added vertices, and the report says why.
"""

from __future__ import annotations

import copy

import numpy as np

from ..errors import SpineMeshError
from ..skeleton import iter_attachments
from .binding import parse_vertices, setup_world
from .document import Outcome, WeightOptions, build_rig, choose, weight_mesh
from .topology import add_rig_vertices


def _local_segments(rig, bone_ids: list[int], slot_bone: int) -> np.ndarray:
    """Bone segments in the slot bone's space, shape (B, 2, 2)."""
    m = rig.bones[slot_bone].world
    inv = np.linalg.inv(m[:, :2])
    segs = np.stack([rig.bones[b].segment() for b in bone_ids])
    return (segs - m[:, 2]) @ inv.T


def weight_upgraded(doc: dict, targets, max_vertices: int | None = None) -> None:
    """Bind and weight every mesh the upgrade made in ``doc`` (targets with status ``meshed``).

    Sets each target's ``weights`` (a report entry: status, reason, bones and why, bones left
    out) and, when vertices were added, its ``vertices`` and ``triangles`` counts.
    """
    by_place = {(t.skin, t.slot, t.name): t for t in targets if t.status == "meshed"}
    if not by_place:
        return
    rig = build_rig(doc)
    options = WeightOptions(bones="auto")
    for ref in iter_attachments(doc):
        t = by_place.get((ref.skin, ref.slot, ref.name))
        if t is None or ref.type != "mesh":
            continue
        before = copy.deepcopy(ref.attachment)
        outcome = Outcome(t.skeleton, ref.skin, ref.slot, ref.name)
        added = 0
        try:
            slot_bone = rig.slot_bone.get(ref.slot)
            if slot_bone is not None and rig.bones[slot_bone].exact:
                mesh = parse_vertices(ref.attachment, len(rig.bones))
                world = setup_world(mesh, rig.worlds, slot_bone)
                tris = np.asarray(ref.attachment["triangles"], int).reshape(-1, 3)
                choice = choose(rig, ref, mesh, world, tris, "auto")
                if len(choice.bones) > 1:
                    index = {b: i for i, b in enumerate(choice.bones)}
                    parents = [index.get(rig.bones[b].parent) for b in choice.bones]
                    added = add_rig_vertices(ref.attachment, _local_segments(rig, choice.bones, slot_bone),
                                             parents, max_vertices)
            weight_mesh(rig, ref, options, outcome)
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
