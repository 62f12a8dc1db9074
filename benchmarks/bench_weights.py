"""Rig replay: our automatic weights against the artists', played in the official runtime.

    .venv/bin/python benchmarks/bench_weights.py [--examples 4.2] [--corpus N] [--method bbw]
        [--anims N] [--times 4] [--tool DIR] [--every K] [--start S] [--json OUT]
    .venv/bin/python benchmarks/bench_weights.py --merge OUT1 OUT2 ...

For every artist-weighted mesh attachment not keyed by deform timelines, the weights are
recomputed with ``--replace --bones keep`` (the artist's vertices and bones), with
``--replace --bones rule`` and with ``--replace --bones learned``; the learned choice of each
project is made by the model fitted without that project's fold
(``--fold-models``, written by ``scripts/train_bone_choice.py --fold-models``), so every
figure is repository-held-out; a model that reads the project's habits gets them from the
artist-weighted meshes of all the project's replayed skeletons, as ``spinemesh weights`` reads
them from a project folder. The artist's animations are played in the official runtime
(``../shared/tools/spine-runtime``, ``dump.mjs``: every animation of each skeleton, or its first
``--anims``, ``--times`` evenly spaced samples of each) and every vertex's world position is
compared with the artist's version. Per attachment: the mean distance in world units (pixels at
scale 1) over its vertices and sampled frames. Two baselines are played too: every vertex
following its heaviest artist bone rigidly (the artist's rig without blending), and the whole
mesh following its slot's bone (what a user gets without ``--weights auto``), both in the same
setup pose. Keep, rule and learned are then judged on the same meshes against each baseline with
the aggregates ``bench_weights_offline.py`` prints (:func:`aggregates_table`: median and
geometric mean of the ratios, sum of errors over the baseline's, share of meshes better).
Printed per project and overall: the median error, the
median ratio to the baseline (attachments whose baseline is within ``RIGID_FLOOR`` are left out of the
ratio), for keep, rule and learned, the share of meshes whose chosen bones are exactly the
artist's (and the share whose written bones are those ``keep`` writes: a bone the weights leave
at 0 everywhere is not written) and the bones chosen per mesh (95th percentile) against the
artists', and the share of triangles that flip (signed area changes sign
against the setup pose) in the sampled frames, ours and the artists'. Setup-pose drift
(largest vertex distance in the setup pose, ours against the artists') is printed too, and how
much the overall ratios hang on single projects: the median over projects of their median
ratios, the ratios without the project of most meshes, and the 5th-95th percentile of the median
ratio over draws of the projects with replacement. ``--every K --start S`` replays every K-th
skeleton from the S-th; ``--merge`` judges the ``--json`` files of such runs together (the K
runs, one per start: every skeleton).

Needs Node and ``npm ci`` in the tool folder (``--tool`` names an installed copy).
"""

from __future__ import annotations

import argparse
import copy
import json
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
SHARED = REPO.parent / "shared"

from spinemesh.errors import SpineMeshError  # noqa: E402
from spinemesh.project import find_project, image_source_for  # noqa: E402
from spinemesh.rig.binding import bind, parse_vertices, setup_world  # noqa: E402
from spinemesh.anim.bone_worlds import sampled_bone_worlds  # noqa: E402
from spinemesh.rig.document import WeightOptions, build_rig, weight_document  # noqa: E402
from spinemesh.skeleton import dumps_skeleton, iter_attachments, load_skeleton, spine_version  # noqa: E402

RUNTIME_VERSIONS = ("3.8", "4.0", "4.1", "4.2")

#: Attachments whose rigid baseline is off by less than this (world units) move rigidly in the
#: sampled frames: any weights do; they are left out of the ratios (not of the errors).
RIGID_FLOOR = 0.05


def skeletons(examples: str | None, corpus: int) -> list[tuple[str, Path]]:
    """``(project label, skeleton)`` pairs: one skeleton per example/corpus project, JSON first."""
    out = []
    roots = []
    if examples:
        roots += [("examples", p) for p in sorted((SHARED / "spine-examples" / examples).iterdir()) if p.is_dir()]
    if corpus:
        corp = [p for p in sorted((SHARED / "spine-corpus").iterdir()) if p.is_dir()]
        roots += [("corpus", p) for p in corp[:corpus]]
    for kind, proj in roots:
        files = sorted(proj.rglob("*.json")) + sorted(proj.rglob("*.skel"))
        names = {f.with_suffix("") for f in files if f.suffix == ".json"}
        for f in files:
            if f.suffix == ".skel" and f.with_suffix("") in names:
                continue  # its JSON twin is replayed
            try:
                doc = load_skeleton(f)
            except SpineMeshError:  # a file the readers refuse: the replay moves on
                continue
            if spine_version(doc)[:3] in RUNTIME_VERSIONS:
                out.append((f"{kind}/{proj.name}", f))
    return out


def anim_length(node) -> float:
    """Largest key ``time`` anywhere in an animation (its duration)."""
    if isinstance(node, dict):
        t = float(node["time"]) if isinstance(node.get("time"), (int, float)) else 0.0
        return max([t] + [anim_length(v) for v in node.values()])
    if isinstance(node, list):
        return max([0.0] + [anim_length(v) for v in node])
    return 0.0


def poses(doc: dict, anims: int | None, times: int) -> list[str]:
    """``times`` evenly spaced frames (``name@seconds``) of each of the first ``anims``
    animations of ``doc`` (None: all of them) that last longer than an instant."""
    out = []
    for name, anim in list((doc.get("animations") or {}).items())[:anims]:
        length = anim_length(anim)
        if length <= 0:
            continue
        out += [f"{name}@{length * (i + 1) / (times + 1):.4f}" for i in range(times)]
    return out


def rigid_baseline(doc: dict, rig, places: set) -> None:
    """Every chosen mesh's vertices bound rigidly to their heaviest artist bone, setup unchanged."""
    for ref in iter_attachments(doc):
        if (ref.skin, ref.slot, ref.name) not in places:
            continue
        mesh = parse_vertices(ref.attachment, len(rig.bones))
        world = setup_world(mesh, rig.worlds, rig.slot_bone[ref.slot])
        heaviest = [max(inf, key=lambda e: e[3])[0] for inf in mesh.influences]
        ids = sorted(set(heaviest))
        w = np.zeros((mesh.count, len(ids)))
        w[np.arange(mesh.count), [ids.index(b) for b in heaviest]] = 1.0
        ref.attachment["vertices"] = bind(world, w, ids, rig.worlds)


def slot_baseline(doc: dict, rig, places: set) -> None:
    """Every chosen mesh bound wholly to its slot's bone, setup unchanged: what the attachment
    does without ``--weights auto`` (an upgraded region follows its slot's bone alone)."""
    for ref in iter_attachments(doc):
        if (ref.skin, ref.slot, ref.name) not in places:
            continue
        mesh = parse_vertices(ref.attachment, len(rig.bones))
        world = setup_world(mesh, rig.worlds, rig.slot_bone[ref.slot])
        ref.attachment["vertices"] = bind(world, np.ones((mesh.count, 1)), [rig.slot_bone[ref.slot]], rig.worlds)


def dump(tool: Path, atlas: Path, skeleton: Path, pose_list: list[str], out: Path) -> dict:
    args = ["node", "dump.mjs", str(atlas), str(skeleton), "--out", str(out)]
    if pose_list:
        args += ["--poses", ",".join(pose_list)]
    r = subprocess.run(args, cwd=tool, capture_output=True, text=True, timeout=600)
    if r.returncode:
        raise RuntimeError(r.stderr[-500:])
    return {p["label"]: {(d["slot"], d["attachment"]): d for d in p["attachments"]}
            for p in json.loads(out.read_text())["poses"]}


def signed_areas(v: np.ndarray, tris: np.ndarray) -> np.ndarray:
    a, b, c = v[tris[:, 0]], v[tris[:, 1]], v[tris[:, 2]]
    return (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])


#: The bone choices replayed, beside the two baselines.
MODES = ("keep", "rule", "learned")

#: The baselines every choice is judged against (:func:`against`): each vertex rigid on its
#: heaviest artist bone (the artist's rig without blending), and the whole mesh rigid on its
#: slot's bone (what an upgraded region does without ``--weights auto``).
BASELINES = {"rigid": "rigid on each vertex's heaviest artist bone",
             "on_slot_bone": "rigid on the slot's bone (no weights)"}


def against(cases: list[dict], results: dict[int, float], baseline: str) -> dict:
    """A variant's errors against a baseline's (``rigid``: the artist's heaviest bone;
    ``on_slot_bone``: the slot's bone), on the meshes the baseline moves (more than ``RIGID_FLOOR``, finite):
    median and geometric mean of the ratios, the sum of errors over the sum of the baseline's
    (the meshes that move most weigh most), and the share of meshes better than the baseline.

    ``cases``: per mesh, a dict with each baseline's error (None: not replayed); ``results``:
    the variant's error per index of ``cases``.
    """
    ids = [i for i in results if RIGID_FLOOR < (cases[i].get(baseline) or 0.0) < float("inf")]
    if not ids:
        return {"meshes": 0, "median": float("nan"), "geomean": float("nan"), "sum": float("nan"), "better": float("nan")}
    ours = np.array([results[i] for i in ids])
    theirs = np.array([cases[i][baseline] for i in ids])
    ratio = ours / theirs
    finite = np.isfinite(ours)
    return {"meshes": len(ids), "median": float(np.median(ratio)),
            "geomean": float(np.exp(np.mean(np.log(np.clip(ratio, 1e-3, 1e3))))),
            "sum": float(ours[finite].sum() / theirs[finite].sum()) if finite.any() else float("inf"),
            "better": float(np.mean(ratio < 1))}


def aggregates_table(cases: list[dict], per_variant: dict[str, dict[int, float]]) -> str:
    """The variants side by side (columns) on the same meshes (those every variant has), every
    aggregate of :func:`against` against both baselines (rows), as a Markdown table."""
    names = list(per_variant)
    common = set.intersection(*(set(r) for r in per_variant.values())) if names else set()
    stats = {n: {b: against(cases, {i: per_variant[n][i] for i in common}, b) for b in BASELINES} for n in names}
    lines = ["| against | " + " | ".join(names) + " |", "|---|" + "--:|" * len(names)]
    for base, label in BASELINES.items():
        moved = stats[names[0]][base]["meshes"] if names else 0
        for key, what in (("median", "median ratio"), ("geomean", "geometric mean"),
                          ("sum", "sum of errors / sum of baseline's"), ("better", "meshes better")):
            cells = [f"{stats[n][base][key]:.1%}" if key == "better" else f"{stats[n][base][key]:.3f}" for n in names]
            lines.append(f"| {label}: {what} ({moved} meshes) | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def rows_table(rows: list[dict]) -> str:
    """:func:`aggregates_table` of the replayed rows: keep, rule and learned on the meshes each
    of them was replayed for."""
    per_mode = {m: {i: r[m] for i, r in enumerate(rows) if all(r.get(k) is not None for k in MODES)} for m in MODES}
    return aggregates_table(rows, per_mode)


def project_habits_of(paths: list[Path]):
    """The artists' habits (:func:`spinemesh.rig.learned.project_habits`) over a project's
    skeletons, as ``spinemesh weights`` reads them from a project folder."""
    from spinemesh.rig.learned import project_habits

    docs = [load_skeleton(p) for p in paths]
    return project_habits([(d, build_rig(d)) for d in docs])


def replay(label: str, skeleton: Path, tool: Path, method: str, anims: int | None, times: int,
           model=None, habits=None) -> list[dict]:
    """One row per artist-weighted mesh compared: errors of each mode and of the baseline, flips,
    bones chosen. ``model``: the learned choice's model (default: the package's); ``habits``:
    the project's (:func:`project_habits_of`; None: the prior)."""
    from spinemesh.rig import learned
    doc = load_skeleton(skeleton)
    proj = find_project(skeleton.parent)
    source = image_source_for(doc, skeleton, proj)
    if source is None or not hasattr(source, "atlases"):
        return []
    atlas = source.atlases[0].path
    rig = build_rig(doc, sampled_bone_worlds)  # guarded as `spinemesh weights` guards
    rig.habits = habits
    variants = {"artist": doc}
    outcomes = {}
    learned.use_model(model)
    try:
        for mode in MODES:
            d = copy.deepcopy(doc)
            outcomes[mode] = {(o.skin, o.slot, o.name): o for o in weight_document(
                d, skeleton.name, WeightOptions(bones=mode, replace=True, method=method), rig)}
            variants[mode] = d
    finally:
        learned.use_model(None)
    artist_weighted = {(r.skin, r.slot, r.name) for r in iter_attachments(doc) if r.type == "mesh"
                       and len(r.attachment.get("vertices", [])) != len(r.attachment.get("uvs", []))}
    places = {k for k in artist_weighted if all(outcomes[m][k].status == "weighted" for m in MODES)}
    if not places:
        return []
    base = copy.deepcopy(doc)
    rigid_baseline(base, rig, places)
    variants["rigid"] = base
    alone = copy.deepcopy(doc)
    slot_baseline(alone, rig, places)
    variants["on_slot_bone"] = alone
    pose_list = poses(doc, anims, times)
    dumps = {}
    with tempfile.TemporaryDirectory() as tmp:
        for name, d in variants.items():
            path = Path(tmp) / f"{name}.json"
            path.write_text(dumps_skeleton(d))
            dumps[name] = dump(tool, atlas, path, pose_list, Path(tmp) / f"{name}.dump.json")
    rows = []
    by_slot = {(k[1], k[2]) for k in places}
    chosen = {(k[1], k[2]): {m: sorted(outcomes[m][k].chosen()) for m in MODES} for k in places}
    written = {(k[1], k[2]): {m: sorted(outcomes[m][k].bones) for m in MODES} for k in places}
    names = [b.name for b in rig.bones]
    artist = {(r.slot, r.name): sorted(names[b] for b in parse_vertices(r.attachment, len(names)).bones())
              for r in iter_attachments(doc) if (r.skin, r.slot, r.name) in places}
    tri_of = {(r.slot, r.name): np.asarray(r.attachment["triangles"], int).reshape(-1, 3)
              for r in iter_attachments(doc) if (r.skin, r.slot, r.name) in places}
    for slot_att in sorted(by_slot):
        err = {m: [] for m in (*MODES, *BASELINES)}
        flips = {m: [0, 0] for m in (*MODES, "artist")}
        setup_drift = 0.0
        tris = tri_of[slot_att]
        ref_setup = dumps["artist"]["setup"].get(slot_att)
        for pose in dumps["artist"]:
            a = dumps["artist"][pose].get(slot_att)
            if a is None:
                continue
            va = np.asarray(a["vertices"], float).reshape(-1, 2)
            if not np.isfinite(va).all():
                # the artist's own rig draws NaN here (a bone scaled to 0, say): nothing to compare,
                # and one NaN would make every median of the table meaningless
                continue
            for m in (*MODES, *BASELINES):
                b = dumps[m][pose].get(slot_att)
                if b is None:
                    continue
                vb = np.asarray(b["vertices"], float).reshape(-1, 2)
                d = float(np.linalg.norm(va - vb, axis=1).mean())
                if pose == "setup":
                    setup_drift = max(setup_drift, float(np.linalg.norm(va - vb, axis=1).max()))
                    continue
                err[m].append(d)
                if m in MODES and ref_setup is not None:
                    s0 = np.sign(signed_areas(np.asarray(ref_setup["vertices"], float).reshape(-1, 2), tris))
                    s1 = np.sign(signed_areas(vb, tris))
                    flips[m][0] += int(((s0 * s1) < 0).sum())
                    flips[m][1] += len(tris)
            if pose != "setup" and ref_setup is not None:
                s0 = np.sign(signed_areas(np.asarray(ref_setup["vertices"], float).reshape(-1, 2), tris))
                flips["artist"][0] += int(((s0 * np.sign(signed_areas(va, tris))) < 0).sum())
                flips["artist"][1] += len(tris)
        if not err["keep"]:
            continue
        row = {"project": label, "skeleton": skeleton.name, "slot": slot_att[0], "attachment": slot_att[1],
               "setup_drift": setup_drift}
        for m in (*MODES, *BASELINES):
            row[m] = float(np.mean(err[m])) if err[m] else None
        for m in (*MODES, "artist"):
            row[f"flips_{m}"] = flips[m]
        for m in MODES:
            row[f"bones_{m}"] = chosen[slot_att][m]
            row[f"written_{m}"] = written[slot_att][m]
        row["bones_artist"] = artist[slot_att]
        rows.append(row)
    return rows


def summary(rows: list[dict]) -> dict:
    def med(xs):
        xs = [x for x in xs if x is not None]
        return statistics.median(xs) if xs else float("nan")

    def ratio(m):
        return med([r[m] / r["rigid"] for r in rows if r[m] is not None and r["rigid"] and r["rigid"] > RIGID_FLOOR])

    def share(m):
        f = sum(r[f"flips_{m}"][0] for r in rows)
        n = sum(r[f"flips_{m}"][1] for r in rows)
        return f / n if n else float("nan")

    out = {"meshes": len(rows), "rigid": med([r["rigid"] for r in rows]), "flips_artist": share("artist"),
           "setup_drift": max((r["setup_drift"] for r in rows), default=0.0),
           "artist_p95": float(np.percentile([len(r["bones_artist"]) for r in rows], 95)) if rows else float("nan")}
    for m in MODES:
        counts = [len(r[f"bones_{m}"]) for r in rows]
        out.update({m: med([r[m] for r in rows]), f"{m}_ratio": ratio(m), f"flips_{m}": share(m),
                    f"{m}_exact": float(np.mean([r[f"bones_{m}"] == r["bones_artist"] for r in rows])) if rows else 0.0,
                    f"{m}_written_exact": float(np.mean([r[f"written_{m}"] == r["written_keep"] for r in rows]))
                    if rows else 0.0,
                    f"{m}_p95": float(np.percentile(counts, 95)) if counts else float("nan")})
    return out


def by_project(rows: list[dict]) -> dict[str, list[dict]]:
    """The rows of each project."""
    out: dict[str, list] = {}
    for r in rows:
        out.setdefault(r["project"], []).append(r)
    return out


#: Resamples of the projects for the interval of the median ratio (:func:`spread`).
RESAMPLES = 1000


def _ratios(rows: list[dict], mode: str) -> np.ndarray:
    """Each row's ratio to the rigid baseline (NaN where the baseline is within ``RIGID_FLOOR``)."""
    return np.array([r[mode] / r["rigid"] if r[mode] is not None and r["rigid"] and r["rigid"] > RIGID_FLOOR
                     else np.nan for r in rows])


def spread(rows: list[dict], seed: int = 0) -> dict:
    """How much the overall ratios hang on single projects: per mode, the median over projects of
    each project's median ratio, the overall median ratio without the project of most meshes
    (``largest``, its share of the meshes ``largest_share``), and the 5th and 95th percentiles of
    the median ratio over ``RESAMPLES`` draws of as many projects, with replacement."""
    projects = by_project(rows)
    names = sorted(projects)
    rng = np.random.default_rng(seed)
    draws = [rng.integers(0, len(names), len(names)) for _ in range(RESAMPLES)] if names else []
    largest = max(projects, key=lambda k: len(projects[k])) if projects else ""
    rest = [r for r in rows if r["project"] != largest]
    out = {"projects": len(projects), "largest": largest,
           "largest_share": len(projects.get(largest, [])) / max(len(rows), 1)}
    for m in MODES:
        per = [summary(rs)[f"{m}_ratio"] for rs in projects.values()]
        per = [x for x in per if x == x]  # projects whose every mesh moves rigidly have no ratio
        out[f"{m}_project_median"] = statistics.median(per) if per else float("nan")
        out[f"{m}_without_largest"] = summary(rest)[f"{m}_ratio"] if rest else float("nan")
        each = [_ratios(projects[k], m) for k in names]
        drawn = (np.concatenate([each[i] for i in d]) for d in draws)
        medians = [np.nanmedian(x) for x in drawn if not np.isnan(x).all()]
        out[f"{m}_interval"] = tuple(np.percentile(medians, [5, 95])) if medians else (float("nan"),) * 2
    return out


def report(rows: list[dict], method: str) -> None:
    """The per-project table, the overall row, the spread over projects and the setup drift."""
    print("\n| project | meshes | keep px | keep / rigid | rule px | rule / rigid | learned px | learned / rigid "
          "| rigid px | exact set rule / learned | written as keep rule / learned | bones p95 rule / learned / artists "
          "| flips keep / rule / learned / artist |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for name, rs in sorted(by_project(rows).items()) + [("**all**", rows)]:
        s = summary(rs)
        print(f"| {name} | {s['meshes']} | {s['keep']:.2f} | {s['keep_ratio']:.2f} | {s['rule']:.2f} | "
              f"{s['rule_ratio']:.2f} | {s['learned']:.2f} | {s['learned_ratio']:.2f} | {s['rigid']:.2f} | "
              f"{s['rule_exact']:.0%} / {s['learned_exact']:.0%} | {s['rule_written_exact']:.0%} / "
              f"{s['learned_written_exact']:.0%} | {s['rule_p95']:.0f} / {s['learned_p95']:.0f} / "
              f"{s['artist_p95']:.0f} | {s['flips_keep']:.3f} / {s['flips_rule']:.3f} / {s['flips_learned']:.3f} / "
              f"{s['flips_artist']:.3f} |")
    sp = spread(rows)
    print(f"\n{sp['projects']} projects; median over projects of their median ratio: "
          + ", ".join(f"{m} {sp[m + '_project_median']:.2f}" for m in MODES)
          + f"\nwithout {sp['largest']} ({sp['largest_share']:.0%} of the meshes): "
          + ", ".join(f"{m} {sp[m + '_without_largest']:.2f}" for m in MODES)
          + f"\nmedian ratio over {RESAMPLES} draws of the projects, 5th-95th percentile: "
          + ", ".join(f"{m} {sp[m + '_interval'][0]:.2f}-{sp[m + '_interval'][1]:.2f}" for m in MODES))
    print(f"\nkeep, rule and learned on the same meshes, every aggregate against both baselines:\n\n{rows_table(rows)}")
    s = summary(rows)
    print(f"\nsetup pose: largest vertex drift {s['setup_drift']:.4f} world units; method {method}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--examples", default="4.2", help="example version to replay ('' for none)")
    ap.add_argument("--corpus", type=int, default=0, help="first N corpus projects")
    ap.add_argument("--method", default="bbw", choices=("bbw", "harmonic", "biharmonic"))
    ap.add_argument("--anims", type=int, default=0, help="replay each skeleton's first N animations (0: all)")
    ap.add_argument("--times", type=int, default=4)
    ap.add_argument("--tool", type=Path, help="installed copy of tools/spine-runtime")
    ap.add_argument("--only", default="", help="substring of project labels to run")
    ap.add_argument("--json", type=Path)
    ap.add_argument("--every", type=int, default=1, help="replay every K-th skeleton (faster)")
    ap.add_argument("--start", type=int, default=0, help="with --every K: begin at this skeleton (0 to K-1; "
                    "runs with each start together replay every skeleton)")
    ap.add_argument("--fold-models", type=Path, default=Path("/tmp/spinemesh-bone-choice-folds"),
                    help="the learned choice's fold models (scripts/train_bone_choice.py --fold-models)")
    ap.add_argument("--merge", type=Path, nargs="+", help="print the tables of earlier runs' --json files "
                    "together (runs with --every K and each --start), replaying nothing")
    args = ap.parse_args()
    if args.merge:
        rows = [r for f in args.merge for r in json.loads(f.read_text())["rows"]]
    elif args.tool is None:
        ap.error("--tool is needed to replay (or --merge earlier runs)")
    else:
        rows = replay_all(args)
    report(rows, args.method)
    if args.json:
        args.json.write_text(json.dumps({"rows": rows, "overall": summary(rows)}, indent=1))


def replay_all(args: argparse.Namespace) -> list[dict]:
    """Replay every ``--every``-th skeleton from ``--start``, printing a line per skeleton; the rows."""
    from spinemesh.train import bone_choice as train_choice

    models = train_choice.load_fold_models(args.fold_models)
    rows = []
    every = skeletons(args.examples, args.corpus)
    habits_of: dict[str, object] = {}
    for label, skel in every[args.start::args.every]:
        if args.only and args.only not in label:
            continue
        model = train_choice.model_for(models, train_choice.repository_of(label, SHARED / "spine-corpus"))
        # a model reading the project's habits gets them from all the project's replayed skeletons
        if model.reads_habits and label not in habits_of:
            habits_of[label] = project_habits_of([s for g, s in every if g == label])
        habits = habits_of.get(label)
        try:
            got = replay(label, skel, args.tool, args.method, args.anims or None, args.times, model, habits)
        except (RuntimeError, subprocess.TimeoutExpired) as e:
            print(f"{label}/{skel.name}: runtime failed: {str(e)[:200]}", file=sys.stderr)
            continue
        rows += got
        if got:
            s = summary(got)
            print(f"{label:34s} {skel.name:28s} n={s['meshes']:3d} "
                  + " ".join(f"{m} {s[m]:7.2f} ({s[m + '_ratio']:.2f}x)" for m in MODES)
                  + f" rigid {s['rigid']:7.2f} setup {s['setup_drift']:.3f}", flush=True)
    return rows


if __name__ == "__main__":
    main()
