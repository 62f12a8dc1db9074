"""benchmarks/bench_weights.py: how the replay's ratios are summed up, and runs judged together."""

from __future__ import annotations

import json
import sys

import pytest

from conftest import REPO

sys.path.insert(0, str(REPO / "benchmarks"))

import bench_weights  # noqa: E402


def _row(project: str, keep: float, rule: float, learned: float, rigid: float = 1.0) -> dict:
    """One replayed mesh: errors per mode against a rigid error, two bones each, the artist's kept."""
    return {"project": project, "skeleton": "s.json", "slot": "s", "attachment": "a", "setup_drift": 0.0,
            "keep": keep, "rule": rule, "learned": learned, "rigid": rigid,
            **{f"flips_{m}": [0, 1] for m in (*bench_weights.MODES, "artist")},
            "bones_keep": [1, 2], "bones_rule": [1, 2, 3], "bones_learned": [1, 2], "bones_artist": [1, 2],
            "written_keep": [1, 2], "written_rule": [1, 2, 3], "written_learned": [1, 2]}


def _rows() -> list[dict]:
    # a project of three meshes replaying at the rigid error and one of a single mesh at 3x it
    return [_row("big", 1.0, 2.0, 1.0) for _ in range(3)] + [_row("small", 1.0, 2.0, 3.0)]


def test_spread_weighs_projects_alike_and_leaves_out_the_largest():
    sp = bench_weights.spread(_rows())
    assert sp["projects"] == 2 and sp["largest"] == "big" and sp["largest_share"] == pytest.approx(0.75)
    assert bench_weights.summary(_rows())["learned_ratio"] == pytest.approx(1.0)   # 3 meshes of 4 at 1x
    assert sp["learned_project_median"] == pytest.approx(2.0)                       # median of 1x and 3x
    assert sp["learned_without_largest"] == pytest.approx(3.0)
    low, high = sp["learned_interval"]
    assert 1.0 <= low <= high <= 3.0 and high == pytest.approx(3.0)   # some draws hold only "small"
    assert sp["rule_interval"] == pytest.approx((2.0, 2.0))


def test_exact_sets_compare_the_chosen_bones_with_the_artists_own():
    # the artist bound bones 1, 2 and 3, but weighted nothing to 3: keep writes 1 and 2 alone
    row = {**_row("p", 1.0, 2.0, 1.0), "bones_artist": [1, 2, 3], "bones_keep": [1, 2, 3],
           "written_keep": [1, 2], "bones_rule": [1, 2], "written_rule": [1, 2],
           "bones_learned": [1, 2, 3], "written_learned": [1, 2]}
    s = bench_weights.summary([row])
    assert s["learned_exact"] == 1.0 and s["rule_exact"] == 0.0 and s["keep_exact"] == 1.0
    assert s["rule_written_exact"] == 1.0 and s["learned_written_exact"] == 1.0   # the written bones hide it
    assert s["artist_p95"] == 3.0


def test_ratios_leave_out_meshes_the_rigid_baseline_already_places():
    rows = _rows() + [_row("still", 0.01, 0.01, 5.0, rigid=bench_weights.RIGID_FLOOR / 2)]
    ratios = bench_weights._ratios(rows, "learned")
    assert ratios[:4].tolist() == [1.0, 1.0, 1.0, 3.0] and ratios[4] != ratios[4]   # NaN
    assert bench_weights.summary(rows)["learned_ratio"] == pytest.approx(1.0)


def test_merge_judges_earlier_runs_together(tmp_path, monkeypatch, capsys):
    rows = _rows()
    for k, part in enumerate((rows[:2], rows[2:])):
        (tmp_path / f"run-{k}.json").write_text(json.dumps({"rows": part}))
    monkeypatch.setattr(sys, "argv", ["bench_weights.py", "--merge", str(tmp_path / "run-0.json"),
                                      str(tmp_path / "run-1.json"), "--json", str(tmp_path / "all.json")])
    bench_weights.main()
    out = capsys.readouterr().out
    assert "| **all** | 4 |" in out and "2 projects" in out and "without big (75% of the meshes)" in out
    assert json.loads((tmp_path / "all.json").read_text())["overall"]["meshes"] == 4


def test_offline_replay_counts_a_mesh_drawn_nowhere_as_the_worst():
    import numpy as np

    import bench_weights_offline as offline

    # one vertex bound to one bone, replayed over one frame where that bone is scaled to nothing (NaN)
    case = {"world": np.array([[1.0, 0.0]]), "setup_matrices": np.array([[[1.0, 0, 0], [0, 1.0, 0]]]),
            "frame_matrices": np.full((1, 1, 2, 3), np.nan), "frame_vertices": np.array([[[1.0, 0.0]]])}
    assert offline.replay(case, np.ones((1, 1)), [0]) == float("inf")
    cases = [{"rigid": 1.0, "bones": [0]}, {"rigid": 1.0, "bones": [0]}, {"rigid": 1.0, "bones": [0]}]
    judged = offline.judge(cases, {0: 1.0, 1: 2.0, 2: float("inf")}, {0: [0], 1: [0], 2: [1]})
    assert judged["ratio"] == 2.0 and np.isfinite(judged["geomean"]) and judged["exact"] == 2 / 3


def test_offline_replay_judges_each_choice_against_both_baselines():
    import numpy as np

    import bench_weights_offline as offline

    # rigid: the artist's heaviest bone; slot: the slot's bone alone. Mesh 3 the baseline leaves
    # in place (below the floor): out of that baseline's figures
    cases = [{"rigid": 1.0, "on_slot_bone": 4.0}, {"rigid": 2.0, "on_slot_bone": 2.0},
             {"rigid": 1.0, "on_slot_bone": 10.0}, {"rigid": 0.01, "on_slot_bone": 1.0}]
    errors = {0: 2.0, 1: 1.0, 2: 4.0, 3: 0.5}
    rigid = offline.against(cases, errors, "rigid")
    assert rigid["meshes"] == 3 and rigid["median"] == 2.0 and rigid["sum"] == 7.0 / 4.0
    assert rigid["better"] == 1 / 3 and rigid["geomean"] == np.exp(np.log([2.0, 0.5, 4.0]).mean())
    slot = offline.against(cases, errors, "on_slot_bone")
    assert slot["meshes"] == 4 and slot["median"] == 0.5 and slot["sum"] == 7.5 / 17.0 and slot["better"] == 1.0
    table = offline.aggregates_table(cases, {"keep": {i: 1.0 for i in range(4)}, "rule": errors})
    assert "| against | keep | rule |" in table
    assert "slot's bone (no weights): sum of errors / sum of baseline's (4 meshes) | 0.235 | 0.441 |" in table


def test_offline_replay_keeps_each_variants_errors_across_runs(tmp_path, monkeypatch):
    import bench_weights_offline as offline

    solved = []
    monkeypatch.setitem(offline.VARIANTS, "rule", lambda case: solved.append(case["name"]) or ([0], None))
    monkeypatch.setattr(offline, "replay", lambda case, w, bones: case["error"])
    monkeypatch.setattr(offline, "sparsify", lambda w, cap, floor: w)
    cases = [{"label": "corpus/p", "skeleton": "s.json", "skin": "default", "slot": "s", "name": n, "error": e}
             for n, e in (("a", 1.0), ("b", 2.0))]
    saved = tmp_path / "errors.json"
    assert offline.errors_of(cases, "rule", saved=saved) == {0: 1.0, 1: 2.0} and solved == ["a", "b"]
    cases.append({**cases[0], "name": "c", "error": 3.0})
    assert offline.errors_of(cases, "rule", saved=saved) == {0: 1.0, 1: 2.0, 2: 3.0}
    assert solved == ["a", "b", "c"], "the cases of the earlier run were replayed again"
    monkeypatch.setattr(offline.rig_weights, "REFINED_VERTEX_BUDGET", 1000)  # --points 1000
    assert offline.errors_of(cases, "rule", saved=saved) == {0: 1.0, 1: 2.0, 2: 3.0}
    assert solved == ["a", "b", "c"] * 2, "errors of another refinement were taken for these"


def test_offline_cases_keep_their_slot_name_beside_the_slot_bone_baseline(monkeypatch):
    from pathlib import Path

    import bench_weights_offline as offline

    # the learned choice's habits leave out the meshes sharing the judged mesh's slot name: the
    # baseline's error must not take that name's place
    case = {"label": "corpus/p", "skeleton": "s.json", "skin": "default", "slot": "arm", "name": "sleeve"}
    monkeypatch.setattr(offline, "collect", lambda *a: [("corpus/p", Path("s.json"), Path("d.json"))])
    monkeypatch.setattr(offline, "cases_of", lambda *a: [dict(case)])
    monkeypatch.setattr(offline, "rigid_error", lambda c: 1.0)
    monkeypatch.setattr(offline, "slot_error", lambda c: 2.0)
    monkeypatch.setattr(offline, "VARIANTS", dict(offline.VARIANTS))
    [got] = offline.replay_cases(Path("tool"), Path("cache"), "4.2", 0, 1, None, 4, Path("folds"))
    assert got["slot"] == "arm" and got["rigid"] == 1.0 and got["on_slot_bone"] == 2.0
    assert offline.case_key(got) == "corpus/p|s.json|default|arm|sleeve"


def test_runtime_replay_tables_every_choice_against_both_baselines():
    rows = [{**_row("p", 1.0, 2.0, 0.5), "on_slot_bone": 4.0}, {**_row("p", 3.0, 1.0, 1.0), "on_slot_bone": 2.0}]
    table = bench_weights.rows_table(rows)
    assert "| against | keep | rule | learned |" in table
    # against the slot's bone: keep 1/4 and 3/2, rule 2/4 and 1/2, learned 0.5/4 and 1/2
    assert "slot's bone (no weights): sum of errors / sum of baseline's (2 meshes) | 0.667 | 0.500 | 0.250 |" in table
    assert "slot's bone (no weights): meshes better (2 meshes) | 50.0% | 100.0% | 100.0% |" in table
    assert "heaviest artist bone: median ratio (2 meshes) | 2.000 | 1.500 | 0.750 |" in table


def test_offline_post_processing_variants_make_a_two_bone_strip_more_local(monkeypatch):
    import numpy as np

    import bench_weights_offline as offline

    # a strip along x from 0 to 10, bone 0 from 0 to 5, bone 1 from 5 to 10; smooth weights
    # blending linearly over the whole strip
    x = np.linspace(0.0, 10.0, 11)
    points = np.stack([x, np.zeros_like(x)], axis=1)
    w = np.stack([1 - x / 10, x / 10], axis=1)
    segs = np.array([[[0.0, 0.0], [5.0, 0.0]], [[5.0, 0.0], [10.0, 0.0]]])
    case = {"world": points, "tris": np.zeros((0, 3), int), "rig": None}
    monkeypatch.setattr(offline, "segments", lambda c, bones: segs)
    for name in ("keep:sharpen=2", "keep:band=0.2", "keep:floor=0.3", "keep:sharpen=3+cap=1"):
        got = offline.finished(case, name, w, [0, 1], 4)
        assert np.allclose(got.sum(axis=1), 1.0) and (got >= 0).all() and (got <= 1).all(), name
        assert (np.abs(got - 0.5) >= np.abs(w - 0.5) - 1e-12).all(), f"{name} blends more somewhere"
        assert (got.argmax(1) == w.argmax(1))[x != 5].all(), name
        assert (np.abs(got - 0.5) > np.abs(w - 0.5) + 1e-6).any(), f"{name} changed nothing"
    # the band: unchanged at the joint, one bone alone from a fifth of the strip's length on
    banded = offline.banded(w, points, segs, 0.2)
    assert np.allclose(banded[5], w[5]) and np.allclose(banded[[0, 1, 9, 10]], np.eye(2)[[0, 0, 1, 1]])
    # the slot's bone favoured: it leads more of the strip, the ends stay on one bone each
    favoured = offline.finished({**case, "slot_bone": 0}, "keep:slot=0.5", w, [0, 1], 4)
    assert (favoured[:, 0] >= w[:, 0] - 1e-12).all() and favoured[5, 0] > 0.5
    assert np.allclose(favoured[[0, 10]], np.eye(2)) and np.allclose(favoured.sum(axis=1), 1.0)
    assert offline.variant_of("keep:sharpen=2+reach=0") is not offline.VARIANTS["keep"]
    with pytest.raises(ValueError, match="unknown post-processing"):
        offline.finished(case, "keep:blur=1", w, [0, 1], 4)


def test_each_repository_fold_is_judged_at_the_variant_the_other_folds_pick(monkeypatch, capsys):
    from types import SimpleNamespace

    import numpy as np

    import bench_weights_offline as offline
    from spinemesh.train import bone_choice as train_choice

    # two folds of one repository each: "a" gains from the variant "x", "b" loses from it
    models = {0: SimpleNamespace(meta={"held_out": ["a"]}), 1: SimpleNamespace(meta={"held_out": ["b"]})}
    monkeypatch.setattr(train_choice, "load_fold_models", lambda folder: models)
    monkeypatch.setattr(train_choice, "repository_of", lambda label, corpus: label)
    cases = [{"label": r, "rigid": 1.0, "on_slot_bone": 10.0} for r in ("a", "a", "b", "b")]
    errors = {"none": {0: 5.0, 1: 5.0, 2: 5.0, 3: 5.0}, "x": {0: 1.0, 1: 1.0, 2: 9.0, 3: 9.0}}
    monkeypatch.setattr(offline, "errors_of", lambda cases, name, *a: errors[name])
    got = offline.chosen_by_fold(cases, ["none", "x"], None, "folds")
    # fold "a" judged at the pick of fold "b" (none), fold "b" at the pick of fold "a" (x)
    assert got == {0: 5.0, 1: 5.0, 2: 9.0, 3: 9.0}
    assert "fold 0: none" in capsys.readouterr().out
    steps = "learned:driftslot=0.75+ref=likely+refdrift=0.5+spread=1+spreadwhere=off+minp=0.05"
    assert offline.finished({}, steps, np.eye(2), [0, 1], 4).shape == (2, 2)  # the choice's steps


def test_offline_habitkeep_keeps_the_unlikely_bones_the_projects_artists_bound_on_the_slot_bone(monkeypatch):
    """``habitkeep``: the product's unlikely-bone limit, but for the bones the project's artists
    bound on the other meshes on the same slot bone; nothing changes without the habits, for the
    upgrade's art, or (``habitkeep=slot``) where the slot's bone is not where the art goes."""
    import numpy as np

    import bench_weights_offline as offline
    from spinemesh.rig import drift
    from spinemesh.rig.habits import TALLY_SIZE
    from spinemesh.rig.learned import TreeEnsemble
    from test_bone_choice_learned import _mesh_of, _tree_model, _worm_mesh_doc

    rig, ref, mesh, world, tris = _mesh_of(_worm_mesh_doc())
    at = {b.name: i for i, b in enumerate(rig.bones)}
    case = {"rig": rig, "slot_bone": rig.slot_bone["worm"], "world": world, "tris": tris, "skin": ref.skin}
    model = TreeEnsemble.from_json(_tree_model("is_descendant", 0.5))  # seg2, seg3: 0.95; "beside": 0.05
    chosen, others = sorted([at["seg2"], at["beside"]]), np.ones(TALLY_SIZE)
    bound = {(at["seg1"], at["beside"]): 1}                             # another mesh on seg1 bound "beside"

    def keep(value, nearby, habits=others, unweighted=False):
        monkeypatch.setattr(offline, "SOLVE", {"habitkeep": value})
        return offline.without_unlikely_but_bound(case, model, habits, nearby, chosen, unweighted)

    assert keep("1", {}) == [at["seg2"]]                                # the product's limit: under 0.05
    assert keep("1", bound) == chosen and keep("slot", bound) == chosen  # bound on the slot bone: kept
    assert keep("1", {}, habits=None) == chosen and keep("1", {}, unweighted=True) == chosen
    split = {**bound, (at["seg1"], at["seg2"]): 2}                       # bound on 1 of 3: not by most
    assert keep("1", split) == chosen and keep("most", split) == [at["seg2"]] and keep("most", bound) == chosen
    monkeypatch.setattr(drift, "follows_slot", lambda *a, **k: False)  # slot's bone off the art
    assert keep("slot", bound) == [at["seg2"]] and keep("1", bound) == chosen
    steps = "learned:driftslot=0.75+habitkeep=slot"
    assert offline.finished({}, steps, np.eye(2), [0, 1], 4).shape == (2, 2)  # a choice step
