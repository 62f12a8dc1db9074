"""How often each bone choice bends art: on the meshes artists bent, and on what they left rigid.

``upgrade --weights auto`` (and ``spinemesh weights`` on a mesh its artist left unweighted)
binds art no artist chose to weight. The learned choice was fitted on meshes artists weighted,
95% of them to several bones, so it is judged here on both sides, repository-held-out (each
project's bones chosen by the fold models fitted without its repository, ``scripts/train_bone_choice.py
--fold-models``), with and without the project's habits:

- *artist-weighted meshes* (the training dataset, ``--cache``): the share bound to exactly the
  artist's bones, the share bound to several bones of those the artist bound to several, and to
  one bone of those the artist bound to one. The ``unweighted`` row applies the test of
  ``choose_learned(unweighted=True)`` to the held-out probabilities (several bones only when a
  bone besides the slot's reaches the threshold);
- *attachments artists left rigid* (every ``--every``-th region, as its quad in the setup pose,
  and unweighted mesh of the examples and corpus): the share bound to several bones, by
  :func:`spinemesh.rig.choice.choose_by_rule` and :func:`spinemesh.rig.learned.choose_learned`
  with and without ``unweighted``.

Usage::

    .venv/bin/python benchmarks/bench_unweighted_bones.py --cache bone-choice.npz \\
        --fold-models bone-choice-folds [--every 3] [--examples DIR] [--corpus DIR]
"""

from __future__ import annotations

import argparse
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from spinemesh.errors import SpineMeshError  # noqa: E402
from spinemesh.train import bone_choice as tc  # noqa: E402
from spinemesh.rig.binding import parse_vertices, setup_world  # noqa: E402
from spinemesh.rig.choice import choose_by_rule  # noqa: E402
from spinemesh.rig.document import build_rig  # noqa: E402
from spinemesh.rig.habits import keys_of  # noqa: E402
from spinemesh.rig.learned import FEATURES, choose_learned, neighbour_sets, share_project_habits  # noqa: E402
from spinemesh.rig.upgraded_meshes import QUAD_TRIANGLES, QUAD_UV, BendingRegions  # noqa: E402
from spinemesh.skeleton import iter_attachments, load_skeleton  # noqa: E402

SHARED = REPO.parent / "shared"


def weighted_side(data: dict, models: dict) -> None:
    """The artist-weighted meshes: one table row per choice."""
    starts = tc._mesh_rows(data)
    col = {f: i for i, f in enumerate(FEATURES)}
    allowed = (data["X"][:, col["not_exact"]] == 0) & (data["X"][:, col["skin_inactive"]] == 0)
    slot = allowed & (data["X"][:, col["is_slot_bone"]] == 1)
    other = allowed & (data["X"][:, col["is_slot_bone"]] == 0)
    artist = np.asarray(data["artist_count"])

    def per_mesh(rows):
        return np.add.reduceat(rows.astype(int), starts[:-1])

    def row(name, chosen):
        n = per_mesh(chosen)
        j = tc.judge(data, chosen)
        print(f"| {name} | {j['exact']:.1%} | {np.mean(n[artist >= 2] > 1):.1%} | {np.mean(n[artist == 1] <= 1):.1%} |")

    print(f"artist-weighted meshes: {len(artist)}, of {len(np.unique(data['group']))} projects; bound to several "
          f"bones by the artist: {np.sum(artist >= 2)}, to one: {np.sum(artist == 1)}\n")
    print("| choice | exact bone set | several, where the artist bound several | one, where the artist bound one |")
    print("|---|--:|--:|--:|")
    row("rule", data["rule"].astype(bool))
    for label, d in (("without habits", tc.with_habits(data, alone=True)), ("with habits", tc.with_habits(data))):
        p, _ = tc.held_out_probabilities(d, 0.5, log=lambda s: None, models=models)
        learned = tc.fold_sets(d, p, models)
        threshold = next(iter(models.values())).threshold
        likely = np.maximum.reduceat(np.where(other, p, 0.0), starts[:-1]) >= threshold
        rigid = ~likely & (per_mesh(slot) > 0)
        row(f"learned, {label}", learned)
        row(f"unweighted, {label}", np.where(np.repeat(rigid, np.diff(starts)), slot, learned))


def rigid_side(pairs: list[tuple[str, Path]], models: dict, every: int) -> None:
    """The attachments artists left rigid: the share each choice binds to several bones."""
    by_project = defaultdict(list)
    for group, path in pairs:
        by_project[group].append(path)
    counts = defaultdict(list)
    seen = 0
    for group, paths in by_project.items():
        model = tc.model_for(models, tc.repository_of(group, SHARED / "spine-corpus"))
        docs = []
        for path in paths:
            try:
                doc = load_skeleton(path)
                docs.append((doc, build_rig(doc)))
            except SpineMeshError:
                continue
        share_project_habits(docs)
        for doc, rig in docs:
            regions = BendingRegions.of(rig)
            for ref in iter_attachments(doc):
                if ref.type not in ("region", "mesh") or ref.slot not in rig.slot_bone:
                    continue
                slot_bone = rig.slot_bone[ref.slot]
                if not rig.bones[slot_bone].exact:
                    continue
                seen += 1
                if seen % every:
                    continue
                try:
                    if ref.type == "region":
                        world, tris = regions.world(ref, QUAD_UV), QUAD_TRIANGLES
                    else:
                        mesh = parse_vertices(ref.attachment, len(rig.bones))
                        if mesh.weighted:
                            continue
                        world = setup_world(mesh, rig.worlds, slot_bone)
                        tris = np.asarray(ref.attachment["triangles"], int).reshape(-1, 3)
                except (SpineMeshError, KeyError, TypeError, ValueError):
                    continue
                if world is None or not len(tris) or not np.isfinite(world).all() or np.ptp(world, axis=0).max() <= 0:
                    continue
                skin = rig.skin_bones.get(ref.skin, set())
                keys = keys_of(ref.slot, ref.name)
                habits = (rig.habits.others(keys), neighbour_sets(rig.habits, rig.bones, slot_bone, keys))
                counts["kind"].append(ref.type)
                counts["rule"].append(len(choose_by_rule(rig.bones, slot_bone, world, tris, skin).bones))
                for label, (others, nearby) in (("without habits", (None, {})), ("with habits", habits)):
                    for unweighted in (False, True):
                        chosen = choose_learned(rig.bones, slot_bone, world, tris, skin, rig.constrained, model,
                                                others, nearby, unweighted=unweighted).bones
                        counts[("unweighted, " if unweighted else "learned, ") + label].append(len(chosen))
        print(f"{group}: {len(counts['kind'])} attachments", file=sys.stderr, flush=True)
    kind = np.array(counts.pop("kind"))
    print(f"\nattachments artists left rigid (one in {every}): {np.sum(kind == 'region')} regions, "
          f"{np.sum(kind == 'mesh')} unweighted meshes, of {len(by_project)} projects read\n")
    print("| choice | several bones: all | regions | unweighted meshes |")
    print("|---|--:|--:|--:|")
    for name, n in counts.items():
        n = np.asarray(n)
        print(f"| {name} | {np.mean(n > 1):.1%} | {np.mean(n[kind == 'region'] > 1):.1%} | "
              f"{np.mean(n[kind == 'mesh'] > 1):.1%} |")


def dataset_arguments(description: str) -> argparse.ArgumentParser:
    """The arguments of the benchmarks that judge fold models on the training dataset."""
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("--cache", type=Path, required=True, help="the training dataset (train_bone_choice.py --cache)")
    ap.add_argument("--fold-models", type=Path, required=True, help="train_bone_choice.py --habits strict --fold-models")
    ap.add_argument("--examples", type=Path, default=SHARED / "spine-examples")
    ap.add_argument("--corpus", type=Path, default=SHARED / "spine-corpus")
    return ap


def dataset_and_models(args) -> tuple[list[tuple[str, Path]], dict, dict]:
    """``(skeletons, dataset, fold models)`` of :func:`dataset_arguments`' parsed ``args``."""
    pairs = tc.training_skeletons(args.examples, args.corpus)
    data = tc.with_folds(tc.build_dataset(pairs, args.cache, log=lambda s: print(s, file=sys.stderr, flush=True)),
                         args.corpus)
    return pairs, data, tc.load_fold_models(args.fold_models)


def main() -> None:
    ap = dataset_arguments(__doc__.split("\n\n")[0])
    ap.add_argument("--every", type=int, default=3, help="judge every K-th rigid attachment (faster)")
    args = ap.parse_args()
    pairs, data, models = dataset_and_models(args)
    weighted_side(data, models)
    print()
    rigid_side(pairs, models, args.every)


if __name__ == "__main__":
    main()
