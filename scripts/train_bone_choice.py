"""Fit the ``learned`` bone choice to the artists' bindings, judge it repository-held-out, ship it.

    .venv/bin/python scripts/train_bone_choice.py [--examples DIR] [--corpus DIR]
        [--cache FILE.npz] [--project-power P] [--threshold T] [--fold-models DIR] [--write]
        [--habits strict] [--train-share S] [--replay TOOL --replay-cache DIR --replay-every K]

Builds the dataset (:mod:`spinemesh.train.bone_choice`: every artist-weighted mesh of each
example in its newest version and of every corpus project, each bone near its art a row),
cached in ``--cache`` (extraction takes minutes; delete the file to rebuild). Then fits one
per-bone model per repository-held-out fold, and per fold a set-level model
(:mod:`spinemesh.rig.bone_sets`) on the other folds' candidate sets, their per-bone
probabilities each from a model fitted without their own fold; prints, for the ``rule``, the
per-bone choice at a few thresholds and the ``learned`` choice (per bone, then set level) on
the same meshes, the share of meshes given exactly the artist's bone set and the bones per
mesh against the artists'. ``--fold-models DIR`` keeps the fold models for the weights benchmarks
(their ``learned`` rows, repository-held-out). ``--write`` fits on every project and writes
``spinemesh/models/bone_choice.json``. ``--train-share S`` lets the models learn from a share
``S`` of the projects only (drawn by name; the others weigh 0 in every fit) while every mesh is
still judged held out: run with a few shares, it draws the learning curve. ``--replay TOOL``
then plays keep, rule, the learned choice and the upgrade's choice of the fold models in the
artists' animations (``benchmarks/bench_weights_offline.py``) and prints every aggregate against
both baselines. The folds hold out whole repositories (:func:`spinemesh.train.bone_choice.with_folds`).
Needs scikit-learn and LightGBM (the ``train`` extra); set ``OMP_NUM_THREADS=1`` on a busy machine.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from spinemesh.rig import habits as hb  # noqa: E402
from spinemesh.train import bone_choice as tc  # noqa: E402
from spinemesh.rig.learned import CHAIN_REACH, MODEL_PATH, REACH  # noqa: E402


def table(rows: list[tuple[str, dict]]) -> None:
    print("| choice | meshes | projects | exact bone set | bones / mesh median | p95 | artists' median | p95 "
          "| more than the artist | fewer |")
    print("|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|")
    for name, s in rows:
        print(f"| {name} | {s['meshes']} | {s['projects']} | {s['exact']:.1%} | {s['bones_median']:.0f} | "
              f"{s['bones_p95']:.0f} | {s['artist_median']:.0f} | {s['artist_p95']:.0f} | {s['too_many']:.1%} | "
              f"{s['too_few']:.1%} |")


def main() -> None:
    shared = REPO.parent / "shared"
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--examples", type=Path, default=shared / "spine-examples")
    ap.add_argument("--corpus", type=Path, default=shared / "spine-corpus")
    ap.add_argument("--cache", type=Path, default=Path("/tmp/spinemesh-bone-choice.npz"))
    ap.add_argument("--project-power", type=float, default=0.5, help="a project of M meshes weighs M**P")
    ap.add_argument("--threshold", type=float, default=0.5, help="probability at which a bone is chosen")
    ap.add_argument("--fold-models", type=Path, help="write the fold models here (for the weights benchmarks)")
    ap.add_argument("--reuse-folds", action="store_true", help="judge with the fold models already in "
                    "--fold-models (fitted on the same dataset) instead of fitting them again")
    ap.add_argument("--reach", type=float, default=REACH, help="candidates' reach, share of the art's diagonal")
    ap.add_argument("--chain-reach", type=float, default=CHAIN_REACH,
                    help="candidates' reach along the slot bone's chain, share of the art's diagonal")
    ap.add_argument("--habits", choices=("none", "strict", "loose"), default="none",
                    help="add the project's habits (the other weighted meshes of its project; strict: also "
                    "without those of the same slot or attachment name)")
    ap.add_argument("--write", action="store_true", help="fit on every project and write the shipped model")
    ap.add_argument("--train-share", type=float, default=1.0,
                    help="learn from this share of the projects only (drawn by name), judging every mesh held out "
                    "as before: a learning curve")
    ap.add_argument("--replay", type=Path, metavar="TOOL", help="then replay keep, rule and the learned "
                    "choice of the fold models in the artists' animations (benchmarks/bench_weights_offline.py, "
                    "an installed copy of tools/spine-runtime; needs --fold-models): every aggregate against both "
                    "baselines")
    ap.add_argument("--replay-cache", type=Path, default=Path("weights-replay-cache"), help="the replay's dumps")
    ap.add_argument("--replay-every", type=int, default=1, help="replay every K-th mesh (faster)")
    args = ap.parse_args()
    if args.replay and not args.fold_models:
        ap.error("--replay judges the fold models: give --fold-models")
    if not 0 < args.train_share <= 1:
        ap.error("--train-share must be in (0, 1]")
    if args.train_share < 1 and args.write:
        ap.error("--train-share is for learning curves: the shipped model learns from every project")

    start = time.perf_counter()
    data = tc.build_dataset(tc.training_skeletons(args.examples, args.corpus), args.cache,
                            log=lambda s: print(s, file=sys.stderr, flush=True), reach=args.reach,
                            chain_reach=args.chain_reach)
    data = tc.with_folds(data, args.corpus)
    meshes = len(data["group"])
    print(f"{meshes} artist-weighted meshes, {len(np.unique(data['group']))} projects of "
          f"{len(np.unique(data['repository']))} repositories, {len(data['y'])} candidate "
          f"bones ({data['y'].mean():.1%} bound by the artist); artist's bones beyond the candidates on "
          f"{(data['missed'] > 0).mean():.1%} of meshes ({time.perf_counter() - start:.0f} s)\n")
    habits = tc.with_habits(data, args.habits != "loose")
    # meshes whose project has no other weighted mesh (of another slot and attachment name)
    alone = np.flatnonzero(hb.meshes_in(habits["habit_others"]) == 0)
    if args.habits != "none":
        data = habits
    if args.train_share < 1:
        data = {**data, "learn_from": tc.drawn_projects(data["group"], args.train_share)}
        drawn = data["learn_from"]
        print(f"learning from {len(np.unique(data['group'][drawn]))} of {len(np.unique(data['group']))} projects "
              f"({drawn.mean():.0%} of the meshes); every mesh judged held out\n")
    def log(line: str) -> None:
        print(line, file=sys.stderr, flush=True)

    before = tc.load_fold_models(args.fold_models) if args.reuse_folds and args.fold_models else None
    p, models = tc.held_out_probabilities(data, args.project_power, log=log, models=before)
    if before and all(m.sets is not None for m in before.values()):
        by_sets = tc.fold_sets(data, p, models)
    else:
        inner = tc.inner_probabilities(data, args.project_power, log=log)
        by_sets = tc.held_out_sets(data, p, models, inner, args.project_power, log=log)
    if args.habits != "none":
        for m in models.values():
            m.meta = {**m.meta, "habit_prior": data["habit_prior"].tolist()}
    if args.fold_models:
        tc.save_fold_models(models, args.fold_models)
    rows = [("rule", tc.judge(data, data["rule"].astype(bool)))]
    for t in sorted({0.3, 0.4, args.threshold, 0.6}):
        rows.append((f"per bone, threshold {t:.1f} (repository-held-out)", tc.judge(data, tc.choose_rows(data, p, t))))
    rows.append(("learned: per bone, then set level (repository-held-out)", tc.judge(data, by_sets)))
    table(rows)
    kinds = {"examples": np.char.startswith(data["group"].astype(str), "examples/")}
    kinds["corpus"] = ~kinds["examples"]
    kinds["no other weighted mesh in the project"] = np.isin(np.arange(meshes), alone)
    for kind, mask in kinds.items():
        ids = np.flatnonzero(mask)
        print(f"\n{kind}:")
        table([("rule", tc.judge(data, data["rule"].astype(bool), ids)),
               (f"per bone, threshold {args.threshold:.1f}", tc.judge(data, tc.choose_rows(data, p, args.threshold), ids)),
               ("learned: per bone, then set level", tc.judge(data, by_sets, ids))])
    if args.replay:
        sys.path.insert(0, str(REPO / "benchmarks"))
        import bench_weights_offline as offline

        cases = offline.replay_cases(args.replay, args.replay_cache, "4.2", 200, args.replay_every, None, 4,
                                     args.fold_models)
        names = ("keep", "rule", "learned", "upgrade")
        print(f"\nreplayed in the artists' animations, repository-held-out ({len(cases)} meshes):\n")
        print(offline.aggregates_table(cases, {n: offline.errors_of(cases, n) for n in names}))
    if args.write:
        model = tc.fit(data["X"], data["y"], tc.mesh_weights(data, args.project_power), args.threshold,
                       features=tc.feature_names(data))
        # the set stage learns from held-out per-bone probabilities, as the shipped model gives new projects
        model.sets = tc.fit_sets(data, tc.set_rows(data, p, np.arange(meshes), args.threshold), args.project_power)
        model.sets.meta = {**model.sets.meta, "trained_on": "the candidate sets of the same meshes, from held-out "
                           "per-bone probabilities", "objective": "lambdarank", "trees": tc.SET_TREES,
                           "leaves": tc.SET_LEAVES, "learning_rate": tc.SET_LEARNING_RATE}
        model.meta = {**model.meta, "trained_on": f"{meshes} artist-weighted meshes of {len(np.unique(data['group']))} projects",
                      "trees": tc.TREES, "leaves": tc.LEAVES, "learning_rate": tc.LEARNING_RATE,
                      "project_power": args.project_power, "reach": args.reach, "chain_reach": args.chain_reach,
                      "command": "scripts/train_bone_choice.py --write"
                      + (f" --habits {args.habits}" if args.habits != "none" else "")}
        if args.habits != "none":
            model.meta["habit_prior"] = data["habit_prior"].tolist()
        tc.write_model(MODEL_PATH, model)
        print(f"\nwrote {MODEL_PATH.relative_to(REPO)} ({MODEL_PATH.stat().st_size / 1024:.0f} KB, "
              f"{len(model.trees)} + {len(model.sets.trees)} trees, {len(model.features)} + {len(model.sets.features)} features)")


if __name__ == "__main__":
    main()
