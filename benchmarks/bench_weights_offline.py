"""Rig replay without the runtime in the loop: many weighting variants against the artists' own.

    .venv/bin/python benchmarks/bench_weights_offline.py --tool DIR [--corpus 200] [--cache DIR]
        [--every K] [--start N] [--variants NAME,...] [--bounds] [--learned] [--points P] [--tolerance T]
        [--drift-folds D,...] [--pick-folds VARIANT,...]

``bench_weights.py`` plays every variant in the official runtime (four dumps per skeleton,
about 15 minutes for one variant pair). Linear blend skinning is linear in the weights, so one
dump of the artist's skeleton per skeleton is enough to judge any number of variants: the
dump gives every bone's world transform in every sampled frame and every artist vertex's
position; a variant's vertex is then ``sum_j w_j * M_j(frame) @ M_j(setup)^-1 @ p_setup``
(``M_j(setup)`` and ``p_setup`` from :mod:`spinemesh.rig`, which match the runtime's setup pose),
exactly what the runtime draws for a mesh bound the way ``spinemesh weights`` binds it.
(Checked: the artists' own weights, bound that way, give a median ratio of 0.00.)

Printed per variant: meshes compared, the median error per attachment (world units), the
median ratio to the rigid heaviest-artist-bone baseline (attachments the baseline places
within 0.05 left out, as in ``bench_weights.py``), the geometric mean of the ratios, and the
seconds the weights took. Variants:

- ``bbw``: the default (bounded biharmonic weights, handles on the bone segments), on the
  artist's own bones; ``keep`` is the same row (what ``--bones keep`` binds);
- ``bbw-fine``: the same on a refinement of up to 2,000 points (the default is 1,600);
  ``bbw-600``, ``bbw-1200``: on up to 600 (the size before PIQP) or 1,200 points;
- ``bbw-libigl-600``, ``bbw-libigl-fine``: the same problem solved by libigl's active-set
  ``bbw`` on up to 600 points (the default before) or 2,000 points;
- ``harmonic``: harmonic weights (a linear solve);
- ``bbw-mid-handles``: handles on the middle 60% of each segment only;
- ``bbw-point-handles``: one handle per bone, at its segment's middle;
- ``bbw-smoothed``: the default, then one step of averaging with mesh neighbours;
- ``bbw-segments-first``: zero-length bones weighted only when no bone of the mesh has a length;
- ``auto``, ``auto-near``: the ``--bones rule`` choice (segments over the art; ``rule`` is the
  same row), and the same with bones within 5% of the art's size also chosen (the rule before
  this script);
- ``learned``: the ``--bones learned`` choice, repository-held-out: each mesh's bones are chosen by
  the model fitted without its repository's fold (``--fold-models``, written by
  ``scripts/train_bone_choice.py --fold-models``), with the habits of the artist-weighted meshes
  of the project's replayed skeletons when the model reads them;
- ``learned-alone``: the same without the habits, as a project with no artist-weighted mesh
  shows;
- ``confident``, ``upgrade-confident``: ``learned`` and ``upgrade`` where the model is confident
  (no candidate between 0.2 and 0.8 likely), the ``rule`` elsewhere;
- ``upgrade``, ``upgrade-alone``: the bones ``spinemesh upgrade --weights auto`` binds, with and
  without the habits: the learned choice for art no artist chose to weight (more than one bone
  only where a bone besides the slot's reaches the per-bone threshold).

Any variant name may end in ``:`` and steps joined by ``+`` that change its weights:
``sharpen=P`` (each weight to the power ``P``, rows renormalised: above 1 more local, below
softer), ``band=D`` (each vertex eased to its heaviest bone alone as its nearest other weighted
bone's segment lies farther than its heaviest's, wholly from ``D`` times the art's diagonal on),
``smooth=N`` (``N`` steps of averaging with mesh neighbours), ``floor=F`` (weights below ``F``
dropped instead of below 0.01), ``cap=K`` (at most ``K`` bones per vertex), ``reach=R`` (bones
missing the art by at most ``R`` times its diagonal get a handle; ``NEAR`` by default),
``method=M`` (:func:`spinemesh.rig.weights.solve_weights`'s method; ``falloff=P`` the exponent of
``method=geodesic``), ``driftslot=D`` (the
motion guard of the product, :func:`spinemesh.rig.drift.guard`, at limit ``D``: bones that would
carry the art more than ``D`` art diagonals from its slot's bone in the skeleton's animations,
sampled by our own sampler, left out and the slot's bone bound; ``drift=D`` the same without
binding the slot's bone unless nothing is left; ``near=R`` the slot's bone taken as where the art
goes within ``R`` diagonals of it, -1: always; ``ref=R`` where it is not, the guard measures
against another bone, at the limit ``refdrift=D``: ``likely``, the chosen bone the model finds
likeliest, ``habit``, the one the project's artists bound most on the slot's bone, ``art``, the
bone on the art nearest its centre; ``spread=S`` a choice whose bones would carry the art more
than ``S`` diagonals apart bound to the likeliest alone, ``spreadwhere=off`` only where the slot's
bone is not where the art goes), ``minp=P`` (the learned choice's least likely bone taken,
:data:`spinemesh.rig.learned.LEAST_LIKELY`, at ``P``; with ``minpwhere=off`` only where the
slot's bone is not where the art goes, ``minpelse=likely`` the likeliest bound where none is
left; ``habitkeep=1`` but for the bones the project's artists bound on the other meshes on the
same slot bone or its mirror image, ``habitkeep=slot`` so only where the slot's bone is where
the art goes, ``habitkeep=most`` only the bones at least half of them bound), ``slot=A`` (the slot
bone's weights alone to the power ``A``, rows renormalised: below 1 it leads more of the
vertices it shares): ``learned:sharpen=2``.

``--points`` and ``--tolerance`` weigh every variant on another refinement (most points) or
with another solver tolerance than ``spinemesh``'s own.

Each skeleton is played over all its animations (``--animations``), ``--times`` frames each.
Then the variants run side by side on the same meshes, with every aggregate against two
baselines: each vertex rigid on its heaviest artist bone (the artist's rig without blending),
and the whole mesh rigid on its slot's bone (what an upgraded region does without
``--weights auto``): median and geometric mean of the ratios, sum of errors over the baseline's,
and the share of meshes better than the baseline.

Besides the errors, each row prints the share of meshes bound to exactly the artist's bone
set and the bones per mesh (median and 95th percentile; the artists': the last line).

``--bounds`` adds rows that use the artist's answer, to show how far any tuning of these
weights could go: per mesh, the bbw weights sharpened or softened (``w ** p``, renormalised)
with the ``p`` that replays best against the artist; bbw with the artist's heaviest bone put
first at every vertex; and, per mesh, the best of the keep variants run. No tool can know these
choices for a new project; they bound what choosing them could gain.

``--learned`` adds an upper bound for any rule computed from the geometry: a small network
(per vertex and bone: the bbw weights of three handle layouts, distances to every segment,
bone length, the segment parameter, slot bone, bone count) trained on the artists' own weights
of half of the projects and judged on the other half, and the other way round (needs torch,
the ``train`` extra). It shows how much of the artists' weights the geometry can predict.

Needs Node and ``npm ci`` in the runtime tool folder (``--tool``), as ``bench_weights.py``.
"""

from __future__ import annotations

import argparse
import json
import random
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "benchmarks"))

import bench_weights  # noqa: E402
from bench_weights import against, aggregates_table  # noqa: E402,F401  (one definition, both replays)
from spinemesh.errors import SpineMeshError  # noqa: E402
from spinemesh.project import find_project, image_source_for  # noqa: E402
from spinemesh.rig import weights as rig_weights  # noqa: E402
from spinemesh.rig.binding import parse_vertices, setup_world  # noqa: E402
from spinemesh.rig.choice import NEAR, choose_by_rule  # noqa: E402
from spinemesh.rig.document import build_rig  # noqa: E402
from spinemesh.rig.weights import segment_distances, solve_weights, sparsify  # noqa: E402
from spinemesh.skeleton import dumps_skeleton, iter_attachments, load_skeleton  # noqa: E402


def matrix(m: list[float]) -> np.ndarray:
    """The dump's ``[a, b, c, d, worldX, worldY]`` as a (2, 3) affine matrix."""
    a, b, c, d, x, y = m
    return np.array([[a, b, x], [c, d, y]], float)


def collect(tool: Path, cache: Path, examples: str, corpus: int, animations: int | None = None,
            times: int = 4) -> list[tuple[str, Path, Path]]:
    """One runtime dump of each artist skeleton (setup pose and ``times`` frames of each of its
    first ``animations`` animations; None: all of them), cached."""
    cache.mkdir(parents=True, exist_ok=True)
    out = []
    for i, (label, skel) in enumerate(bench_weights.skeletons(examples, corpus)):
        doc = load_skeleton(skel)
        source = image_source_for(doc, skel, find_project(skel.parent))
        if source is None or not hasattr(source, "atlases"):
            continue
        played_poses = "all" if animations is None else animations
        dump = cache / f"{i:04d}-{skel.stem}-{played_poses}x{times}.json"
        if not dump.exists():
            try:
                # played from our JSON of it, as bench_weights.py plays its variants: the harness
                # picks its reader by the file name, and some exports are binary named .json
                with tempfile.TemporaryDirectory() as tmp:
                    played = Path(tmp) / f"{skel.stem}.json"
                    played.write_text(dumps_skeleton(doc))
                    bench_weights.dump(tool, source.atlases[0].path, played, bench_weights.poses(doc, animations, times), dump)
            except RuntimeError as e:
                print(f"{label}/{skel.name}: runtime failed: {str(e)[:200]}", file=sys.stderr)
                continue
        out.append((label, skel, dump))
    return out


def cases_of(label: str, skel: Path, dump_file: Path) -> list[dict]:
    """Every artist-weighted mesh the weights command would replace, with what a replay needs."""
    doc = load_skeleton(skel)
    rig = build_rig(doc)
    names = [b.name for b in rig.bones]
    poses = json.loads(dump_file.read_text())["poses"]
    frames = poses[1:]  # poses[0] is the setup pose: bound positions come from our own transforms
    every_frame = [np.stack([matrix(p["bones"][n]) for n in names]) for p in frames]
    drawn = [{(d["slot"], d["attachment"]): d for d in p["attachments"]} for p in poses]
    out = []
    for ref in iter_attachments(doc):
        att = ref.attachment
        if ref.type != "mesh" or len(att.get("vertices", [])) == len(att.get("uvs", [])):
            continue
        if (ref.skin, ref.slot, ref.name) in rig.keyed or ref.slot not in rig.slot_bone:
            continue
        try:
            mesh = parse_vertices(att, len(rig.bones))
        except SpineMeshError:
            continue
        bones = mesh.bones()
        tris = np.asarray(att.get("triangles", []), int).reshape(-1, 3)
        key = (ref.slot, ref.name)
        if any(not rig.bones[b].exact for b in bones) or not len(tris) or tris.max() >= mesh.count:
            continue
        # frames where the artist's own rig draws NaN (a bone scaled to 0, say) compare nothing
        seen = [k for k in range(len(frames)) if key in drawn[k + 1]
                and len(drawn[k + 1][key]["vertices"]) == 2 * mesh.count
                and np.isfinite(np.asarray(drawn[k + 1][key]["vertices"], float)).all()]
        if not seen:
            continue
        artist = np.zeros((mesh.count, len(bones)))
        for i, influences in enumerate(mesh.influences):
            for b, _, _, w in influences:
                artist[i, bones.index(b)] += w
        world = setup_world(mesh, rig.worlds, rig.slot_bone[ref.slot])
        out.append(dict(
            label=label, skeleton=skel.name, path=skel, skin=ref.skin, slot=ref.slot, name=ref.name, rig=rig, world=world, tris=tris,
            bones=bones, artist=artist, slot_bone=rig.slot_bone[ref.slot],
            setup_matrices=np.stack(rig.worlds), frame_matrices=np.stack([every_frame[k] for k in seen]),
            frame_vertices=np.stack([np.asarray(drawn[k + 1][key]["vertices"], float).reshape(-1, 2) for k in seen])))
    return out


def replay(case: dict, weights: np.ndarray, bones: list[int]) -> float:
    """Mean distance (world units) of the variant's vertices from the artist's, over frames."""
    p = case["world"]
    local = []
    for m in case["setup_matrices"][bones]:
        inv = np.linalg.inv(np.vstack([m, [0, 0, 1]]))[:2]
        local.append(p @ inv[:, :2].T + inv[:, 2])
    local = np.stack(local)                                               # (B, N, 2)
    frames = case["frame_matrices"][:, bones]                             # (F, B, 2, 3)
    moved = np.einsum("fbij,bnj->fbni", frames[..., :2], local) + frames[:, :, None, :, 2]
    drawn = np.einsum("nb,fbni->fni", weights, moved)
    error = float(np.linalg.norm(drawn - case["frame_vertices"], axis=2).mean())
    # a choice that binds a bone the animations scale to nothing draws no vertex at all: as
    # far off as can be, so it counts as the worst case instead of leaving the median
    return error if np.isfinite(error) else float("inf")


def rigid_error(case: dict) -> float:
    """The baseline of the artist's rig: each vertex rigid on its heaviest artist bone."""
    a = case["artist"]
    return replay(case, np.eye(a.shape[1])[a.argmax(1)], case["bones"])


def slot_error(case: dict) -> float:
    """The baseline of a user without weights: the whole mesh rigid on its slot's bone (what an
    upgraded region does without ``--weights auto``)."""
    return replay(case, np.ones((len(case["world"]), 1)), [case["slot_bone"]])


def segments(case: dict, bones: list[int], middle: tuple[float, float] = (0.0, 1.0)) -> np.ndarray:
    s = np.stack([case["rig"].bones[b].segment() for b in bones])
    a, b = s[:, :1], s[:, 1:]
    return np.concatenate([a + middle[0] * (b - a), a + middle[1] * (b - a)], axis=1)


def solved(case: dict, bones: list[int], method: str = "bbw", middle=(0.0, 1.0)) -> np.ndarray:
    """The weights of ``case`` on ``bones`` (as ``spinemesh weights`` solves them), once per case,
    bones, method, handles and refinement: variants that choose the same bones share them."""
    method = SOLVE.get("method") or method
    near = SOLVE.get("reach", NEAR)
    key = (tuple(bones), method, middle, near, rig_weights.REFINED_VERTEX_BUDGET, rig_weights.MAX_SUBDIVISION,
           rig_weights.GEODESIC_FALLOFF)
    memo = case.setdefault("solved", {})
    if key not in memo:
        reach = near * float(np.linalg.norm(np.ptp(case["world"], axis=0)))
        slot = bones.index(case["slot_bone"]) if case["slot_bone"] in bones else None
        memo[key] = solve_weights(case["world"], case["tris"], segments(case, bones, middle), method, reach, slot)
    return memo[key]


def keep(method: str = "bbw", middle=(0.0, 1.0), smooth: int = 0):
    def variant(case):
        bones = case["bones"]
        w = solved(case, bones, method, middle)
        for _ in range(smooth):
            w = 0.5 * w + 0.5 * neighbour_mean(w, case["tris"])
        return bones, w
    return variant


def segments_first():
    """The default, but zero-length bones get weight only when no bone of the mesh has a length."""
    base = keep()

    def variant(case):
        bones = case["bones"]
        long = [b for b in bones if case["rig"].bones[b].length > 0]
        if not long or len(long) == len(bones):
            return base(case)
        _, w = base(dict(case, bones=long))
        out = np.zeros((len(case["world"]), len(bones)))
        out[:, [bones.index(b) for b in long]] = w
        return bones, out
    return variant


def neighbour_mean(w: np.ndarray, tris: np.ndarray) -> np.ndarray:
    from scipy.sparse import coo_matrix

    e = np.concatenate([tris[:, [0, 1]], tris[:, [1, 2]], tris[:, [2, 0]]])
    e = np.concatenate([e, e[:, ::-1]])
    adj = coo_matrix((np.ones(len(e)), (e[:, 0], e[:, 1])), shape=(len(w), len(w))).tocsr()
    adj.data[:] = 1.0
    deg = np.maximum(np.asarray(adj.sum(1)).ravel(), 1.0)
    return (adj @ w) / deg[:, None]


def fine(variant, points: int = 2000, most: int = 16):
    """The variant on a refinement of up to ``points`` points, ``most`` per triangle side."""
    def run(case):
        old = rig_weights.REFINED_VERTEX_BUDGET, rig_weights.MAX_SUBDIVISION
        rig_weights.REFINED_VERTEX_BUDGET, rig_weights.MAX_SUBDIVISION = points, most
        try:
            return variant(case)
        finally:
            rig_weights.REFINED_VERTEX_BUDGET, rig_weights.MAX_SUBDIVISION = old
    return run


def learned(fold_models: Path, skeletons: dict[str, list[Path]], alone: bool = False, unweighted: bool = False,
            unsure: tuple[float, float] | None = None):
    """The learned choice, each case's bones chosen by the fold model fitted without its repository;
    a model that reads the project's habits gets them from the artist-weighted meshes of the
    project's replayed skeletons (``skeletons``, by project), as ``spinemesh weights`` does.
    ``alone``: without them, as a project with no weighted mesh shows. ``unweighted``: as for
    art no artist chose to weight, as ``upgrade --weights auto`` binds
    (:func:`spinemesh.rig.upgraded_meshes.upgrade_choice`). ``unsure``: the model only where it is
    confident, the rule elsewhere: where a candidate's per-bone probability lies inside this
    band, the rule's bones."""
    from spinemesh.train import bone_choice as train_choice
    from spinemesh.rig.habits import keys_of
    from spinemesh.rig.learned import candidates, choose_learned, neighbour_sets
    from spinemesh.rig.drift import follows_slot

    models: dict[int, object] = {}
    habits: dict[str, object] = {}

    def variant(case):
        if not models:
            models.update(train_choice.load_fold_models(fold_models))
        model = train_choice.model_for(models, train_choice.repository_of(case["label"], bench_weights.SHARED
                                                                          / "spine-corpus"))
        reads = model.reads_habits and not alone
        if reads and case["label"] not in habits:
            habits[case["label"]] = bench_weights.project_habits_of(skeletons[case["label"]])
        keys = keys_of(case["slot"], case["name"])
        others = habits[case["label"]].others(keys) if reads else None
        rig = case["rig"]
        nearby = neighbour_sets(habits.get(case["label"]), rig.bones, case["slot_bone"], keys)
        # minp=P: the product's least likely bone taken (LEAST_LIKELY) at P; with minpwhere or
        # minpelse, this replay's own variant of it below
        own = "minpwhere" in SOLVE or "minpelse" in SOLVE
        keep_bound = SOLVE.get("habitkeep") in ("1", "slot", "most")
        chosen = choose_learned(rig.bones, case["slot_bone"], case["world"], case["tris"],
                                rig.skin_bones.get(case["skin"], set()), rig.constrained, model, others, nearby,
                                unweighted, least_likely=0.0 if own or keep_bound else SOLVE.get("minp")).bones
        if keep_bound:
            chosen = without_unlikely_but_bound(case, model, others, nearby, chosen, unweighted)
        if unsure is not None:
            cand = candidates(rig.bones, case["slot_bone"], case["world"], case["tris"],
                              rig.skin_bones.get(case["skin"], set()), rig.constrained)
            p = model.probability(model.with_habits(cand.features, others))
            if ((p > unsure[0]) & (p < unsure[1])).any():
                chosen = choose_by_rule(rig.bones, case["slot_bone"], case["world"], case["tris"],
                                        rig.skin_bones.get(case["skin"], set())).bones
        if SOLVE.get("drift") is not None or SOLVE.get("spread") is not None or own:
            likeliest = None
            if SOLVE.get("ref") in ("likely", "habit") or SOLVE.get("spread") is not None or own:
                cand = candidates(rig.bones, case["slot_bone"], case["world"], case["tris"],
                                  rig.skin_bones.get(case["skin"], set()), rig.constrained)
                p = dict(zip(cand.bones, model.probability(model.with_habits(cand.features, others))))
                likeliest = max(chosen, key=lambda b: p.get(b, 0.0))
                if SOLVE.get("ref") == "habit":  # the chosen bone the project's artists bound most on this slot bone
                    bound = {b: sum(n for members, n in nearby.items() if b in members) for b in chosen}
                    likeliest = max(chosen, key=lambda b: (bound[b], p.get(b, 0.0)))
            if own and (SOLVE.get("minpwhere") != "off" or not follows_slot(
                    rig.bones, case["slot_bone"], case["world"], case["tris"])):
                # chosen bones the per-bone model finds unlikely left out where the slot's bone
                # is off the art (minpwhere=off), the likeliest bound where none is left (minpelse=likely)
                kept = [b for b in chosen if p.get(b, 0.0) >= SOLVE["minp"] or b == case["slot_bone"]]
                chosen = kept or [likeliest if SOLVE.get("minpelse") == "likely" else case["slot_bone"]]
            chosen = guarded_bones(case, chosen, SOLVE.get("drift", float("inf")), SOLVE.get("add_slot", False),
                                   likeliest)
        return chosen, solved(case, chosen)
    return variant


def without_unlikely_but_bound(case: dict, model, others, nearby: dict, chosen: list[int], unweighted: bool) -> list[int]:
    """The ``habitkeep=1`` step: the product's unlikely-bone limit
    (:func:`spinemesh.rig.learned._without_unlikely` at ``minp=P``, default
    :data:`spinemesh.rig.learned.LEAST_LIKELY`, under the same conditions) on the ``chosen`` bones,
    but for the bones the project's artists bound on the other meshes on the same slot bone or its
    mirror image (``nearby``: :func:`spinemesh.rig.learned.neighbour_sets`), kept whatever the
    per-bone model finds (``habitkeep=slot``: only where the slot's bone stands for where the art
    goes, :func:`spinemesh.rig.drift.follows_slot`; ``habitkeep=most``: only the bones at least
    half of those meshes bound)."""
    from spinemesh.rig.learned import LEAST_LIKELY, _without_unlikely, candidates
    from spinemesh.rig.drift import follows_slot

    rig, slot_bone = case["rig"], case["slot_bone"]
    if others is None or not np.any(others) or unweighted:
        return chosen
    if SOLVE.get("habitkeep") == "slot" and not follows_slot(rig.bones, slot_bone, case["world"], case["tris"]):
        nearby = {}  # where the slot's bone is not where the art goes, the product's limit as it is
    skin = rig.skin_bones.get(case["skin"], set())
    cand = candidates(rig.bones, slot_bone, case["world"], case["tris"], skin, rig.constrained)
    p = model.probability(model.with_habits(cand.features, others))
    total = sum(nearby.values())
    least = total / 2 if SOLVE.get("habitkeep") == "most" else 1
    bound = {b for members in nearby for b in members
             if sum(n for other, n in nearby.items() if b in other) >= least}
    p[[k for k, b in enumerate(cand.bones) if b in bound]] = 1.0  # never under the limit
    at = {b: k for k, b in enumerate(cand.bones)}
    bone = rig.bones[slot_bone]
    slot = at[slot_bone] if bone.exact and not (bone.skin_required and slot_bone not in skin) else None
    taken, _ = _without_unlikely([at[b] for b in chosen], p, slot, SOLVE.get("minp", LEAST_LIKELY))
    return sorted(cand.bones[k] for k in taken)


#: Each skeleton's sampled bone transforms (:func:`spinemesh.anim.bone_worlds.sampled_bone_worlds`), by path.
SAMPLED: dict[Path, np.ndarray] = {}


def guarded_bones(case: dict, chosen: list[int], limit: float, add_slot: bool = False,
                  likeliest: int | None = None) -> list[int]:
    """``chosen`` without the bones that would carry the art more than ``limit`` art diagonals
    from where its slot's bone carries it over the skeleton's animations sampled by our own
    sampler (:func:`spinemesh.rig.drift.guarded`, the ``drift=D`` step).

    Where the slot's bone does not stand for where the art goes (the root, or off the art:
    :func:`spinemesh.rig.drift.follows_slot`), the ``ref=R`` step measures against another
    bone instead, at the limit ``refdrift=D`` (default ``limit``): ``art``, the bone on the art
    nearest the art's centre (:func:`art_bone`); ``likely``, the chosen bone the model finds
    likeliest (``likeliest``); ``habit``, the chosen bone the project's artists bound most on
    the mesh's slot bone (:func:`spinemesh.rig.learned.neighbour_sets`; the likeliest of a tie:
    ``likeliest`` then). ``spread=S``: a choice whose bones would carry the art more than
    ``S`` art diagonals apart (the largest drift between two of them) is bound to
    ``likeliest`` alone (``spreadwhere=off``: only where the slot's bone does not stand for the
    art)."""
    from spinemesh.rig.choice import Choice
    from spinemesh.rig.drift import SLOT_NEAR, follows_slot, guarded

    rig = case["rig"]
    follows = SOLVE.get("slot_near", 0.0) < 0 or follows_slot(rig.bones, case["slot_bone"], case["world"],
                                                               case["tris"], SOLVE.get("slot_near", SLOT_NEAR))
    spread = SOLVE.get("spread")
    if spread is not None and len(chosen) > 1 and (not follows or SOLVE.get("spreadwhere") != "off"):
        if max(drift_between(case, a, [b])[b] for a in chosen for b in chosen if a < b) > spread:
            return [likeliest]
    if limit == float("inf"):
        return chosen
    reference = case["slot_bone"]
    if not follows:
        ref = SOLVE.get("ref")
        reference = art_bone(case) if ref == "art" else likeliest if ref in ("likely", "habit") else None
        if reference is None:
            return chosen
        limit = SOLVE.get("refdrift", limit)
    drift = drift_between(case, reference, chosen)
    exact = rig.bones[reference].exact
    return guarded(Choice(list(chosen), {}, {}), drift, reference, limit, add_slot, exact).bones


def drift_between(case: dict, reference: int, bones: list[int]) -> dict[int, float]:
    """How far each of ``bones`` would carry the art from where ``reference`` carries it
    (:func:`spinemesh.rig.drift.drifts`), over the skeleton's animations sampled by our own
    sampler; kept on the case."""
    from spinemesh.anim.bone_worlds import sampled_bone_worlds
    from spinemesh.rig.drift import drifts

    if case["path"] not in SAMPLED:
        SAMPLED[case["path"]] = sampled_bone_worlds(load_skeleton(case["path"]))
    known = case.setdefault("drifts", {}).setdefault(reference, {})
    missing = [b for b in bones if b not in known]
    if missing:
        known.update(drifts(case["world"], case["setup_matrices"], SAMPLED[case["path"]], reference, missing))
    return known


def art_bone(case: dict) -> int | None:
    """The bone whose segment passes nearest the centre of the art's bounding box among the
    bones that lie on the art (within :data:`spinemesh.rig.drift.SLOT_NEAR` of its diagonal),
    not the root, setup transform exact; None when there is none."""
    from spinemesh.rig.choice import distance_to_art
    from spinemesh.rig.drift import SLOT_NEAR

    if "art_bone" not in case:
        rig, world = case["rig"], case["world"]
        diag = float(np.linalg.norm(np.ptp(world, axis=0)))
        centre = (world.min(axis=0) + world.max(axis=0)) / 2
        best, nearest = None, float("inf")
        for i, b in enumerate(rig.bones):
            if b.parent is None or not b.exact:
                continue
            a, e = np.asarray(b.segment(), float).reshape(2, 2)
            points = a + np.linspace(0.0, 1.0, 17)[:, None] * (e - a)
            if distance_to_art(points, world, case["tris"]).min() > SLOT_NEAR * diag:
                continue
            d = float(segment_distances(centre[None], np.stack([a, e])[None])[0, 0])
            if d < nearest:
                best, nearest = i, d
        case["art_bone"] = best
    return case["art_bone"]


def auto(near: float | None = None):
    def variant(case):
        import spinemesh.rig.choice as choice

        rig, old = case["rig"], choice.OVER_ART
        if near is not None:
            choice.OVER_ART = near
        try:
            chosen = choose_by_rule(rig.bones, case["slot_bone"], case["world"], case["tris"],
                                 rig.skin_bones.get(case["skin"], set())).bones
        finally:
            choice.OVER_ART = old
        return chosen, solved(case, chosen)
    return variant


VARIANTS = {
    "keep": keep(),
    "bbw": keep(),
    "bbw-fine": fine(keep()),
    "bbw-600": fine(keep(), 600, 8),
    "bbw-1200": fine(keep(), 1200, 16),
    "bbw-libigl-600": fine(keep("bbw-libigl"), 600, 8),
    "bbw-libigl-fine": fine(keep("bbw-libigl")),
    "harmonic": keep("harmonic"),
    "bbw-mid-handles": keep(middle=(0.2, 0.8)),
    "bbw-point-handles": keep(middle=(0.5, 0.5)),
    "bbw-smoothed": keep(smooth=1),
    "bbw-segments-first": segments_first(),
    "auto": auto(),
    "rule": auto(),
    "auto-near": auto(NEAR),
}


def judge(cases: list[dict], results: dict[int, float], chosen: dict[int, list[int]] | None = None) -> dict:
    """Median error and ratios to rigid; with the bones ``chosen`` per case, the exact-set share and
    bones per mesh (median, 95th percentile)."""
    ratios = [results[i] / cases[i]["rigid"] for i in results
              if bench_weights.RIGID_FLOOR < cases[i]["rigid"] < float("inf")]
    out = {"meshes": len(results), "error": statistics.median(results.values()),
           "ratio": statistics.median(ratios), "geomean": float(np.exp(np.mean(np.log(np.clip(ratios, 1e-3, 1e3)))))}
    if chosen:
        counts = [len(chosen[i]) for i in results]
        out.update(exact=float(np.mean([set(chosen[i]) == set(cases[i]["bones"]) for i in results])),
                   bones=f"{np.median(counts):.0f} / {np.percentile(counts, 95):.0f}")
    return out


#: What a variant's name after a ``:`` changes in the solve (:func:`variant_of`): ``reach=R``,
#: bones whose segment misses the art by at most ``R`` times its diagonal get a handle (default
#: ``NEAR``); ``method=M``, the method of :func:`solve_weights`.
SOLVE: dict = {}


def variant_of(name: str):
    """The variant ``name`` of :data:`VARIANTS`, its solve changed by the ``reach`` and
    ``method`` steps after a ``:`` (:data:`SOLVE`); the other steps are post-processing
    (:func:`finished`)."""
    base = VARIANTS[name.partition(":")[0]]
    options = {}
    for step in filter(None, name.partition(":")[2].split("+")):
        what, _, value = step.partition("=")
        if what == "reach":
            options["reach"] = float(value)
        elif what == "method":
            options["method"] = value
        elif what == "falloff":
            options["falloff"] = float(value)
        elif what in ("drift", "driftslot"):
            options["drift"], options["add_slot"] = float(value), what == "driftslot"
        elif what == "near":
            options["slot_near"] = float(value)
        elif what in ("refdrift", "spread", "minp"):
            options[what] = float(value)
        elif what in ("ref", "spreadwhere", "minpwhere", "minpelse", "habitkeep"):
            options[what] = value

    def run(case):
        SOLVE.clear()
        SOLVE.update(options)
        falloff = rig_weights.GEODESIC_FALLOFF
        rig_weights.GEODESIC_FALLOFF = options.get("falloff", falloff)
        try:
            return base(case)
        finally:
            SOLVE.clear()
            rig_weights.GEODESIC_FALLOFF = falloff
    return run


def finished(case: dict, name: str, w: np.ndarray, bones: list[int], cap: int) -> np.ndarray:
    """The solved weights ``w`` of ``case`` as the runtime gets them under the variant ``name``:
    its post-processing after a ``:`` (joined by ``+``, in order: ``sharpen=P``, each weight
    to the power ``P``, renormalised; ``band=D``, each vertex eased to its heaviest bone as its
    nearest other weighted bone's segment lies farther than its heaviest's, wholly from ``D``
    times the art's diagonal on; ``floor=F``, weights below ``F`` dropped; ``cap=K``, at most
    ``K`` bones per vertex), then at most ``cap`` bones per vertex, none below 0.01."""
    floor = 0.01
    for step in filter(None, name.partition(":")[2].split("+")):
        what, _, value = step.partition("=")
        if what == "sharpen":
            w = sharpened(w, float(value))
        elif what == "slot" and case["slot_bone"] in bones:
            w = np.asarray(w, float).copy()
            col = bones.index(case["slot_bone"])
            w[:, col] **= float(value)
            w /= w.sum(axis=1, keepdims=True)
        elif what == "slot":
            pass  # the slot's bone is not bound: nothing to favour
        elif what == "band":
            w = banded(w, case["world"], segments(case, bones), float(value))
        elif what == "floor":
            floor = float(value)
        elif what == "cap":
            cap = min(cap, int(value))
        elif what == "smooth":
            for _ in range(int(value)):
                w = 0.5 * w + 0.5 * neighbour_mean(w, case["tris"])
        elif what in ("reach", "method", "falloff", "drift", "driftslot", "near", "ref", "refdrift", "spread",
                      "spreadwhere", "minp", "minpwhere", "minpelse", "habitkeep"):
            pass  # the solve's (variant_of)
        else:
            raise ValueError(f"unknown post-processing {step!r} in variant {name!r}")
    return sparsify(w, cap, floor)


def banded(w: np.ndarray, points: np.ndarray, segs: np.ndarray, band: float) -> np.ndarray:
    """``w`` eased towards each vertex's heaviest bone alone, linearly in how much farther the
    nearest other weighted bone's segment lies than the heaviest's: unchanged where they lie
    as near, its heaviest bone alone from ``band`` times the art's diagonal on."""
    w = np.asarray(w, float)
    if w.shape[1] < 2:
        return w
    diag = max(float(np.linalg.norm(np.ptp(points, axis=0))), 1e-9)
    d = segment_distances(points, segs) / diag                               # (N, B)
    rows = np.arange(len(w))
    top = w.argmax(1)
    other = np.where((w > 0) & (np.arange(w.shape[1]) != top[:, None]), d, np.inf).min(1)
    t = np.clip((other - d[rows, top]) / band, 0.0, 1.0)[:, None]
    return (1 - t) * w + t * np.eye(w.shape[1])[top]


#: Exponents tried by the sharpness bound: below 1 softens the blend, above 1 sharpens it.
SHARPNESS = (0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 4.0, 6.0, 10.0, 30.0)


def sharpened(w: np.ndarray, p: float) -> np.ndarray:
    """Weights raised to the power ``p``, rows renormalised to sum 1."""
    w = np.asarray(w, float) ** p
    return w / w.sum(axis=1, keepdims=True)


def heaviest_swapped(w: np.ndarray, artist: np.ndarray) -> np.ndarray:
    """``w`` with, at each vertex, its largest weight moved to the artist's heaviest bone."""
    w = w.copy()
    rows = np.arange(len(w))
    ours, theirs = w.argmax(1), artist.argmax(1)
    big, other = w[rows, ours], w[rows, theirs]
    w[rows, theirs], w[rows, ours] = big, other
    return w


def oracle_bounds(cases: list[dict], per_variant: dict[str, dict[int, float]],
                  bbw: dict[int, tuple] | None = None) -> dict[str, dict[int, float]]:
    """Errors of choices made with the artist's answer (see ``--bounds``).

    ``bbw``: each case's ``(bones, weights)`` of the ``bbw`` variant when already solved.
    """
    sharp, swapped = {}, {}
    for i, c in enumerate(cases):
        bones, w = bbw[i] if bbw else VARIANTS["bbw"](c)
        sharp[i] = min(replay(c, sparsify(sharpened(w, p), 4, 0.01), bones) for p in SHARPNESS)
        swapped[i] = replay(c, sparsify(heaviest_swapped(w, c["artist"]), 4, 0.01), bones)
    out = {"bbw, sharpness chosen per mesh against the artist (bound)": sharp,
           "bbw, artist's heaviest bone put first (bound)": swapped}
    kept_bones = {n: r for n, r in per_variant.items() if not n.startswith("auto")}
    if len(kept_bones) > 1:  # the auto variants bind other bones: not compared here
        best = {i: min(r[i] for r in kept_bones.values()) for i in range(len(cases))}
        out[f"best of the {len(kept_bones)} keep variants per mesh (bound)"] = best
    return out


def learned_bound(cases: list[dict], seed: int = 0) -> dict[int, float]:
    """Errors of a network trained on the artists' weights of the other half of the projects."""
    import torch

    torch.manual_seed(seed)
    layouts = [keep(), keep(middle=(0.2, 0.8)), keep(middle=(0.5, 0.5))]
    feats = []
    for c in cases:
        w = [v(c)[1] for v in layouts]
        segs = segments(c, c["bones"])
        diag = float(np.linalg.norm(np.ptp(c["world"], axis=0))) + 1e-9
        d = segment_distances(c["world"], segs) / diag
        length = np.linalg.norm(segs[:, 1] - segs[:, 0], axis=1) / diag
        t = np.zeros_like(d)
        for j, (a, b) in enumerate(segs):
            ab = b - a
            t[:, j] = ((c["world"] - a) @ ab) / (ab @ ab) if ab @ ab > 0 else 0.0
        slot = np.array([b == c["slot_bone"] for b in c["bones"]], float)
        f = np.stack([*w, d, d - d.min(1, keepdims=True), np.broadcast_to(length, d.shape),
                      np.clip(t, -2, 3), np.broadcast_to(slot, d.shape), np.full(d.shape, 1 / len(segs))], -1)
        feats.append(torch.tensor(f, dtype=torch.float32))
    projects = sorted({c["label"] for c in cases})
    random.Random(seed).shuffle(projects)
    fold = {p: i % 2 for i, p in enumerate(projects)}
    out = {}
    for k in (0, 1):
        net = torch.nn.Sequential(torch.nn.Linear(feats[0].shape[-1], 32), torch.nn.ReLU(),
                                  torch.nn.Linear(32, 32), torch.nn.ReLU(), torch.nn.Linear(32, 1))
        opt = torch.optim.Adam(net.parameters(), 3e-3)
        train = [i for i, c in enumerate(cases) if fold[c["label"]] != k and len(c["bones"]) > 1]
        for _ in range(15):
            random.Random(seed).shuffle(train)
            for i in train:
                w = torch.softmax(net(feats[i]).squeeze(-1), dim=1)
                loss = (w - torch.tensor(cases[i]["artist"], dtype=torch.float32)).abs().sum(1).mean()
                opt.zero_grad()
                loss.backward()
                opt.step()
        with torch.no_grad():
            for i, c in enumerate(cases):
                if fold[c["label"]] == k:
                    w = torch.softmax(net(feats[i]).squeeze(-1), dim=1).numpy().astype(float)
                    out[i] = replay(c, sparsify(w, 4, 0.01), c["bones"])
    return out


def replay_cases(tool: Path, cache: Path, examples: str, corpus: int, every: int, animations: int | None,
                 times: int, fold_models: Path, start: int = 0) -> list[dict]:
    """Every ``every``-th artist-weighted mesh from the ``start``-th of the replayed skeletons (:func:`collect`,
    :func:`cases_of`) with both baselines' errors (``rigid``, ``slot``), and the learned
    variants registered in :data:`VARIANTS` with the fold models ``fold_models``."""
    cases, skeletons = [], {}
    for label, skel, dump in collect(tool, cache, examples, corpus, animations, times):
        cases += cases_of(label, skel, dump)
        skeletons.setdefault(label, []).append(skel)
    VARIANTS["learned"] = learned(fold_models, skeletons)
    VARIANTS["learned-alone"] = learned(fold_models, skeletons, alone=True)
    VARIANTS["upgrade"] = learned(fold_models, skeletons, unweighted=True)
    VARIANTS["upgrade-alone"] = learned(fold_models, skeletons, alone=True, unweighted=True)
    VARIANTS["confident"] = learned(fold_models, skeletons, unsure=(0.2, 0.8))
    VARIANTS["upgrade-confident"] = learned(fold_models, skeletons, unweighted=True, unsure=(0.2, 0.8))
    cases = cases[start::every]
    for c in cases:
        # not "slot": that is the slot's name, which the learned choice's habits read
        c["rigid"], c["on_slot_bone"] = rigid_error(c), slot_error(c)
    return cases


def case_key(case: dict) -> str:
    """A case's name across runs: its project, skeleton and attachment."""
    return f"{case['label']}|{case['skeleton']}|{case['skin']}|{case['slot']}|{case['name']}"


def errors_of(cases: list[dict], name: str, cap: int = 4, saved: Path | None = None,
              fold_models: Path | None = None) -> dict[int, float]:
    """Each case's replay error under the variant ``name``, at most ``cap`` bones per vertex.

    ``saved``: a JSON file of the errors of earlier runs, read and written back: a case's error
    under the same variant, cap (and, for the variants that read them, fold models) is not
    computed again, so runs over a few variants at a time add up to one table.
    """
    import json as _json

    known = _json.loads(saved.read_text()) if saved is not None and saved.is_file() else {}
    models = str(fold_models) if name.partition(":")[0] in LEARNED_VARIANTS else ""
    solver = (rig_weights.REFINED_VERTEX_BUDGET, rig_weights.SOLVER_TOLERANCE)
    # errors under other --points or --tolerance are kept apart (the defaults keep the old keys)
    apart = "" if solver == SHIPPED_SOLVER else f"|{solver[0]}|{solver[1]:g}"
    column = known.setdefault(f"{name}|{cap}|{models}{apart}", {})
    out = {}
    for i, c in enumerate(cases):
        key = case_key(c)
        if key not in column:
            bones, w = variant_of(name)(c)
            column[key] = replay(c, finished(c, name, w, bones, cap), bones)
        out[i] = column[key]
    if saved is not None:
        saved.write_text(_json.dumps(known))
    return out


#: The refinement's most points and PIQP's tolerance that ``spinemesh`` weighs with (``--points``,
#: ``--tolerance`` replay others).
SHIPPED_SOLVER = (rig_weights.REFINED_VERTEX_BUDGET, rig_weights.SOLVER_TOLERANCE)


def drift_chosen_by_fold(cases: list[dict], limits: list[float], saved: Path | None, fold_models: Path) -> dict[int, float]:
    """``learned`` with the motion guard (``driftslot=D``) at a limit chosen without the judged
    repository (:func:`chosen_by_fold` among ``learned:driftslot=D`` for each of ``limits``)."""
    return chosen_by_fold(cases, [f"learned:driftslot={d:g}" for d in limits], saved, fold_models)


def chosen_by_fold(cases: list[dict], names: list[str], saved: Path | None, fold_models: Path) -> dict[int, float]:
    """Each case's error under the variant of ``names`` chosen without its repository: for the
    meshes of each repository fold, the variant with the lowest slot-bone sum ratio on the
    meshes of the other folds. Prints each fold's pick.

    The folds are the fold models' (each lists the repositories it held out)."""
    from spinemesh.train import bone_choice as train_choice

    models = train_choice.load_fold_models(fold_models)
    repos = {c["label"]: train_choice.repository_of(c["label"], bench_weights.SHARED / "spine-corpus") for c in cases}
    fold = [next((k for k in sorted(models) if repos[c["label"]] in models[k].meta.get("held_out", ())), min(models))
            for c in cases]
    errors = {name: errors_of(cases, name, 4, saved, fold_models) for name in names}
    out = {}
    for k in sorted(set(fold)):
        others = [i for i in range(len(cases)) if fold[i] != k]
        best = min(names, key=lambda n: against(cases, {i: errors[n][i] for i in others}, "on_slot_bone")["sum"])
        print(f"fold {k}: {best} (chosen on the other folds' {len(others)} meshes)")
        out.update({i: errors[best][i] for i in range(len(cases)) if fold[i] == k})
    return out


#: The variants that read the fold models (:func:`learned`).
LEARNED_VARIANTS = ("learned", "learned-alone", "upgrade", "upgrade-alone", "confident", "upgrade-confident")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--tool", type=Path, required=True, help="installed copy of tools/spine-runtime")
    ap.add_argument("--examples", default="4.2")
    ap.add_argument("--corpus", type=int, default=200)
    ap.add_argument("--cache", type=Path, default=Path("weights-replay-cache"), help="folder for the dumps")
    ap.add_argument("--every", type=int, default=1, help="judge every K-th mesh (faster)")
    ap.add_argument("--start", type=int, default=0, help="with --every K, start at the N-th mesh (0 to K-1)")
    ap.add_argument("--animations", type=int, default=0, help="replay each skeleton's first N animations (0: all)")
    ap.add_argument("--times", type=int, default=4, help="frames replayed per animation, evenly spaced")
    ap.add_argument("--variants", default="bbw,harmonic,bbw-mid-handles,bbw-point-handles,bbw-smoothed,auto,auto-near")
    ap.add_argument("--bounds", action="store_true", help="add the bounds that use the artist's answer")
    ap.add_argument("--max-bones", default="4", help="most bones per vertex, as `spinemesh weights --max-bones`; "
                    "a comma-separated list replays each variant with each")
    ap.add_argument("--learned", action="store_true")
    ap.add_argument("--errors", type=Path, help="JSON file of the errors of earlier runs: reused and added to "
                    "(a variant run before is not run again; the table covers every variant named)")
    ap.add_argument("--drift-folds", default="", help="comma-separated limits of the motion guard (driftslot=D): "
                    "adds learned with each repository fold's limit chosen on the other folds")
    ap.add_argument("--pick-folds", default="", help="comma-separated variants: adds the one each repository fold "
                    "picks on the other folds (lowest slot-bone sum ratio), judged on its own meshes")
    ap.add_argument("--fold-models", type=Path, default=Path("/tmp/spinemesh-bone-choice-folds"),
                    help="the learned choice's fold models (scripts/train_bone_choice.py --fold-models)")
    ap.add_argument("--points", type=int, default=rig_weights.REFINED_VERTEX_BUDGET,
                    help="most points of the refinement every variant solves its weights on")
    ap.add_argument("--tolerance", type=float, default=rig_weights.SOLVER_TOLERANCE,
                    help="PIQP's absolute and relative tolerance for the bounded biharmonic weights")
    args = ap.parse_args()
    # every variant's weights with these (the rows named after a point count set their own)
    rig_weights.REFINED_VERTEX_BUDGET, rig_weights.SOLVER_TOLERANCE = args.points, args.tolerance
    cases = replay_cases(args.tool, args.cache, args.examples, args.corpus, args.every, args.animations or None,
                         args.times, args.fold_models, args.start)
    print(f"{len(cases)} artist-weighted meshes, {len({c['label'] for c in cases})} projects\n", flush=True)
    print("| variant | meshes | median error | median ratio to rigid | geometric mean ratio | exact bone set "
          "| bones / mesh median / p95 | seconds |")
    print("|---|---|---|---|---|---|---|---|")
    names = [n for n in args.variants.split(",") if n]
    per_variant: dict[str, dict[int, float]] = {}

    def row(name: str, results: dict[int, float], start: float, chosen: dict | None = None) -> None:
        s = judge(cases, results, chosen)
        exact = f"{s['exact']:.1%}" if chosen else ""
        print(f"| {name} | {s['meshes']} | {s['error']:.3f} | {s['ratio']:.3f} | {s['geomean']:.3f} | "
              f"{exact} | {s.get('bones', '')} | {time.perf_counter() - start:.0f} |", flush=True)

    caps = [int(n) for n in args.max_bones.split(",") if n]
    bbw = {}  # the default's weights, kept for the bounds built on them
    for name in names:
        start = time.perf_counter()
        if args.errors is not None and caps == [4] and not args.bounds:  # errors only, kept across runs
            per_variant[name] = errors_of(cases, name, 4, args.errors, args.fold_models)
            row(name, per_variant[name], start)
            continue
        results, chosen = {cap: {} for cap in caps}, {}
        for i, c in enumerate(cases):
            bones, w = variant_of(name)(c)
            if name == "bbw" and args.bounds:
                bbw[i] = bones, w
            for cap in caps:
                results[cap][i] = replay(c, finished(c, name, w, bones, cap), bones)
            chosen[i] = bones
        per_variant[name] = results[caps[0]]
        for cap in caps:
            row(name if caps == [4] else f"{name}, at most {cap} bones per vertex", results[cap], start, chosen)
    if args.bounds:
        start = time.perf_counter()
        for name, results in oracle_bounds(cases, per_variant, bbw).items():
            row(name, results, start)
            per_variant[name] = results
    if args.drift_folds:
        start = time.perf_counter()
        name = "learned, drift limit chosen on the other folds"
        per_variant[name] = drift_chosen_by_fold(cases, [float(d) for d in args.drift_folds.split(",")], args.errors,
                                                 args.fold_models)
        row(name, per_variant[name], start)
    if args.pick_folds:
        start = time.perf_counter()
        name = "variant chosen on the other folds"
        per_variant[name] = chosen_by_fold(cases, [n for n in args.pick_folds.split(",") if n], args.errors,
                                           args.fold_models)
        row(name, per_variant[name], start)
    if args.learned:
        start = time.perf_counter()
        row("learned weights (project-held-out upper bound)", learned_bound(cases), start)
    print(f"\nthe same meshes, every aggregate against both baselines:\n\n{aggregates_table(cases, per_variant)}")
    counts = [len(c["bones"]) for c in cases]
    print(f"\nartists' bones per mesh: median {np.median(counts):.0f}, p95 {np.percentile(counts, 95):.0f}")
    per_vertex = np.concatenate([(np.asarray(c["artist"]) > 0).sum(axis=1) for c in cases])
    shares = ", ".join(f"{n}: {np.mean(np.minimum(per_vertex, 5) == n):.1%}" for n in range(1, 6))
    print(f"artists' bones per vertex (5: five or more): {shares}")


if __name__ == "__main__":
    main()
