"""Where the learned bone choice misses the artists' exact bone sets, repository-held-out.

Each artist-weighted mesh of the training dataset (``--cache``) is bound by the fold models
fitted without its repository (``--fold-models``, ``scripts/train_bone_choice.py --habits strict``),
with and without the project's habits, as :mod:`bench_unweighted_bones` binds them; each mesh
whose chosen set is not the artist's is counted under the first of:

- *an artist's bone beyond the candidates*: the artist bound a bone farther from the art than
  any candidate (:data:`spinemesh.rig.learned.REACH`), which no choice among the candidates binds;
- *the artist binds more than 8 bones*: more than any automatic choice takes
  (:data:`spinemesh.rig.choice.MAX_AUTO_BONES`);
- *artist's bones left out only*, *bones the artist did not bind only*, or *both*.

For the meshes missing bones the artist bound, the share of the mesh's weight those bones carry
in the artist's own weights (the sum over its vertices of their weights, over the mesh's whole
weight): a set that misses only bones of little weight matters little in a game.

Usage::

    .venv/bin/python benchmarks/bench_bone_set_errors.py --cache bone-choice.npz --fold-models bone-choice-folds
"""

from __future__ import annotations

import sys
from collections import Counter, defaultdict
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "benchmarks"))

from bench_unweighted_bones import dataset_and_models, dataset_arguments  # noqa: E402

from spinemesh.errors import SpineMeshError  # noqa: E402
from spinemesh.train import bone_choice as tc  # noqa: E402
from spinemesh.rig.binding import parse_vertices  # noqa: E402
from spinemesh.rig.choice import MAX_AUTO_BONES  # noqa: E402
from spinemesh.skeleton import iter_attachments, load_skeleton  # noqa: E402


KINDS = ("exact", "an artist's bone beyond the candidates", f"the artist binds more than {MAX_AUTO_BONES} bones",
         "artist's bones left out only", "bones the artist did not bind only", "both")


def weight_shares(data: dict) -> dict[int, dict[int, float]]:
    """Per mesh of the dataset: each bone the artist bound, with its share of the mesh's weight."""
    by_skeleton: dict[str, dict[str, int]] = defaultdict(dict)
    for m, (skeleton, attachment) in enumerate(zip(data["skeleton"], data["attachment"])):
        by_skeleton[str(skeleton)][str(attachment)] = m
    out = {}
    for skeleton, meshes in by_skeleton.items():
        try:
            doc = load_skeleton(Path(skeleton))
        except SpineMeshError:
            continue
        bone_count = len(doc.get("bones", []))
        for ref in iter_attachments(doc):
            m = meshes.get(f"{ref.skin}/{ref.slot}/{ref.name}")
            if m is None:
                continue
            total: Counter = Counter()
            for influences in parse_vertices(ref.attachment, bone_count).influences:
                for bone, _, _, weight in influences:
                    total[bone] += weight
            whole = sum(total.values()) or 1.0
            out[m] = {b: w / whole for b, w in total.items()}
    return out


def held_out_choices(data: dict, models: dict) -> dict[str, np.ndarray]:
    """The learned choice of every candidate row, held out, without and with the project's habits."""
    out = {}
    for label, d in (("without habits", tc.with_habits(data, alone=True)), ("with habits", tc.with_habits(data))):
        p, _ = tc.held_out_probabilities(d, 0.5, log=lambda s: None, models=models)
        out[label] = tc.fold_sets(d, p, models)
    return out


def kind_of(chosen: set[int], artist: set[int], beyond: bool) -> str:
    if chosen == artist:
        return KINDS[0]
    if beyond:
        return KINDS[1]
    if len(artist) > MAX_AUTO_BONES:
        return KINDS[2]
    missing, extra = artist - chosen, chosen - artist
    return KINDS[5] if missing and extra else KINDS[3] if missing else KINDS[4]


def main() -> None:
    _, data, models = dataset_and_models(dataset_arguments(__doc__.split("\n\n")[0]).parse_args())
    shares = weight_shares(data)
    starts = tc._mesh_rows(data)
    meshes = len(data["group"])
    counts, missed = {}, {}
    for label, chosen in held_out_choices(data, models).items():
        counts[label], missed[label] = Counter(), []
        for m in range(meshes):
            rows = slice(starts[m], starts[m + 1])
            bones = data["bone"][rows]
            artist = shares.get(m, {})
            kind = kind_of(set(bones[chosen[rows]].tolist()), set(artist), data["missed"][m] > 0)
            counts[label][kind] += 1
            if kind in KINDS[3:]:
                missing = set(artist) - set(bones[chosen[rows]].tolist())
                if missing:
                    missed[label].append(sum(artist[b] for b in missing))
    labels = list(counts)
    print(f"artist-weighted meshes: {meshes} ({len(shares)} with their weights read)\n")
    print("| chosen set | " + " | ".join(labels) + " |")
    print("|---|" + "--:|" * len(labels))
    for kind in KINDS:
        print(f"| {kind} | " + " | ".join(f"{counts[x][kind]:,} ({counts[x][kind] / meshes:.1%})" for x in labels) + " |")
    reachable = meshes - counts[labels[0]][KINDS[1]] - counts[labels[0]][KINDS[2]]
    print(f"| exact, of the {reachable:,} meshes a choice among the candidates can match | "
          + " | ".join(f"{counts[x][KINDS[0]] / reachable:.1%}" for x in labels) + " |")
    print("\nartist's weight carried by the bones left out, where some are (reachable meshes):\n")
    print("| | " + " | ".join(labels) + " |")
    print("|---|" + "--:|" * len(labels))
    print("| meshes | " + " | ".join(f"{len(missed[x]):,}" for x in labels) + " |")
    for q in (25, 50, 75):
        print(f"| p{q} | " + " | ".join(f"{np.percentile(missed[x], q):.0%}" for x in labels) + " |")
    print("| under 5% of the weight | " + " | ".join(f"{np.mean(np.array(missed[x]) < 0.05):.1%}" for x in labels) + " |")


if __name__ == "__main__":
    main()
