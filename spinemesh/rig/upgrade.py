"""``spinemesh upgrade --weights auto``: upgraded meshes bound and weighted in the same run.

Each mesh the upgrade just made gets the ``auto`` bones (:mod:`.choice`), the rig-aware
vertices for them (:mod:`.topology`, within the vertex budget), then weights and an exact
setup-pose binding (:mod:`.document`). A mesh that cannot be weighted (its slot's bone is
moved by a constraint in the setup pose, say) stays the unweighted mesh the upgrade made,
without the added vertices, and the report says why.

Before meshing, :class:`BendingRegions` tells which region attachments would bend: their art,
in the setup pose, lies over more than one ``auto`` bone. ``upgrade`` meshes those even where
the keep rule (:mod:`spinemesh.mesher.worth`) would keep them for saving too few pixels: a mesh
that bends with the skeleton is worth having for that alone. One that then does not get more
than one bone is put back as the region it was.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass

import numpy as np

from ..errors import SpineMeshError
from ..skeleton import AttachmentRef, iter_attachments
from .binding import parse_vertices, setup_world
from .choice import Choice, choose_auto
from .document import Outcome, Rig, WeightOptions, build_rig, choose, weight_mesh
from .topology import add_rig_vertices

#: A region's image corners (u, v), 0..1 over the original image, and the quad's two triangles.
QUAD_UV = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
QUAD_TRIANGLES = np.array([[0, 1, 2], [0, 2, 3]])

#: How far the art outline of :func:`art_outline` may stray from the texels' squares: this
#: share of the art's diagonal, at least one texel. The bone choice tests every bone sample
#: against every triangle, so a finer outline costs time (1 texel: 44 ms per region on a corpus
#: robot, against 2 ms for its quad) for a decision the mesh's own hull (within up to 16 px,
#: ``worth.MAX_HULL_TOLERANCE``) does not make finer.
OUTLINE_TOLERANCE = 0.01

#: Most separate pieces of art outlined one by one; art in more pieces (particles, rain) is
#: outlined by the convex hull of them all, which bounds the time (a 2000x2000 sheet of 80,000
#: specks took minutes piece by piece). Such art is kept by the keep rule's vertex-cost tests
#: anyway (``worth.islands_reason``: 200 outline vertices are about 66 pieces).
MAX_OUTLINE_PIECES = 64


def art_outline(drawn: np.ndarray, origin: tuple[int, int], size: tuple[int, int],
                tolerance: float = OUTLINE_TOLERANCE) -> tuple[np.ndarray, np.ndarray]:
    """The art's outline, triangulated, in the image's (u, v): what a mesh of it will cover.

    Parameters
    ----------
    drawn : ndarray, shape (h, w), bool
        The texels the mesh must cover, in the stored part of the image (``MeshTask.drawn``).
    origin : (int, int)
        Where that part starts in the original image, pixels (x, y).
    size : (int, int)
        The original image's width and height in pixels.
    tolerance : float
        Simplification of the outline, a share of the drawn texels' diagonal (at least one
        texel; :data:`OUTLINE_TOLERANCE`).

    Returns
    -------
    uv : ndarray, shape (N, 2)
        Outline points, 0..1 over the original image (u right, v down).
    triangles : ndarray, shape (T, 3), int
        A constrained Delaunay triangulation of each outer outline (holes filled, as the mesh
        fills them); empty when nothing is drawn. Art in more than :data:`MAX_OUTLINE_PIECES`
        pieces: the convex hull of them all.
    """
    import cv2
    import shapely

    contours, _ = cv2.findContours(np.asarray(drawn, np.uint8), cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    if len(contours) > MAX_OUTLINE_PIECES:
        contours = [cv2.convexHull(np.concatenate(contours))]
    # Contours run through texel centres: half a texel out (mitred) gives the texels' squares,
    # lines and points (one-texel-wide art) included.
    pieces = [shapely.make_valid(shapely.Polygon(c[:, 0] + 0.5)) if len(c) >= 3
              else shapely.LineString(c[:, 0] + 0.5) if len(c) == 2 else shapely.Point(c[0, 0] + 0.5)
              for c in contours]
    if not pieces:
        return np.zeros((0, 2)), np.zeros((0, 3), int)
    try:
        art = shapely.union_all(pieces).buffer(0.5, cap_style="square", join_style="mitre")
        x0, y0, x1, y1 = art.bounds
        art = shapely.simplify(art, max(1.0, tolerance * float(np.hypot(x1 - x0, y1 - y0))))
        tris = shapely.get_parts(shapely.constrained_delaunay_triangles(art))
        corners = np.stack([shapely.get_coordinates(t)[:3] for t in tris]) if len(tris) else np.zeros((0, 3, 2))
    except shapely.errors.GEOSException:
        # geometry GEOS cannot process: the convex hull of the art, a fan (it is convex)
        hull = cv2.convexHull(np.concatenate(contours))[:, 0] + 0.5
        corners = np.stack([np.stack([hull[0], hull[i], hull[i + 1]]) for i in range(1, len(hull) - 1)]) \
            if len(hull) >= 3 else np.zeros((0, 3, 2))
    uv = (corners.reshape(-1, 2) + np.asarray(origin, float)) / np.asarray(size, float)
    return uv, np.arange(len(uv)).reshape(-1, 3)


@dataclass
class BendingRegions:
    """Which region attachments of one skeleton would bend, from its setup pose.

    A region *bends* when the ``auto`` bone choice (:func:`.choice.choose_auto`) for its art,
    placed where the region draws it in the setup pose, gives more than one bone. Only regions
    whose slot bone's setup transform is exact are considered (nothing is bound otherwise).

    Attributes
    ----------
    rig : Rig
        The skeleton's rig (:func:`.document.build_rig`), built once and reused to weight.
    boxes : ndarray, shape (B, 2, 2)
        Each bone segment's bounding box (min, max), world units: a region whose box meets
        no other bone's cannot bend, and is rejected without the choice.
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
        from ..upgrade.geometry import region_quad_transform

        slot_bone = self.rig.slot_bone.get(ref.slot)
        if slot_bone is None or not self.rig.bones[slot_bone].exact:
            return None
        a = region_quad_transform(ref.attachment)
        m = self.rig.bones[slot_bone].world
        local = uv @ a[:, :2].T + a[:, 2]
        return local @ m[:, :2].T + m[:, 2]

    def choice(self, ref: AttachmentRef, uv: np.ndarray = QUAD_UV,
               triangles: np.ndarray = QUAD_TRIANGLES) -> Choice | None:
        """The ``auto`` bones of the art ``uv``/``triangles`` of a region (default: its whole quad).

        None when the region cannot be weighted (see :meth:`world`) or no bone but its slot
        bone comes near its box.
        """
        world = self.world(ref, uv)
        if world is None or len(triangles) == 0:
            return None
        slot_bone = self.rig.slot_bone[ref.slot]
        lo, hi = world.min(axis=0), world.max(axis=0)
        meets = ~((self.boxes[:, 1] < lo).any(axis=1) | (self.boxes[:, 0] > hi).any(axis=1))
        meets[slot_bone] = False
        if not meets.any():  # choose_auto would reject every other bone by the same box test
            return None
        return choose_auto(self.rig.bones, slot_bone, world, triangles, self.rig.skin_bones.get(ref.skin, set()))

    def bends(self, ref: AttachmentRef, uv: np.ndarray = QUAD_UV, triangles: np.ndarray = QUAD_TRIANGLES) -> bool:
        """Whether the art (default: the whole quad) gets more than one ``auto`` bone."""
        try:
            choice = self.choice(ref, uv, triangles)
        except SpineMeshError:
            return False  # a region placed by non-numbers is not weighted either
        return choice is not None and len(choice.bones) > 1


def _local_segments(rig, bone_ids: list[int], slot_bone: int) -> np.ndarray:
    """Bone segments in the slot bone's space, shape (B, 2, 2)."""
    m = rig.bones[slot_bone].world
    inv = np.linalg.inv(m[:, :2])
    segs = np.stack([rig.bones[b].segment() for b in bone_ids])
    return (segs - m[:, 2]) @ inv.T


def weight_upgraded(doc: dict, targets, max_vertices: int | None = None, rig: Rig | None = None) -> None:
    """Bind and weight every mesh the upgrade made in ``doc`` (targets with status ``meshed``).

    Sets each target's ``weights`` (a report entry: status, reason, bones and why, bones left
    out) and, when vertices were added, its ``vertices`` and ``triangles`` counts. A target
    meshed only because it bends (its ``overruled`` holds the keep rule's reason) that is not
    weighted to more than one bone is put back as its region (``region``), kept with that reason.
    ``rig`` is :func:`.document.build_rig` of ``doc`` when the caller has it already.
    """
    by_place = {(t.skin, t.slot, t.name): t for t in targets if t.status == "meshed"}
    if not by_place:
        return
    rig = rig or build_rig(doc)
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
        if getattr(t, "overruled", ""):
            _settle_bending(ref, t, outcome)


def _settle_bending(ref: AttachmentRef, t, outcome: Outcome) -> None:
    """A target meshed only because it would bend: kept meshed when it bends, else its region again."""
    bends = outcome.status == "weighted" and len(outcome.bones) > 1
    t.weights["meshed_to_bend"] = bends
    if bends:
        t.reason = f"meshed because it bends over {len(outcome.bones)} bones; the keep rule alone: {t.overruled}"
        return
    why = (f"weighted to {len(outcome.bones)} bone" if outcome.status == "weighted"
           else f"not weighted: {outcome.reason}")
    ref.attachment.clear()
    ref.attachment.update(t.region)
    t.status = "kept"
    t.reason = f"{t.overruled} (its region would bend, but its mesh was {why})"
    t.vertices = t.triangles = 0
    t.coverage = t.waste = None
    t.weights["added_vertices"] = 0
