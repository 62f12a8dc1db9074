"""Fitting the ``learned`` bone choice (:mod:`spinemesh.rig.learned`) to artists' bindings, and judging it.

The dataset: every artist-weighted mesh attachment of a set of projects (its artist's bones
all with an exact setup transform, its slot with a bone), each bone near its art a row of
:data:`spinemesh.rig.learned.FEATURES`, labelled by whether the artist bound it. Judged per mesh, on
repositories held out of the fit (:func:`with_folds`): the share of meshes whose chosen bone set is
exactly the artist's, and bones per mesh against the artists'.

Needs scikit-learn and LightGBM (the ``train`` extra); the package itself reads the fitted model without it.
Used by ``scripts/train_bone_choice.py`` and the weights benchmarks.
"""

from __future__ import annotations

import zlib
from collections import Counter
from itertools import pairwise
from pathlib import Path

import numpy as np

from ..errors import SpineMeshError
from ..files.atomic import atomic_write_stream, atomic_write_text
from ..files.strict_json import strict_json
from ..rig import bone_sets, habits
from ..rig.document import build_rig
from ..rig.habits import HABIT_FEATURES
from ..rig.learned import CHAIN_REACH, FEATURES, REACH, TreeEnsemble, weighted_meshes
from ..skeleton import load_skeleton

#: Repository-held-out folds (:func:`with_folds`).
FOLDS = 5

#: Boosting settings (kept small: the model ships in the package).
TREES, LEAVES, LEARNING_RATE, MIN_LEAF = 120, 15, 0.1, 40

#: The set model: LightGBM's LambdaRank, ``SET_TREES`` trees of at most ``SET_LEAVES`` leaves at
#: rate ``SET_LEARNING_RATE``, at least ``MIN_LEAF`` sets per leaf, each mesh's sets one query.
#: Measured held out on the same per-bone probabilities: exact bone sets 41.0% with
#: scikit-learn's classifier of 60 x 7 trees (margin 0.05 in probability), 42.0% with this
#: ranker (margin 0.1 in score; 60 x 7 at rate 0.1: 41.5%). Choosing ranker or classifier and
#: their settings by cross-validation inside each fold's training projects picked a ranker on
#: all 5 folds (41.6% on the held-out folds).
SET_TREES, SET_LEAVES, SET_LEARNING_RATE = 120, 7, 0.05


#: The repository every example project comes from (Esoteric Software's): one fold holds them all.
EXAMPLES_REPOSITORY = "EsotericSoftware/spine-runtimes"


def repository_of(group: str, corpus: Path | None) -> str:
    """The repository a project comes from: ``examples/NAME`` all from :data:`EXAMPLES_REPOSITORY`,
    ``corpus/NAME`` from the ``repo`` its ``.source.json`` names (under ``corpus``); a project
    that names none is a repository of its own.

    Characters of one game share a rig, bone names and an artist's habits, and a game's
    projects its repository: folds hold out whole repositories, so that a held-out figure is
    what a studio the fit never saw would get.
    """
    kind, _, name = group.partition("/")
    if kind == "examples":
        return EXAMPLES_REPOSITORY
    source = corpus / name / ".source.json" if corpus is not None and name else None
    if source is not None and source.is_file():
        import json

        repo = json.loads(source.read_text()).get("repo")
        if isinstance(repo, str) and repo:
            return repo
    return group


def with_folds(data: dict, corpus: Path | None, folds: int = FOLDS) -> dict:
    """``data`` with each mesh's ``repository`` (:func:`repository_of`) and held-out ``fold``
    (M,): scikit-learn's ``GroupKFold`` on the repositories (each fold about as many meshes,
    no repository in two folds)."""
    from sklearn.model_selection import GroupKFold

    repos = np.array([repository_of(str(g), corpus) for g in data["group"]])
    fold = np.zeros(len(repos), int)
    for k, (_, test) in enumerate(GroupKFold(folds).split(np.zeros(len(repos)), groups=repos)):
        fold[test] = k
    return {**data, "repository": repos, "fold": fold}


def model_for(models: dict[int, TreeEnsemble], repository: str) -> TreeEnsemble:
    """The fold model fitted without ``repository`` (each lists those it held out, meta
    ``held_out``); a repository none held out was in no fit: the first model."""
    for k in sorted(models):
        if repository in models[k].meta.get("held_out", ()):
            return models[k]
    return models[min(models)]


def training_skeletons(examples: Path | None, corpus: Path | None) -> list[tuple[str, Path]]:
    """``(project, skeleton)`` pairs: each example in its newest version, every corpus project.

    A project is ``examples/NAME`` or ``corpus/NAME`` (the benchmarks' labels). A ``.skel``
    beside a ``.json`` of the same name is the same skeleton and is left out.
    """
    roots: list[tuple[str, Path]] = []
    if examples is not None:
        newest: dict[str, Path] = {}
        for version in sorted((p for p in examples.iterdir() if p.is_dir()), key=lambda p: [int(x) for x in
                                                                                               p.name.split(".") if x.isdigit()]):
            for proj in version.iterdir():
                if proj.is_dir():
                    newest[proj.name] = proj
        roots += [(f"examples/{name}", p) for name, p in sorted(newest.items())]
    if corpus is not None:
        roots += [(f"corpus/{p.name}", p) for p in sorted(corpus.iterdir()) if p.is_dir()]
    out = []
    for group, proj in roots:
        files = sorted(proj.rglob("*.json")) + sorted(proj.rglob("*.skel"))
        jsons = {f.with_suffix("") for f in files if f.suffix == ".json"}
        out += [(group, f) for f in files if not (f.suffix == ".skel" and f.with_suffix("") in jsons)]
    return out


def mesh_rows(doc: dict, reach: float = REACH, chain_reach: float = CHAIN_REACH) -> list[dict]:
    """Every artist-weighted mesh of a skeleton document with its candidates and labels
    (:func:`spinemesh.rig.learned.weighted_meshes`)."""
    return weighted_meshes(doc, build_rig(doc), reach, chain_reach)


def build_dataset(pairs: list[tuple[str, Path]], cache: Path | None = None, log=print,
                  reach: float = REACH, chain_reach: float = CHAIN_REACH) -> dict[str, np.ndarray]:
    """The dataset of :func:`mesh_rows` over skeletons, as flat arrays; cached as ``.npz`` when ``cache``.

    ``reach``, ``chain_reach``: the candidates' reach (:func:`spinemesh.rig.learned.candidates`).

    Returns
    -------
    dict
        ``X`` (R, F) features, ``y`` (R,) labels, ``mesh`` (R,) mesh number, ``bone`` (R,) bone
        index, ``parent`` (R,) its parent bone (-1: the root), ``rule`` (R,) whether the rule takes it; per mesh: ``group`` (project),
        ``skeleton`` (file), ``attachment`` (``skin/slot/name``), ``artist_count`` (artist's bones),
        ``missed`` (artist's bones not among the candidates), ``rule_count``, ``rule_exact``.
    """
    if cache is not None and cache.exists():
        with np.load(cache, allow_pickle=False) as data:
            if "parent" in data.files:  # else written by an older version: built again
                return {k: data[k] for k in data.files}
    X, y, mesh, bone, parent, rule = [], [], [], [], [], []
    per_mesh: dict[str, list] = {k: [] for k in ("group", "skeleton", "attachment", "artist_count", "missed",
                                                 "rule_count", "rule_exact")}
    for n, (group, path) in enumerate(pairs):
        try:
            doc = load_skeleton(path)
        except SpineMeshError:
            continue
        if not isinstance(doc, dict) or not isinstance(doc.get("bones"), list):
            continue
        try:
            rows = mesh_rows(doc, reach, chain_reach)
        except (SpineMeshError, ValueError, np.linalg.LinAlgError) as e:
            log(f"{path}: left out: {e}")
            continue
        for r in rows:
            m = len(per_mesh["group"])
            X.append(r["features"])
            y.append(r["label"])
            mesh.append(np.full(len(r["bones"]), m))
            bone.append(np.asarray(r["bones"]))
            parent.append(np.asarray(r["parents"]))
            rule.append(np.array([b in r["rule"] for b in r["bones"]]))
            per_mesh["group"].append(group)
            per_mesh["skeleton"].append(str(path))
            per_mesh["attachment"].append(f"{r['skin']}/{r['slot']}/{r['name']}")
            per_mesh["artist_count"].append(len(r["artist"]))
            per_mesh["missed"].append(len(set(r["artist"]) - set(r["bones"])))
            per_mesh["rule_count"].append(len(r["rule"]))
            per_mesh["rule_exact"].append(set(r["rule"]) == set(r["artist"]))
        log(f"[{n + 1}/{len(pairs)}] {group} {path.name}: {len(rows)} weighted meshes")
    data = {"X": np.concatenate(X) if X else np.zeros((0, len(FEATURES))),
            "y": np.concatenate(y) if y else np.zeros(0, bool),
            "mesh": np.concatenate(mesh) if mesh else np.zeros(0, int),
            "bone": np.concatenate(bone) if bone else np.zeros(0, int),
            "parent": np.concatenate(parent) if parent else np.zeros(0, int),
            "rule": np.concatenate(rule) if rule else np.zeros(0, bool),
            **{k: np.asarray(v) for k, v in per_mesh.items()}}
    if cache is not None:  # whole or not at all: a run stopped while writing leaves no cache to misread
        atomic_write_stream(cache, lambda f: np.savez_compressed(f, **data))
    return data


def feature_names(data: dict) -> tuple[str, ...]:
    """The names of the columns of ``data["X"]``: :data:`spinemesh.rig.learned.FEATURES`, then
    :data:`spinemesh.rig.habits.HABIT_FEATURES` when :func:`with_habits` added them."""
    return FEATURES + (HABIT_FEATURES if data["X"].shape[1] > len(FEATURES) else ())


def mesh_keys(data: dict) -> list[set[str]]:
    """Each mesh's names (its slot's and its attachment's), for :func:`spinemesh.rig.habits.others_of`."""
    return [habits.keys_of(*str(a).split("/", 2)[1:]) for a in data["attachment"]]


def with_habits(data: dict, strict: bool = True, alone: bool = False) -> dict:
    """``data`` with the :data:`spinemesh.rig.habits.HABIT_FEATURES` of each row appended to ``X``, from the
    other artist-weighted meshes of its mesh's project (``strict``: also without those of the
    same slot or attachment name), and ``habit_prior`` (the rates over every mesh) and
    ``habit_others`` (each mesh's others' tally, (M, TALLY_SIZE)) and ``habit_neighbours``
    (:func:`neighbour_sets`, a list) added. ``alone``: as a project with no other weighted mesh
    shows each mesh (the prior alone, no neighbours' sets)."""
    starts = _mesh_rows(data)
    tallies = np.stack([habits.tally(data["X"][s:e], data["y"][s:e], n, FEATURES)
                        for s, e, n in zip(starts[:-1], starts[1:], data["artist_count"])])
    if alone:
        others, neighbours = np.zeros_like(tallies), [{} for _ in data["group"]]
    else:
        others = habits.others_of(tallies, data["group"], mesh_keys(data) if strict else None)
        neighbours = neighbour_sets(data, strict)
    base = habits.prior(tallies)
    H = np.concatenate([habits.habit_features(data["X"][s:e], FEATURES, others[m], base)
                        for m, (s, e) in enumerate(pairwise(starts))])
    return {**data, "X": np.hstack([data["X"], H]), "habit_prior": base, "habit_others": others,
            "habit_neighbours": neighbours}


def neighbour_sets(data: dict, strict: bool = True) -> list[dict[tuple[int, ...], int]]:
    """For each mesh, the bone sets (bone indices, sorted) the artists bound on the other meshes
    of its skeleton on the same slot bone, each with how many bound it
    (:meth:`spinemesh.rig.habits.ProjectHabits.neighbours`; ``strict``: leaving out those sharing a slot or
    attachment name with it, else only itself), and on its mirror images
    (:func:`spinemesh.rig.habits.mirror_counts`). Meshes with artist's bones beyond their candidates show no
    set. A skeleton is its file here (the package matches skeletons by
    their bones' names, :func:`spinemesh.rig.habits.rig_key`)."""
    starts = _mesh_rows(data)
    col = FEATURES.index("is_slot_bone")
    bound, keys = [], mesh_keys(data) if strict else [set() for _ in data["group"]]
    keys = [k | {f"#{m}"} for m, k in enumerate(keys)]
    for m, (s, e) in enumerate(pairwise(starts)):
        slot = data["bone"][s:e][data["X"][s:e, col] == 1]
        chosen = frozenset(data["bone"][s:e][data["y"][s:e]].tolist()) if data["missed"][m] == 0 else frozenset()
        bound.append((str(data["skeleton"][m]), int(slot[0]) if len(slot) else -1, chosen))
    by_pool: dict[tuple, list[int]] = {}
    for m, (rig, slot, _) in enumerate(bound):
        by_pool.setdefault((rig, slot), []).append(m)
    trees = skeleton_trees(sorted({rig for rig, _, _ in bound}))
    out = []
    for m, (rig, slot, _) in enumerate(bound):
        def bound_on(bone: int) -> dict[tuple[int, ...], int]:
            pool = by_pool.get((rig, bone), [])
            counts = habits.neighbour_counts([bound[q] for q in pool], [keys[q] for q in pool], keys[m], rig, bone)
            return {tuple(sorted(c)): n for c, n in counts.items()}

        names, parents = trees[rig]
        mirrored = habits.mirror_counts(parents, names, slot, bound_on) if slot >= 0 else {}
        out.append(dict(Counter(bound_on(slot)) + mirrored))
    return out


def skeleton_trees(paths: list[str]) -> dict[str, tuple[list[str], list[int]]]:
    """Each skeleton file's bone names and parents (-1: none), in the order of its bones, for
    :func:`spinemesh.rig.habits.mirror_counts` (the dataset holds only its meshes' candidates)."""
    out = {}
    for path in paths:
        bones = load_skeleton(Path(path))["bones"]
        at = {b["name"]: i for i, b in enumerate(bones)}
        out[path] = ([b["name"] for b in bones], [at.get(b.get("parent"), -1) for b in bones])
    return out


def drawn_projects(groups: np.ndarray, share: float) -> np.ndarray:
    """Which meshes (their projects ``groups``, (M,)) belong to a ``share`` of the projects,
    drawn by each project's name (stable across runs, and a larger share holds a smaller's):
    the models learn from these alone for a learning curve (``learn_from``, :func:`project_weights`).

    Examples
    --------
    >>> groups = np.array([f"corpus/p{i}" for i in range(100)])
    >>> int(drawn_projects(groups, 0.5).sum()), bool((drawn_projects(groups, 0.25) <= drawn_projects(groups, 0.5)).all())
    (53, True)
    """
    draw = np.array([zlib.crc32(f"draw/{g}".encode()) % 1000 / 1000 for g in np.asarray(groups).astype(str)])
    return draw < share


def project_weights(data: dict, project_power: float = 0.5) -> np.ndarray:
    """Each mesh's weight (M,): a project of M meshes weighs ``M ** project_power`` in all (0:
    every project alike, 1: every mesh alike); 0 for the meshes outside ``data["learn_from"]``
    when the dataset names some (:func:`drawn_projects`)."""
    _, project = np.unique(data["group"], return_inverse=True)
    w = np.bincount(project)[project] ** (project_power - 1.0)
    return w * data["learn_from"] if "learn_from" in data else w


def mesh_weights(data: dict, project_power: float = 0.5) -> np.ndarray:
    """Row weights: each mesh weighs the same over its candidates; big projects weigh less per
    mesh (:func:`project_weights`)."""
    mesh = data["mesh"]
    w = project_weights(data, project_power)[mesh] / np.bincount(mesh)[mesh]
    return w / w.mean()


def fit(X: np.ndarray, y: np.ndarray, w: np.ndarray | None = None, threshold: float = 0.5,
        seed: int = 0, features: tuple[str, ...] = FEATURES, trees: int = TREES, leaves: int = LEAVES) -> TreeEnsemble:
    """A gradient-boosted tree ensemble (scikit-learn's ``HistGradientBoostingClassifier``) of
    ``trees`` trees of at most ``leaves`` leaves as a :class:`spinemesh.rig.learned.TreeEnsemble` reading
    columns ``features``."""
    from sklearn.ensemble import HistGradientBoostingClassifier

    clf = HistGradientBoostingClassifier(max_iter=trees, max_leaf_nodes=leaves, learning_rate=LEARNING_RATE,
                                         min_samples_leaf=MIN_LEAF, early_stopping=False, random_state=seed)
    clf.fit(X, y.astype(int), sample_weight=w)
    exported = []
    for (predictor,) in clf._predictors:
        nodes = predictor.nodes
        leaf = nodes["is_leaf"].astype(bool)
        exported.append({"feature": np.where(leaf, -1, nodes["feature_idx"]).astype(np.int64),
                      "threshold": np.where(leaf, 0.0, nodes["num_threshold"]).astype(float),
                      "left": np.where(leaf, 0, nodes["left"]).astype(np.int64),
                      "right": np.where(leaf, 0, nodes["right"]).astype(np.int64),
                      "value": np.where(leaf, nodes["value"], 0.0).astype(float)})
    return _checked(TreeEnsemble(features, float(np.ravel(clf._baseline_prediction)[0]), exported, threshold, {}),
                    X, clf.decision_function, "scikit-learn")


def _checked(model: TreeEnsemble, X: np.ndarray, library_raw, library: str) -> TreeEnsemble:
    """``model`` (trees exported from ``library``), checked to give the library's own raw scores
    (``library_raw``) on up to 2,000 rows of ``X``, with 24 of them kept in its ``meta`` for the
    package's tests to check the numpy evaluation."""
    check = X[np.linspace(0, len(X) - 1, min(len(X), 2000)).astype(int)]
    expected = library_raw(check)
    few = np.linspace(0, len(check) - 1, min(len(check), 24)).astype(int)
    model.meta = {**model.meta, "check": {"x": check[few].tolist(), "raw": expected[few].tolist()}}
    if not np.allclose(model.raw(check), expected, atol=1e-6):
        raise RuntimeError(f"the exported trees do not reproduce {library}'s predictions")
    return model


def fit_ranker(X: np.ndarray, relevant: np.ndarray, queries: np.ndarray, w: np.ndarray | None = None,
               margin: float = 0.0, seed: int = 0, features: tuple[str, ...] = FEATURES, trees: int = SET_TREES,
               leaves: int = SET_LEAVES, rate: float = SET_LEARNING_RATE) -> TreeEnsemble:
    """A LambdaRank tree ensemble (LightGBM's ``LGBMRanker``, MIT) ranking the rows of each
    query, as a :class:`spinemesh.rig.learned.TreeEnsemble` reading columns ``features``; its ``raw`` is the
    ranking score.

    ``relevant`` (R,): the rows to rank first; ``queries`` (R,): each row's query, rows of a
    query together; ``w`` (R,): each row's weight, alike within a query (LightGBM weighs a
    query by it); ``margin``: the model's threshold (:func:`spinemesh.rig.bone_sets.pick`).
    """
    import lightgbm

    starts, ends = _runs(queries)
    ranker = lightgbm.LGBMRanker(objective="lambdarank", n_estimators=trees, num_leaves=leaves,
                                 learning_rate=rate, min_child_samples=MIN_LEAF, lambdarank_truncation_level=3,
                                 random_state=seed, n_jobs=1, verbose=-1)
    ranker.fit(X, relevant.astype(int), group=ends - starts, sample_weight=w)
    exported = [_flat_tree(t["tree_structure"]) for t in ranker.booster_.dump_model()["tree_info"]]
    return _checked(TreeEnsemble(features, 0.0, exported, margin, {}), X, ranker.predict, "LightGBM")


def _flat_tree(root: dict) -> dict[str, np.ndarray]:
    """A LightGBM tree (``dump_model``'s nested nodes) as :class:`spinemesh.rig.learned.TreeEnsemble` arrays,
    each node ahead of its children. Its splits send a value at most the threshold left, as
    the ensemble does; the features hold no missing values."""
    nodes: list[list] = []

    def visit(node: dict) -> int:
        at = len(nodes)
        if "leaf_value" in node:
            nodes.append([-1, 0.0, 0, 0, float(node["leaf_value"])])
            return at
        if node.get("decision_type") != "<=":
            raise RuntimeError(f"unexpected LightGBM split {node.get('decision_type')!r}")
        nodes.append([int(node["split_feature"]), float(node["threshold"]), 0, 0, 0.0])
        nodes[at][2] = visit(node["left_child"])
        nodes[at][3] = visit(node["right_child"])
        return at

    visit(root)
    cols = list(zip(*nodes))
    return {"feature": np.asarray(cols[0], np.int64), "threshold": np.asarray(cols[1], float),
            "left": np.asarray(cols[2], np.int64), "right": np.asarray(cols[3], np.int64),
            "value": np.asarray(cols[4], float)}


def _runs(ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start and end (exclusive) of each run of equal values in ``ids`` (the rows of one mesh, or
    of one query, lie together)."""
    starts = np.flatnonzero(np.r_[True, np.diff(ids) != 0])
    return starts, np.r_[starts[1:], len(ids)]


def choose_rows(data: dict, p: np.ndarray, threshold: float, most: int = 8) -> np.ndarray:
    """Which rows are chosen per mesh: probability at least ``threshold`` (at most ``most`` per
    mesh, the likeliest), else the slot's bone (else the likeliest row); bones not exact /
    inactive never (as :func:`spinemesh.rig.learned.choose_learned`)."""
    col = {f: i for i, f in enumerate(FEATURES)}
    allowed = (data["X"][:, col["not_exact"]] == 0) & (data["X"][:, col["skin_inactive"]] == 0)
    slot = data["X"][:, col["is_slot_bone"]] == 1
    chosen = np.zeros(len(p), bool)
    order = np.lexsort((-p, data["mesh"]))
    for s, e in zip(*_runs(data["mesh"][order])):
        rows = [r for r in order[s:e] if allowed[r]]
        take = [r for r in rows if p[r] >= threshold][:most] or [r for r in rows if slot[r]] or rows[:1]
        chosen[take] = True
    return chosen


def judge(data: dict, chosen: np.ndarray, meshes: np.ndarray | None = None) -> dict:
    """Per-mesh figures of a choice (rows ``chosen``): exact-set share, bones per mesh against artists'."""
    n = len(data["group"])
    meshes = np.arange(n) if meshes is None else meshes
    wrong = np.bincount(data["mesh"], weights=(chosen != data["y"]).astype(float), minlength=n)
    count = np.bincount(data["mesh"], weights=chosen.astype(float), minlength=n)
    exact = (wrong == 0) & (data["missed"] == 0)
    artists = data["artist_count"]
    return {"meshes": len(meshes), "projects": len(np.unique(data["group"][meshes])),
            "exact": float(exact[meshes].mean()), "bones_median": float(np.median(count[meshes])),
            "bones_p95": float(np.percentile(count[meshes], 95)), "artist_median": float(np.median(artists[meshes])),
            "artist_p95": float(np.percentile(artists[meshes], 95)), "too_many": float((count > artists)[meshes].mean()),
            "too_few": float((count < artists)[meshes].mean())}


def write_model(path: str | Path, model: TreeEnsemble) -> None:
    """Write ``model`` as the compact strict JSON its readers take, atomically.

    Raises
    ------
    SpineMeshError
        When it holds a NaN or an infinite number (a fit gone wrong), naming ``path``; nothing is
        written then.
    """
    atomic_write_text(path, strict_json(model.to_json(), None, path, compact=True) + "\n")


def save_fold_models(models: dict[int, TreeEnsemble], folder: Path) -> None:
    """Write each fold's model as ``fold-K.json`` (the benchmarks read them back)."""
    for k, m in models.items():
        write_model(folder / f"fold-{k}.json", m)


def load_fold_models(folder: Path, folds: int = FOLDS) -> dict[int, TreeEnsemble]:
    """The fold models :func:`save_fold_models` wrote; raises SystemExit naming what is missing."""
    import json

    missing = [k for k in range(folds) if not (folder / f"fold-{k}.json").is_file()]
    if missing:
        raise SystemExit(f"{folder}: no fold models {missing}; write them with "
                         f"scripts/train_bone_choice.py --fold-models {folder}")
    return {k: TreeEnsemble.from_json(json.loads((folder / f"fold-{k}.json").read_text())) for k in range(folds)}


def held_out_probabilities(data: dict, project_power: float = 0.5, folds: int = FOLDS, log=print,
                           models: dict[int, TreeEnsemble] | None = None) -> tuple[np.ndarray, dict[int, TreeEnsemble]]:
    """Each row's probability from the model fitted without its repository's fold
    (:func:`with_folds`), and the fold models, each naming the repositories it held out (meta
    ``held_out``; ``models``: fold models fitted before, on the same dataset, reused)."""
    fold = _fold_of_rows(data)
    w = mesh_weights(data, project_power)
    p = np.zeros(len(data["y"]))
    models = dict(models or {})
    for k in range(folds):
        train, test = fold != k, fold == k
        given = k in models
        if not given:
            models[k] = fit(data["X"][train], data["y"][train], w[train], features=feature_names(data))
            models[k].meta = {**models[k].meta,
                              "held_out": sorted(set(data["repository"][data["fold"] == k].tolist()))}
        p[test] = models[k].probability(data["X"][test])
        log(f"fold {k}: model {'given' if given else 'fitted'} on {int(train.sum())} rows, "
            f"{int(test.sum())} judged")
    return p, models


def _fold_of_rows(data: dict) -> np.ndarray:
    """Each row's held-out fold (its mesh's repository's, :func:`with_folds`)."""
    return data["fold"][data["mesh"]]


def inner_probabilities(data: dict, project_power: float = 0.5, folds: int = FOLDS, log=print) -> np.ndarray:
    """For each held-out fold ``k``, every other row's probability from a per-bone model fitted
    without fold ``k`` and without the row's own fold (NaN on fold ``k``), shape (folds, R).

    The set model judged on fold ``k`` learns from these: probabilities the per-bone model
    gives meshes it was not fitted on, as it will on fold ``k``.
    """
    fold = _fold_of_rows(data)
    w = mesh_weights(data, project_power)
    out = np.full((folds, len(data["y"])), np.nan)
    for k in range(folds):
        for j in range(folds):
            if j != k:
                train, test = (fold != k) & (fold != j), fold == j
                out[k, test] = fit(data["X"][train], data["y"][train], w[train],
                                   features=feature_names(data)).probability(data["X"][test])
        log(f"fold {k}: per-bone probabilities of the other folds, each from a model without it")
    return out


def _mesh_rows(data: dict) -> np.ndarray:
    """Row where each mesh's candidates start (rows are grouped by mesh, in order), and the end."""
    starts = np.searchsorted(data["mesh"], np.arange(len(data["group"]) + 1))
    if (np.diff(data["mesh"]) < 0).any():
        raise ValueError("the dataset's rows are not grouped by mesh")
    return starts


def set_rows(data: dict, p: np.ndarray, meshes: np.ndarray, threshold: float = 0.5) -> dict:
    """The candidate sets (:func:`spinemesh.rig.bone_sets.candidate_sets`) of ``meshes`` from per-bone
    probabilities ``p`` (R,): ``Z`` (S, len(SET_FEATURES), with the :data:`spinemesh.rig.bone_sets.SET_HABIT_FEATURES`
    when ``data`` holds the habits, :func:`with_habits`), ``mesh`` (S,), ``exact`` (S,)
    whether the set is the artist's whole set, ``agreed`` (S,) whether the set is the one the
    meshes on the same slot bone agree on (:func:`spinemesh.rig.bone_sets.agreed_set`; with the habits),
    ``members`` (rows of ``data``, per set)."""
    col = {f: i for i, f in enumerate(FEATURES)}
    starts = _mesh_rows(data)
    with_set_habits = "habit_neighbours" in data and feature_names(data) != FEATURES
    Z, owner, exact, agreed, members = [], [], [], [], []
    for m in meshes:
        s, e = starts[m], starts[m + 1]
        f, pm = data["X"][s:e], p[s:e]
        allowed = (f[:, col["not_exact"]] == 0) & (f[:, col["skin_inactive"]] == 0)
        slot = next((int(k) for k in np.flatnonzero(f[:, col["is_slot_bone"]] == 1) if allowed[k]), None)
        ancestors, parents_at = bone_sets.mesh_inputs(data["bone"][s:e], data["parent"][s:e])
        known, mesh_habits, at = {}, None, {int(b): k for k, b in enumerate(data["bone"][s:e])}
        if with_set_habits:
            known = {tuple(sorted(at[b] for b in chosen)): n for chosen, n in data["habit_neighbours"][m].items()
                     if all(b in at for b in chosen)}
            mesh_habits = (habits.pattern_shares(data["habit_others"][m], data["habit_prior"]), known)
        sets = bone_sets.candidate_sets(pm, allowed, slot, ancestors, parents_at, threshold, f[:, col["rule_chose"]] == 1,
                                        known=known)
        if not sets:
            continue
        taken = bone_sets.agreed_set(sets, data["habit_neighbours"][m], at) if with_set_habits else None
        agreed += [k == taken for k in range(len(sets))]
        Z.append(bone_sets.set_features(sets, pm, allowed, f, FEATURES, slot, ancestors, parents_at, threshold,
                                        mesh_habits))
        truth = tuple(np.flatnonzero(data["y"][s:e]).tolist()) if data["missed"][m] == 0 else None
        for chosen, _ in sets:
            owner.append(m)
            exact.append(chosen == truth)
            members.append(s + np.asarray(chosen, int))
    width = len(bone_sets.SET_FEATURES) + (len(bone_sets.SET_HABIT_FEATURES) if with_set_habits else 0)
    return {"Z": np.concatenate(Z) if Z else np.zeros((0, width)),
            "mesh": np.asarray(owner, int), "exact": np.asarray(exact, bool), "agreed": np.asarray(agreed, bool),
            "members": members}


def fit_sets(data: dict, sets: dict, project_power: float = 0.5) -> TreeEnsemble:
    """The set model (:func:`fit_ranker`): ranks each mesh's sets (:func:`set_rows`), the
    artist's first. Fitted on the meshes whose artist's set is among the sets weighed (on the
    others no set is exact: they would only teach that the sets weighed are all wrong); a
    project of M meshes weighs ``M ** project_power``, each mesh alike (:func:`project_weights`)."""
    mesh_weight = project_weights(data, project_power)
    weighed = np.zeros(len(data["group"]), bool)
    weighed[sets["mesh"][sets["exact"]]] = True
    keep = weighed[sets["mesh"]]
    names = bone_sets.SET_FEATURES
    if sets["Z"].shape[1] > len(names):
        names += bone_sets.SET_HABIT_FEATURES
    kept = sets["mesh"][keep]
    w = mesh_weight[kept] / mesh_weight[np.unique(kept)].mean()  # the meshes fitted on weigh 1 on average
    return fit_ranker(sets["Z"][keep], sets["exact"][keep], kept, w, bone_sets.SET_MARGIN, features=names)


def choose_sets(data: dict, sets: dict, model: TreeEnsemble) -> np.ndarray:
    """Rows chosen when each mesh of ``sets`` takes the set its neighbours agree on, else the
    set ``model`` picks (:func:`spinemesh.rig.bone_sets.pick`, the model's threshold the margin; as
    :func:`spinemesh.rig.learned.choose_learned` with a set stage)."""
    score = model.raw(sets["Z"])
    chosen = np.zeros(len(data["y"]), bool)
    for s, e in zip(*_runs(sets["mesh"])):
        agreed = np.flatnonzero(sets["agreed"][s:e])
        best = int(agreed[0]) if len(agreed) else bone_sets.pick(score[s:e], model.threshold)
        chosen[sets["members"][s + best]] = True
    return chosen


def fold_sets(data: dict, p: np.ndarray, models: dict[int, TreeEnsemble], folds: int = FOLDS) -> np.ndarray:
    """Rows chosen by fitted fold models with set stages (:func:`load_fold_models`): each fold's
    meshes take their sets from ``p`` (held-out per-bone probabilities) through that fold's set model."""
    mesh_fold = data["fold"]
    chosen = np.zeros(len(p), bool)
    for k, m in models.items():
        chosen |= choose_sets(data, set_rows(data, p, np.flatnonzero(mesh_fold == k), m.threshold), m.sets)
    return chosen


def held_out_sets(data: dict, p: np.ndarray, models: dict[int, TreeEnsemble], inner: np.ndarray,
                  project_power: float = 0.5, folds: int = FOLDS, log=print) -> np.ndarray:
    """Rows chosen with a set stage, repository-held-out: fold ``k``'s set model is fitted on the
    other folds' sets from ``inner[k]`` (:func:`inner_probabilities`) and attached to
    ``models[k]``; fold ``k``'s meshes take their sets from ``p`` (held-out per-bone probabilities)."""
    mesh_fold = data["fold"]
    chosen = np.zeros(len(data["y"]), bool)
    for k in range(folds):
        train = set_rows(data, inner[k], np.flatnonzero(mesh_fold != k), models[k].threshold)
        test = set_rows(data, p, np.flatnonzero(mesh_fold == k), models[k].threshold)
        models[k].sets = fit_sets(data, train, project_power)
        chosen |= choose_sets(data, test, models[k].sets)
        log(f"fold {k}: set model fitted on {len(train['mesh'])} sets, {len(test['mesh'])} judged; the artist's "
            f"set among them on {len(np.unique(test['mesh'][test['exact']]))} of {int((mesh_fold == k).sum())} meshes; "
            f"taken as agreed on {int(test['agreed'].sum())}, the artist's on {int((test['agreed'] & test['exact']).sum())}")
    return chosen
