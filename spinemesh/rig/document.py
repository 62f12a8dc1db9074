"""Weighting the mesh attachments of one skeleton document, in place.

Per mesh attachment: choose its bones (:mod:`.choice`), compute weights on its triangles in
the setup pose (:mod:`.weights`), bind exactly (:mod:`.binding`). Left as they are, with
the reason: meshes keyed by deform timelines (their keys are laid out per bone entry, so
new bindings would break them), meshes whose current setup position depends on a bone the
setup transform of which is not reproduced exactly (see :mod:`.bones`), and meshes already
weighted unless ``replace``. Linked meshes draw their parent's vertices and follow it.
"""

from __future__ import annotations

import fnmatch
import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import SpineMeshError
from ..skeleton import AttachmentRef, checked_attachments, image_paths, iter_attachments, linked_source
from .binding import bind, mesh_triangles, parse_vertices, setup_world
from .bones import Bone, skeleton_bones
from .choice import NEAR, Choice, choose_by_rule
from .habits import ProjectHabits, keys_of
from .learned import BELOW_THRESHOLD, choose_learned, constrained_bones, neighbour_sets
from .drift import Motion, guard
from .weights import solve_weights_once, sparsify

METHODS = ("bbw", "harmonic", "biharmonic", "geodesic")

#: ``--bones`` choices: ``keep`` (the mesh's bones now), ``rule`` (:func:`.choice.choose_by_rule`),
#: ``learned`` (:func:`.learned.choose_learned`), and ``auto``, which is :data:`AUTO_BONES`.
BONE_CHOICES = ("keep", "auto", "rule", "learned")

#: What ``auto`` means: the choice that measures closer to the artists' bindings on projects
#: held out of the learned model's fit (see the bone-choice guide for the figures).
AUTO_BONES = "learned"


@dataclass
class WeightOptions:
    """What to weight and how (see ``spinemesh weights --help``)."""

    bones: str = "auto"               # keep | auto | rule | learned (see BONE_CHOICES)
    max_bones: int = 4
    min_weight: float = 0.01
    replace: bool = False
    method: str = "bbw"
    only: list[str] = field(default_factory=list)
    exclude: list[str] = field(default_factory=list)
    # how the skeleton's animations are sampled for the motion guard of the learned choice
    # (:class:`.drift.Motion`; ``spinemesh weights`` passes spinemesh.anim.bone_worlds.sampled_bone_worlds);
    # None: the choice is not guarded
    sample_motion: object = None


#: Why a chosen bone is not written: the weights left every vertex at 0 for it.
UNWEIGHTED_BONE = "no vertex weighted to it: its segment is not on or near the art"

#: At most this many bones left out are listed for a mesh in a report (``left_out``), the others
#: counted (``left_out_more``): the learned choice weighs every bone within reach of the art, and
#: listing them all made a report of 756 bones per mesh (4.3 MB for 49 meshes of one skeleton).
LEFT_OUT_LISTED = 12


def left_out_reported(left_out: dict[str, str]) -> dict:
    """A mesh's bones left out (bone name -> why) as its report row gives them: ``left_out``, at
    most :data:`LEFT_OUT_LISTED` of them, first those left out for a reason of their own (another
    skin's, no exact setup transform, no vertex weighted to it, more than enough bones), then
    those the model found likeliest; ``left_out_more``, how many more were left out.

    Examples
    --------
    >>> why = {f"b{i}": f"learned: 0.0{i}, below the threshold 0.50" for i in range(9, -1, -1)}
    >>> why.update({f"skin{i}": "only active in other skins" for i in range(5)})
    >>> row = left_out_reported(why)
    >>> list(row["left_out"]), row["left_out_more"]
    (['skin0', 'skin1', 'skin2', 'skin3', 'skin4', 'b9', 'b8', 'b7', 'b6', 'b5', 'b4', 'b3'], 3)
    """
    unlikely = [b for b, why in left_out.items() if BELOW_THRESHOLD in why]  # likeliest first
    listed = ([b for b, why in left_out.items() if BELOW_THRESHOLD not in why] + unlikely)[:LEFT_OUT_LISTED]
    return {"left_out": {b: left_out[b] for b in listed}, "left_out_more": len(left_out) - len(listed)}


@dataclass
class Outcome:
    """What became of one mesh attachment (a report row)."""

    skeleton: str
    skin: str
    slot: str
    name: str
    status: str = "pending"           # weighted | skipped | failed
    reason: str = ""
    bones: dict = field(default_factory=dict)      # bone name -> why chosen
    left_out: dict = field(default_factory=dict)   # bone name -> why not
    vertices: int = 0
    seconds: float = 0.0

    def row(self) -> dict:
        """The report's row: the bones left out listed as :func:`left_out_reported` gives them."""
        return dict(self.__dict__) | left_out_reported(self.left_out)

    def chosen(self) -> set[str]:
        """The bones chosen for the mesh (their names): those written and those the weights left at 0."""
        return set(self.bones) | {b for b, why in self.left_out.items() if why == UNWEIGHTED_BONE}


@dataclass
class Rig:
    """What the weighting needs to know about a skeleton, computed once per document."""

    bones: list[Bone]
    slot_bone: dict[str, int]
    skin_bones: dict[str, set[int]]
    keyed: dict[tuple[str, str, str], str]
    constrained: dict[int, str] = field(default_factory=dict)  # bones constraints move -> kind
    # the artists' habits over the project's weighted meshes, for the learned choice (None: the prior)
    habits: ProjectHabits | None = None
    # learned choices made on this rig, by everything they depend on (:func:`choose`)
    choices: dict = field(default_factory=dict, repr=False, compare=False)
    # the skeleton's animations, sampled when a learned choice is first guarded (:func:`.drift.guard`)
    motion: Motion | None = field(default=None, repr=False, compare=False)
    # source meshes (skin, slot, name) of a 4.3 linked mesh in a slot of another bone -> that slot
    linked_elsewhere: dict[tuple[str, str, str], str] = field(default_factory=dict)

    # :meth:`posed_skin_bones` and :meth:`unposed` of each skin (and slot bone) asked for
    _posed: dict = field(default_factory=dict, repr=False, compare=False)
    _unposed: dict = field(default_factory=dict, repr=False, compare=False)

    @property
    def worlds(self) -> list[np.ndarray]:
        return [b.world for b in self.bones]

    def _activated(self, skin: str) -> frozenset[int]:
        """The bones ``skin`` activates: those it lists and every bone above them (``updateCache``)."""
        out: set[int] = set()
        for b in self.skin_bones.get(skin, set()):
            while b is not None and b not in out:
                out.add(b)
                b = self.bones[b].parent
        return frozenset(out)

    def posed_skin_bones(self, skin: str, slot_bone: int) -> frozenset[int]:
        """The skin bones (``"skin": true``) the runtimes pose whenever ``skin``'s attachments
        on a slot of ``slot_bone`` are drawn: those the skin activates. The default skin's are
        drawn under every skin (its fallback) and under none: on a skin bone, under the skins
        that activate it, so the bones all of those activate; else only bones of no skin (its
        own list, which no editor writes, activates nothing when no skin is set)."""
        key = (skin, slot_bone if skin == "default" else None)
        out = self._posed.get(key)
        if out is None:
            bone, of_skins = self.bones[slot_bone], False  # whether a skin bone is it or above it
            while bone is not None and not of_skins:
                of_skins = bone.skin_required
                bone = None if bone.parent is None else self.bones[bone.parent]
            if skin != "default":
                out = self._activated(skin)
            elif of_skins:
                having = [a for a in map(self._activated, self.skin_bones) if slot_bone in a]
                out = frozenset.intersection(*having) if having else frozenset()
            else:
                out = frozenset()
            self._posed[key] = out
        return out

    def unposed(self, skin: str, slot_bone: int) -> dict[int, str]:
        """Bones whose world transform is not the runtimes' whenever ``skin``'s attachments on a
        slot of ``slot_bone`` are drawn, with why: a skin bone (``"skin": true``) not among
        :meth:`posed_skin_bones` and every bone below it; and, in every skin, a bone that is no
        skin bone below one (the editor makes every bone below a skin bone one): without the
        skin its world transform comes from a parent the runtimes never update, and this setup
        pose, taken without a skin, holds that one (:func:`.constraints.solver.setup_pose`).
        """
        above = self.posed_skin_bones(skin, slot_bone)
        out = self._unposed.get(above)
        if out is None:
            out, skin_bone = {}, {}  # skin_bone: the skin bone a bone is (or hangs below)
            some = frozenset().union(*map(self._activated, self.skin_bones))  # bones some skin activates
            for bone in self.bones:  # parents first
                up = skin_bone.get(bone.parent) if bone.parent is not None else None
                if bone.skin_required or up is not None:
                    skin_bone[bone.index] = bone.index if bone.skin_required and up is None else up
                if up is not None and (not bone.skin_required or bone.parent in out and
                                       out[bone.parent].endswith("some skins activate")):
                    out[bone.index] = f"below bone {self.bones[up].name!r}, which only some skins activate"
                elif bone.skin_required and bone.index not in above:
                    # a skin bone no skin lists (nor a bone below it) is posed, and drawn, by none
                    out[bone.index] = "only active in other skins" if bone.index in some else "active in no skin"
            self._unposed[above] = out
        return out


def _deform_keys(doc: dict) -> dict[tuple[str, str, str], str]:
    """``(skin, slot, attachment) -> animation`` for every deform timeline.

    Up to 4.1 deform timelines sit under ``animations.A.deform`` (``ffd`` before 3.5); from
    4.2 under ``animations.A.attachments`` beside sequence timelines, which do not depend on
    the vertex layout and do not count.
    """
    out = {}
    anims = doc.get("animations")
    for anim_name, anim in (anims.items() if isinstance(anims, dict) else []):
        if not isinstance(anim, dict):
            continue
        for key in ("deform", "ffd", "attachments"):
            skins = anim.get(key)
            for skin, slots in (skins.items() if isinstance(skins, dict) else []):
                for slot, atts in (slots.items() if isinstance(slots, dict) else []):
                    for att, timeline in (atts.items() if isinstance(atts, dict) else []):
                        if key == "attachments" and not (isinstance(timeline, dict) and "deform" in timeline):
                            continue
                        out.setdefault((str(skin), str(slot), str(att)), str(anim_name))
    return out


def build_rig(doc: dict, sample_motion=None) -> Rig:
    """Bones with setup world transforms, slot bones, skin bones and deform-keyed attachments;
    ``sample_motion``: how its animations are sampled for the motion guard (:attr:`WeightOptions.sample_motion`)."""
    bones = skeleton_bones(doc)
    index = {b.name: b.index for b in bones}
    slot_bone = {}
    for s in doc.get("slots", []) or []:
        if isinstance(s, dict) and s.get("bone") in index:
            slot_bone[str(s.get("name"))] = index[s["bone"]]
    skin_bones: dict[str, set[int]] = {}
    skins = doc.get("skins")
    if isinstance(skins, list):
        for skin in skins:
            if isinstance(skin, dict):
                skin_bones[str(skin.get("name", ""))] = {index[n] for n in skin.get("bones", []) or [] if n in index}
    keyed = _deform_keys(doc)
    elsewhere: dict[tuple[str, str, str], str] = {}
    for ref in iter_attachments(doc):
        if ref.type != "linkedmesh":
            continue
        source = linked_source(ref)  # 4.3: perhaps in another slot
        # A linked mesh plays its parent's deform timelines: keys on it hold the parent too.
        if (ref.skin, ref.slot, ref.name) in keyed:
            keyed.setdefault(source, keyed[(ref.skin, ref.slot, ref.name)])
        # Unweighted, it draws its source's vertices in its own slot's bone: bound to bones, in theirs.
        if slot_bone.get(ref.slot) != slot_bone.get(source[1]):
            elsewhere.setdefault(source, ref.slot)
    return Rig(bones, slot_bone, skin_bones, keyed, constrained_bones(doc), motion=Motion(doc, sample_motion),
               linked_elsewhere=elsewhere)


def _matches(patterns: list[str], ref: AttachmentRef) -> bool:
    names = [ref.slot, ref.name, *image_paths(ref)]
    return any(fnmatch.fnmatchcase(n, p) for p in patterns for n in names)


def uses_learned(options: WeightOptions) -> bool:
    """Whether ``options`` bind with the learned choice (``learned``, or ``auto`` while it is :data:`AUTO_BONES`)."""
    return (AUTO_BONES if options.bones == "auto" else options.bones) == "learned"


def choose(rig: Rig, ref: AttachmentRef, mesh, world: np.ndarray, triangles: np.ndarray,
           mode: str, unweighted: bool = False, explain: bool = True, guarded: bool = True) -> Choice:
    """The bones for one mesh: its current ones (``keep``), the ``rule`` or the ``learned`` choice
    (``auto``: :data:`AUTO_BONES`; with the project's habits when ``rig.habits`` holds them;
    ``unweighted``: for art no artist chose to weight; ``explain=False``: the learned choice's
    bones without their reasons, :func:`.learned.choose_learned`; ``guarded=False``: without
    leaving out the bones that would carry the art away, :func:`.drift.guard`)."""
    slot_bone = rig.slot_bone[ref.slot]
    if mode == "keep":
        current = mesh.bones() if mesh.weighted else [slot_bone]
        why = {b: ("artist's bone" if mesh.weighted else "slot bone") for b in current}
        left = {b: rig.bones[b].why for b in current if not rig.bones[b].exact}
        keep = [b for b in current if rig.bones[b].exact]
        return Choice(keep, {b: why[b] for b in keep}, left)
    if uses_learned(WeightOptions(bones=mode)):
        keys = keys_of(ref.slot, ref.name)
        others = rig.habits.others(keys) if rig.habits is not None else None
        neighbours = neighbour_sets(rig.habits, rig.bones, slot_bone, keys)
        skin_bones = rig.posed_skin_bones(ref.skin, slot_bone)
        made = _remembered(rig, (slot_bone, world, triangles, skin_bones, others, neighbours, unweighted, explain))
        # a bone that would carry the art far from where its slot's bone does is a wrong choice
        return guard(made, rig.bones, slot_bone, world, triangles, rig.motion) if guarded else made
    return choose_by_rule(rig.bones, slot_bone, world, triangles, rig.posed_skin_bones(ref.skin, slot_bone))


def _remembered(rig: Rig, inputs: tuple) -> Choice:
    """:func:`.learned.choose_learned` with the shipped model on ``rig``, of ``inputs`` (slot bone,
    world vertices, triangles, skin bones, habits, neighbour sets, unweighted, explain), made
    once per rig: the same art on the same slot bone recurs (one region in several skins, a
    mesh weighted after its region was tested for bending), and the choice is a function of
    these alone. A copy each time (callers keep its dicts)."""
    from .learned import shipped_model

    slot_bone, world, triangles, skin_bones, others, neighbours, unweighted, explain = inputs
    art, tris = np.asarray(world, float), np.asarray(triangles, np.int64)
    key = (slot_bone, art.shape, art.tobytes(), tris.shape, tris.tobytes(), frozenset(skin_bones),
           None if others is None else np.asarray(others, float).tobytes(), tuple(sorted(neighbours.items())),
           unweighted, explain)
    model = shipped_model()
    made = rig.choices.get(key)
    if made is None or made[0] is not model:  # a model swapped in (benchmarks) chooses afresh
        made = rig.choices[key] = (model, choose_learned(rig.bones, slot_bone, world, triangles, skin_bones,
                                                         rig.constrained, habits=others, neighbours=neighbours,
                                                         unweighted=unweighted, explain=explain))
    c = made[1]
    return Choice(list(c.bones), dict(c.why), dict(c.left_out))


def weight_mesh(rig: Rig, ref: AttachmentRef, options: WeightOptions, outcome: Outcome,
                choice: Choice | None = None) -> None:
    """Choose bones, compute weights and bind one mesh attachment, in place; fills ``outcome``.

    ``choice``: the bones, when the caller chose them already (``options.bones`` chooses else).
    """
    att = ref.attachment
    if ref.slot not in rig.slot_bone:
        outcome.status, outcome.reason = "failed", "its slot has no bone"
        return
    if (ref.skin, ref.slot, ref.name) in rig.keyed:
        outcome.status = "skipped"
        outcome.reason = (f"keyed by a deform timeline (animation {rig.keyed[(ref.skin, ref.slot, ref.name)]!r}); "
                          "its keys are laid out per bone entry")
        return
    mesh = parse_vertices(att, len(rig.bones))
    outcome.vertices = mesh.count
    if mesh.weighted and not options.replace:
        outcome.status, outcome.reason = "skipped", "already weighted (use --replace)"
        return
    linked = rig.linked_elsewhere.get((ref.skin, ref.slot, ref.name))
    if linked is not None and not mesh.weighted:
        outcome.status = "skipped"
        outcome.reason = (f"a linked mesh of slot {linked!r} draws its vertices on that slot's bone; "
                          "bound to bones, it would be drawn where this mesh is")
        return
    slot_bone = rig.slot_bone[ref.slot]
    depends = mesh.bones() if mesh.weighted else [slot_bone]
    inexact = [rig.bones[b] for b in depends if not rig.bones[b].exact]
    unposed = rig.unposed(ref.skin, slot_bone)
    inexact += [rig.bones[b] for b in depends if b in unposed and rig.bones[b].exact]
    if inexact:
        first = inexact[0]
        outcome.status = "skipped"
        outcome.reason = f"setup position depends on bone {first.name!r}, {unposed.get(first.index, first.why)}"
        return
    world = setup_world(mesh, rig.worlds, slot_bone)
    try:
        triangles = mesh_triangles(att, mesh.count)
    except SpineMeshError as e:
        outcome.status, outcome.reason = "failed", str(e)
        return
    if choice is None:  # a mesh its artist did not weight is bound as upgrade binds new ones
        choice = choose(rig, ref, mesh, world, triangles, options.bones, unweighted=not mesh.weighted)
    if any(b in unposed for b in choice.bones):  # a bone below one of another skin's: not posed in this one
        choice = Choice([b for b in choice.bones if b not in unposed], choice.why,
                        {**choice.left_out, **{b: unposed[b] for b in choice.bones if b in unposed}})
    outcome.left_out = {rig.bones[b].name: w for b, w in choice.left_out.items()}
    if not choice.bones:
        outcome.status, outcome.reason = "skipped", "none of its bones has an exact setup transform"
        return
    segments = np.stack([rig.bones[b].segment() for b in choice.bones])
    reach = NEAR * float(np.linalg.norm(np.ptp(world, axis=0)))
    prefer = choice.bones.index(slot_bone) if slot_bone in choice.bones else None
    weights = solve_weights_once(world, triangles, segments, options.method, reach, prefer)
    weights = sparsify(weights, options.max_bones, options.min_weight)
    att["vertices"] = bind(world, weights, choice.bones, rig.worlds)
    for col, b in enumerate(choice.bones):
        if weights[:, col].any():
            outcome.bones[rig.bones[b].name] = choice.why[b]
        else:
            outcome.left_out[rig.bones[b].name] = UNWEIGHTED_BONE
    outcome.status = "weighted"


def mesh_count(doc: dict) -> int:
    """How many mesh attachments :func:`weight_document` goes through (its ``on_mesh`` calls)."""
    return sum(ref.type == "mesh" for ref, _ in checked_attachments(doc))


def _telling(pairs, on_mesh):
    """``pairs`` (attachment, problem) as they come, ``on_mesh()`` called once the loop is done
    with each mesh attachment (whichever way its turn ends)."""
    for ref, problem in pairs:
        yield ref, problem
        if ref.type == "mesh" and on_mesh is not None:
            on_mesh()


def weight_document(doc: dict, skeleton: str, options: WeightOptions, rig: Rig | None = None,
                    on_mesh=None, weigh=None) -> list[Outcome]:
    """Weight every selected mesh attachment of ``doc`` in place; one outcome per mesh attachment.

    One bad attachment never stops the others: it is left as it was and reported failed.
    ``on_mesh()``: called after each mesh attachment, weighted or not (:func:`mesh_count` of them).
    ``weigh(ref, outcome)``: given, each selected mesh is handed to it instead of weighted here
    (``weights --jobs``: on the workers, :func:`weigh_meshes`); its outcome is filled later.
    """
    rig = rig or build_rig(doc, options.sample_motion)
    outcomes = []
    for ref, problem in _telling(checked_attachments(doc), on_mesh):
        if problem:  # a field of the wrong type, weighted vertices that do not fit: as it was
            if ref.type in ("mesh", "linkedmesh"):
                outcomes.append(Outcome(skeleton, ref.skin, ref.slot, ref.name, status="failed", reason=problem))
            continue
        if ref.type == "linkedmesh":
            # It draws its parent's vertices (same slot): it follows whatever the parent becomes.
            outcomes.append(Outcome(skeleton, ref.skin, ref.slot, ref.name, status="linked",
                                    reason=f"draws the vertices of its parent {ref.attachment.get('parent')!r}"))
            continue
        if ref.type != "mesh":
            continue
        o = Outcome(skeleton, ref.skin, ref.slot, ref.name)
        outcomes.append(o)
        if options.only and not _matches(options.only, ref):
            o.status, o.reason = "skipped", "not matched by --only"
            continue
        if options.exclude and _matches(options.exclude, ref):
            o.status, o.reason = "skipped", "matched by --exclude"
            continue
        if weigh is None:
            _weigh_timed(rig, ref, options, o)
        else:
            weigh(ref, o)
    return outcomes


def _weigh_timed(rig: Rig, ref: AttachmentRef, options: WeightOptions, outcome: Outcome) -> None:
    """:func:`weight_mesh` of one selected mesh, timed; one that fails is left as it was."""
    start = time.perf_counter()
    before = ref.attachment.get("vertices")
    try:
        weight_mesh(rig, ref, options, outcome)
    except SpineMeshError as e:
        ref.attachment["vertices"] = before
        outcome.status, outcome.reason = "failed", str(e)
    outcome.seconds = round(time.perf_counter() - start, 4)


def weigh_meshes(job: tuple) -> tuple[list[tuple[dict, Outcome]], bool]:
    """One job of ``weights --jobs``, on a worker: ``(doc, skeleton, options, rig, places)``, the
    document without its animations and the ``(skin, slot, name)`` of the meshes to weigh.
    Returns each of those meshes, in document order, as it ends with its outcome, and whether
    the motion guard asked for the animations (:attr:`.drift.Motion.asked`: said only then)."""
    doc, skeleton, options, rig, places = job
    done = []
    for ref in iter_attachments(doc):
        if ref.type == "mesh" and (ref.skin, ref.slot, ref.name) in places:
            outcome = Outcome(skeleton, ref.skin, ref.slot, ref.name)
            _weigh_timed(rig, ref, options, outcome)
            done.append((ref.attachment, outcome))
    return done, rig.motion is not None and rig.motion.asked
