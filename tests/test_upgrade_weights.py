"""``upgrade --weights auto`` meshes the regions that bend, even where the keep rule would keep them.

The fixture is drawn by our own code: one fully opaque 200x40 bar image (so the keep rule's
first test keeps it: its art fills the whole region), used by two region attachments. ``bar``
hangs on ``upper`` and lies across the joint to ``lower`` (a chain of two 100-unit bones): it
would bend. ``flag`` hangs on ``lone``, far from every other bone: it would not.
"""

from __future__ import annotations

import copy
import json
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from spinemesh.skeleton import iter_attachments
from spinemesh.upgrade import Options, upgrade_project
from spinemesh.upgrade.plan import BENDS_KEY, MeshTask, art_box, plan_project
from spinemesh.upgrade.report import Result
from spinemesh.project import find_project

WIDTH, HEIGHT = 200, 40


def bar_skeleton(lower_x: float = 100.0) -> dict:
    """``lower_x``: where ``lower`` starts on ``upper`` (100: at the bar's middle; far away: nothing bends)."""
    return {
        "skeleton": {"hash": "YmFyYmFyYmFy", "spine": "4.2.22", "x": -110, "y": -30, "width": 220, "height": 360},
        "bones": [
            {"name": "root"},
            {"name": "upper", "parent": "root", "length": 100, "x": -100},
            {"name": "lower", "parent": "upper", "length": 100, "x": lower_x},
            {"name": "lone", "parent": "root", "length": 50, "y": 300},
        ],
        "slots": [{"name": "bar", "bone": "upper", "attachment": "bar"},
                  {"name": "flag", "bone": "lone", "attachment": "bar"}],
        "skins": [{"name": "default", "attachments": {
            "bar": {"bar": {"x": 100, "width": WIDTH, "height": HEIGHT}},
            "flag": {"bar": {"width": WIDTH, "height": HEIGHT}}}}],
        "animations": {"bend": {"bones": {
            "lower": {"rotate": [{"value": 60}]}}}},
    }


def make_bar_project(folder: Path, lower_x: float = 100.0, art_width: int = WIDTH) -> Path:
    """``bar.json``, ``bar.atlas`` and ``bar.png`` in ``folder``; returns the skeleton path.

    ``art_width``: the image's art is its left ``art_width`` pixels, all the atlas stores (the
    rest, transparent, stripped by the packer)."""
    folder.mkdir(parents=True, exist_ok=True)
    page = np.zeros((64, 256, 4), np.uint8)
    y, x = np.mgrid[0:HEIGHT, 0:art_width]
    page[2:2 + HEIGHT, 2:2 + art_width, 0] = np.where((x // 25) % 2 == 0, 210, 70)
    page[2:2 + HEIGHT, 2:2 + art_width, 1] = 140
    page[2:2 + HEIGHT, 2:2 + art_width, 3] = 255
    Image.fromarray(page).save(folder / "bar.png")
    (folder / "bar.atlas").write_text(
        f"bar.png\n\tsize: 256, 64\n\tfilter: Linear, Linear\nbar\n\tbounds: 2, 2, {art_width}, {HEIGHT}\n"
        f"\toffsets: 0, 0, {WIDTH}, {HEIGHT}\n")
    path = folder / "bar.json"
    path.write_text(json.dumps(bar_skeleton(lower_x), indent=1))
    return path


def by_slot(result) -> dict:
    return {t.slot: t for t in result.targets}


def attachments(path: Path) -> dict:
    return {(r.slot, r.name): r.attachment for r in iter_attachments(json.loads(path.read_text()))}


def test_a_bending_region_is_meshed_and_weighted_with_auto_and_kept_with_none(tmp_path):
    project = make_bar_project(tmp_path / "p")
    none = by_slot(upgrade_project(project, tmp_path / "none", Options(weights="none")))
    auto = by_slot(upgrade_project(project, tmp_path / "auto", Options(weights="auto")))

    # --weights none: the keep rule keeps both (the art fills the whole region)
    for slot in ("bar", "flag"):
        assert none[slot].status == "kept" and none[slot].reason.startswith("not worth meshing"), none[slot]
    assert attachments(tmp_path / "none" / "bar.json") == attachments(project)

    # --weights auto: the bending one is meshed and bound to both bones, and says why
    bar = auto["bar"]
    assert bar.status == "meshed", bar
    assert bar.weights["status"] == "weighted" and bar.weights["meshed_to_bend"] is True
    assert set(bar.weights["bones"]) == {"upper", "lower"}
    # the rule finds that it bends, the learned choice (``auto``) binds it and says why
    assert all(why.startswith("learned:") for why in bar.weights["bones"].values()), bar.weights
    assert bar.reason.startswith("meshed because it bends over 2 bones; without --weights auto it would stay a "
                                 "region: not worth meshing")
    assert "overruled" not in bar.row() and "region" not in bar.row()
    out = attachments(tmp_path / "auto" / "bar.json")
    mesh = out[("bar", "bar")]
    assert mesh["type"] == "mesh"
    assert len(mesh["vertices"]) > len(mesh["uvs"])  # weighted: bone count, bone, x, y, weight per vertex
    # the one that does not bend is unaffected: kept, for the same reason, as it was
    assert auto["flag"].status == "kept" and auto["flag"].reason == none["flag"].reason
    assert auto["flag"].weights is None
    assert out[("flag", "bar")] == attachments(project)[("flag", "bar")]


def test_one_image_gets_both_results_by_its_two_keys(tmp_path):
    """The shared image is planned once (plain) under both; under --weights auto, once its plain
    mesh is kept, the bending region is tested and meshed again by the bending key."""
    from spinemesh.cluster import Workers
    from spinemesh.upgrade.bending import settle_bending
    from spinemesh.upgrade.meshing import mesh_tasks

    project = find_project(make_bar_project(tmp_path / "p"))
    keys = {}
    for weights in ("none", "auto"):
        plan = plan_project(project, Options(weights=weights), Result())
        keys[weights] = sorted(plan.tasks)
        targets = {t.slot: t for sk in plan.skeletons for t in sk.targets}
        assert targets["flag"].key in plan.tasks and targets["bar"].key in plan.tasks
        assert [t.slot for t, _ in plan.may_bend] == ([] if weights == "none" else ["bar", "flag"])
        meshes = mesh_tasks(plan.tasks, Workers())
        assert meshes[targets["bar"].key].kept  # the keep rule keeps the plain mesh
        settle_bending(plan, meshes, None)
        assert not plan.may_bend
        if weights == "auto":
            assert targets["bar"].key == BENDS_KEY + keys["none"][0] and targets["flag"].key == keys["none"][0]
            assert sorted(plan.tasks) == sorted(meshes) == [keys["none"][0], BENDS_KEY + keys["none"][0]]
            assert meshes[targets["bar"].key].vertices is not None and meshes[targets["bar"].key].overruled
    assert len(keys["none"]) == 1 and not keys["none"][0].startswith(BENDS_KEY)
    assert keys["auto"] == keys["none"]


def _bar_and_half_project(folder: Path) -> Path:
    """The bar project with a second image, ``half``: an ellipse over the middle 100 of 200
    pixels (the atlas stores those), on a slot of ``upper`` across the joint like ``bar``: it
    bends, and the keep rule meshes it anyway (the ellipse's corners are transparent)."""
    path = make_bar_project(folder)
    page = np.zeros((128, 256, 4), np.uint8)
    page[:64] = np.asarray(Image.open(folder / "bar.png"))
    y, x = np.mgrid[0:HEIGHT, 0:100]
    inside = ((x - 49.5) / 50) ** 2 + ((y - 19.5) / 20) ** 2 <= 1
    page[66:66 + HEIGHT, 2:102][inside] = (90, 200, 60, 255)
    Image.fromarray(page).save(folder / "bar.png")
    atlas = (folder / "bar.atlas").read_text().replace("size: 256, 64", "size: 256, 128")
    (folder / "bar.atlas").write_text(atlas + f"half\n\tbounds: 2, 66, 100, {HEIGHT}\n\toffsets: 50, 0, {WIDTH}, {HEIGHT}\n")
    doc = json.loads(path.read_text())
    doc["slots"].append({"name": "half", "bone": "upper", "attachment": "half"})
    doc["skins"][0]["attachments"]["half"] = {"half": {"x": 100, "width": WIDTH, "height": HEIGHT}}
    path.write_text(json.dumps(doc, indent=1))
    return path


def test_testing_only_the_regions_kept_for_bending_gives_what_testing_all_before_meshing_gave(tmp_path, monkeypatch):
    """--weights auto tests a region for bending only once its plain mesh is kept: the documents
    and the report are those of testing every region before meshing (and meshing those that bend
    as bending tasks), with fewer tests."""
    from spinemesh.cluster import Workers
    from spinemesh.rig.upgraded_meshes import BendingRegions
    from spinemesh.upgrade.bending import gather_habits
    from spinemesh.upgrade.meshing import mesh_tasks
    from spinemesh.upgrade.plan import bending_task
    from spinemesh.upgrade.apply import apply_project

    tested = []
    monkeypatch.setattr(BendingRegions, "bends", lambda self, ref, *a, f=BendingRegions.bends:
                        tested.append(ref.slot) or f(self, ref, *a))
    project = find_project(_bar_and_half_project(tmp_path / "p"))
    plans, tests = [], []
    for every in (True, False):
        tested.clear()
        plan = plan_project(project, Options(weights="auto"), Result())
        if every:  # as before: every region that may bend tested first, its bending task meshed
            gather_habits(plan)
            for t, bends in plan.may_bend:
                if bends(art_box(plan.tasks[t.key])):
                    task = bending_task(plan.tasks[t.key])
                    plan.tasks.setdefault(task.key, task)
                    t.key = task.key
            plan.may_bend = []
            plan.tasks = {k: v for k, v in plan.tasks.items() if any(
                t.key == k for sk in plan.skeletons for t in sk.targets)}
        apply_project(plan, mesh_tasks(plan.tasks, Workers()))
        plans.append(plan)
        tests.append(sorted(tested))
    assert tests == [["bar", "flag", "half"], ["bar", "flag"]]
    (a,), (b,) = [[json.dumps(sk.doc) for sk in p.skeletons] for p in plans]
    assert a == b
    assert _rows_of(plans[0]) == _rows_of(plans[1])
    rows = {t.slot: t for t in plans[1].skeletons[0].targets}
    assert rows["half"].status == "meshed" and not rows["half"].overruled and len(rows["half"].weights["bones"]) == 2
    assert rows["bar"].status == "meshed" and rows["bar"].overruled and rows["bar"].weights["meshed_to_bend"]
    assert rows["flag"].status == "kept"


def test_none_output_does_not_depend_on_the_bones(tmp_path):
    """--weights none: the same attachments, byte for byte, whether the bar lies across a joint or not."""
    bending = make_bar_project(tmp_path / "bending")
    straight = make_bar_project(tmp_path / "straight", lower_x=1000.0)
    upgrade_project(bending, tmp_path / "a", Options(weights="none", min_saving=None))
    upgrade_project(straight, tmp_path / "b", Options(weights="none", min_saving=None))
    a = json.loads((tmp_path / "a" / "bar.json").read_text())
    b = json.loads((tmp_path / "b" / "bar.json").read_text())
    assert a["skins"][0]["attachments"]["bar"]["bar"]["type"] == "mesh"
    assert json.dumps(a["skins"]) == json.dumps(b["skins"])


def test_a_region_that_moves_away_from_the_joint_is_not_bent(tmp_path):
    """The same bar with ``lower`` far off its art: not bending, so the keep rule keeps it under auto too.

    The learned choice alone would bind it to ``upper`` and the root (a point at its middle): the
    rule, which never takes the root nor a bone off the art, says whether the art bends."""
    project = make_bar_project(tmp_path / "p", lower_x=1000.0)
    auto = by_slot(upgrade_project(project, tmp_path / "auto", Options(weights="auto")))
    assert auto["bar"].status == "kept" and auto["bar"].reason.startswith("not worth meshing"), auto["bar"]


def test_the_art_box_is_the_box_of_the_texels_to_cover_over_the_original_image():
    # a 40 x 20 part stored at (10, 5) of a 100 x 50 image, its texels to cover in rows 2-5, columns 4-29
    drawn = np.zeros((20, 40), bool)
    drawn[2:6, 4:30] = True
    task = MeshTask("k", np.zeros((20, 40, 4), np.uint8), (10, 5), (100, 50), (), drawn)
    assert art_box(task).tolist() == [[0.14, 0.14], [0.4, 0.14], [0.4, 0.22], [0.14, 0.22]]
    # nothing to cover (a mask made by the model, say): the whole quad
    nothing = MeshTask("k", np.zeros((20, 40, 4), np.uint8), (10, 5), (100, 50), (), np.zeros((20, 40), bool))
    assert art_box(nothing).tolist() == [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]


def test_a_region_whose_art_stops_short_of_the_joint_is_not_meshed_to_bend(tmp_path):
    """The bar's image spans the joint, its art (the left 70 of 200 pixels) does not: the box of
    the art, not the whole quad, says whether it may bend. So it is kept by the keep rule (the
    atlas stores only the art) and never meshed only to be put back."""
    project = make_bar_project(tmp_path / "p", art_width=70)
    auto = by_slot(upgrade_project(project, tmp_path / "auto", Options(weights="auto")))
    bar = auto["bar"]
    assert bar.status == "kept" and bar.reason.startswith("not worth meshing") and bar.weights is None, bar
    # the whole quad would have bent: over both bones
    from spinemesh.rig.document import build_rig
    from spinemesh.rig.upgraded_meshes import BendingRegions

    doc = json.loads(project.read_text())
    ref = next(r for r in iter_attachments(doc) if r.slot == "bar")
    assert BendingRegions.of(build_rig(doc)).bends(ref)


def test_a_mesh_made_to_bend_that_gets_one_bone_is_its_region_again(tmp_path):
    """weight_upgraded puts the region back, before solving weights, when the mesh meshed only to
    bend gets one bone (its art misses every other bone)."""
    from spinemesh.rig.upgraded_meshes import weight_upgraded

    project = make_bar_project(tmp_path / "p")
    # flag meshed with the rule off, as a bending task would be, then weighted: it gets one bone
    result = upgrade_project(project, tmp_path / "meshed", Options(weights="none", min_saving=None))
    doc = json.loads((tmp_path / "meshed" / "bar.json").read_text())
    region = copy.deepcopy(bar_skeleton()["skins"][0]["attachments"]["flag"]["bar"])
    targets = []
    for t in result.targets:
        assert t.status == "meshed"
        if t.slot == "flag":
            t.overruled, t.region = "not worth meshing: (the rule's reason)", copy.deepcopy(region)
        targets.append(t)
    weight_upgraded(doc, targets)
    flag = next(t for t in targets if t.slot == "flag")
    assert flag.status == "kept" and flag.vertices == 0
    assert flag.reason == "not worth meshing: (the rule's reason) (its region may bend, but no bone but its slot's is likely for its art)"
    assert flag.weights["meshed_to_bend"] is False and flag.weights["status"] == "skipped"
    assert doc["skins"][0]["attachments"]["flag"]["bar"] == region
    # the other mesh (not meshed to bend) stays a mesh, weighted over both bones
    bar = next(t for t in targets if t.slot == "bar")
    assert bar.status == "meshed" and "meshed_to_bend" not in bar.weights
    assert set(bar.weights["bones"]) == {"upper", "lower"}


def test_the_runtime_draws_the_bent_mesh_where_the_region_was_and_bends_it(spine_runtime, tmp_path):
    """Official runtime: in the setup pose the new weighted mesh draws where the region did
    (``compare.mjs``), and at ``bend`` the mesh curls with ``lower`` where the kept region cannot."""
    from runtime_tool import compare_dumps, node
    from test_weights_runtime import setup_dump

    project = make_bar_project(tmp_path / "p")
    for weights in ("none", "auto"):
        upgrade_project(project, tmp_path / weights, Options(weights=weights))
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    setup_dump(spine_runtime, project.parent / "bar.atlas", project, a)
    setup_dump(spine_runtime, tmp_path / "auto" / "bar.atlas", tmp_path / "auto" / "bar.json", b)
    ok, text = compare_dumps(spine_runtime, a, b)
    assert ok, text

    def spread(which: str) -> float:
        path = tmp_path / f"{which}-bend.json"
        r = node(spine_runtime, "dump.mjs", tmp_path / which / "bar.atlas", tmp_path / which / "bar.json",
                 "--out", path, "--poses", "bend@0.5")
        assert r.returncode == 0, r.stderr[-2000:]
        pose = json.loads(path.read_text())["poses"][1]
        bar = next(x for x in pose["attachments"] if x.get("slot") == "bar")
        return float(np.ptp(np.asarray(bar["vertices"]).reshape(-1, 2)[:, 1]))

    # the region is a rigid 40-unit-high quad on ``upper``; the mesh's far half turns 60 degrees up
    assert spread("none") == pytest.approx(HEIGHT, abs=0.1)
    assert spread("auto") > HEIGHT + 40


#: 4.2 example skeletons with regions that only bending gets meshed (from ``benchmarks/
#: bench_corpus_upgrade.py run --root .../4.2 --weights auto``), JSON and binary.
BENDING_EXAMPLES = ["windmill-ess.json", "windmill-ess.skel", "mix-and-match-pro.json", "mix-and-match-pro.skel"]


@pytest.mark.parametrize("name", BENDING_EXAMPLES)
def test_examples_meshed_to_bend_load_in_the_runtime_in_their_setup_pose(name, spine_runtime, tmp_path):
    """Official runtime, real examples: the skeletons with meshes made only to bend load, and in
    the setup pose every mesh draws where its region did (``compare.mjs``)."""
    from conftest import example_projects
    from runtime_tool import compare_dumps
    from test_weights_runtime import atlas_for, setup_dump

    found = [p / name for p in example_projects("4.2") if (p / name).is_file()]
    if not found:
        from conftest import unavailable

        unavailable(f"4.2 example {name} absent")
    skeleton = found[0]
    result = upgrade_project(skeleton, tmp_path / "auto", Options(weights="auto"))
    assert not result.errors and not [t for t in result.targets if t.status == "failed"]
    bent = [t for t in result.targets if t.weights and t.weights.get("meshed_to_bend")]
    assert bent, "no region meshed only because it bends"
    assert all(t.status == "meshed" and len(t.weights["bones"]) > 1 for t in bent)
    atlas = atlas_for(skeleton)
    a, b = tmp_path / "a.json", tmp_path / "b.json"
    setup_dump(spine_runtime, atlas, skeleton, a)
    setup_dump(spine_runtime, tmp_path / "auto" / atlas.relative_to(skeleton.parent), tmp_path / "auto" / name, b)
    ok, text = compare_dumps(spine_runtime, a, b)
    assert ok, text



def test_art_no_artist_weighted_gets_several_bones_only_where_another_is_likely():
    """The set stage, fitted on meshes artists chose to weight, binds the far-joint bar to its
    bone and the root (a point at its middle, 0.24 likely): as for art no artist weighted
    (``upgrade``, and ``weights`` on an unweighted mesh), only the slot's bone, and why."""
    from spinemesh.rig.document import build_rig
    from spinemesh.rig.learned import choose_learned
    from spinemesh.rig.upgraded_meshes import QUAD_TRIANGLES, BendingRegions

    doc = bar_skeleton(lower_x=1000.0)
    rig = build_rig(doc)
    ref = next(r for r in iter_attachments(doc) if r.slot == "bar")
    world = BendingRegions.of(rig).world(ref, np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float))
    names = [b.name for b in rig.bones]
    args = (rig.bones, names.index("upper"), world, QUAD_TRIANGLES, set(), rig.constrained)
    weighted = choose_learned(*args)
    assert len(weighted.bones) > 1
    unweighted = choose_learned(*args, unweighted=True)
    assert [names[b] for b in unweighted.bones] == ["upper"]
    assert "below the threshold 0.50" in unweighted.left_out[names.index("root")]
    # counted without reasons (the bending test before meshing): the same bones, either way
    for kind in ({}, {"unweighted": True}):
        bare = choose_learned(*args, **kind, explain=False)
        assert bare.bones == choose_learned(*args, **kind).bones and not bare.why and not bare.left_out


def test_a_rig_makes_each_learned_choice_once_and_afresh_for_another_model(monkeypatch):
    """The same art on the same slot bone (a region in two skins, say) is chosen for once per
    rig, the same bones and reasons each time, each a copy; other art, or another model swapped
    in, is chosen afresh."""
    from spinemesh.rig import document, learned
    from spinemesh.rig.document import build_rig
    from spinemesh.rig.upgraded_meshes import QUAD_TRIANGLES, QUAD_UV, BendingRegions, upgrade_choice

    made = []
    monkeypatch.setattr(document, "choose_learned", lambda *a, **k: made.append(1) or learned.choose_learned(*a, **k))
    doc = bar_skeleton()
    rig = build_rig(doc)
    ref = next(r for r in iter_attachments(doc) if r.slot == "bar")
    world = BendingRegions.of(rig).world(ref, QUAD_UV)
    first = upgrade_choice(rig, ref, world, QUAD_TRIANGLES)
    first.why.clear()  # a caller's changes stay its own
    again = upgrade_choice(rig, ref, world.copy(), QUAD_TRIANGLES)
    assert len(made) == 1 and again.why and again.bones == first.bones
    fresh = build_rig(doc)  # no choice remembered: the same answer made anew
    assert upgrade_choice(fresh, ref, world, QUAD_TRIANGLES).why == again.why and len(made) == 2
    upgrade_choice(rig, ref, world + 1.0, QUAD_TRIANGLES)
    upgrade_choice(rig, ref, world, QUAD_TRIANGLES, explain=False)
    assert len(made) == 4
    monkeypatch.setattr(learned, "_SHIPPED", [learned.TreeEnsemble.from_json(learned.shipped_model().to_json())])
    upgrade_choice(rig, ref, world, QUAD_TRIANGLES)
    assert len(made) == 5


def test_the_bending_prefilter_reaches_as_far_as_the_candidates_along_the_chain():
    """A region whose only bone within reach is its slot bone's child, farther out than the
    candidates' reach off the chain: the box test that skips the choice must not skip it."""
    from spinemesh.rig.document import build_rig
    from spinemesh.rig.learned import CHAIN_REACH, REACH
    from spinemesh.rig.upgraded_meshes import QUAD_TRIANGLES, QUAD_UV, BendingRegions, upgrade_choice

    doc = {"skeleton": {"spine": "4.2.22"},
           "bones": [{"name": "root"}, {"name": "arm", "parent": "root", "x": 1000, "length": 100},
                     {"name": "hand", "parent": "arm", "x": 140, "length": 20}],
           "slots": [{"name": "arm", "bone": "arm", "attachment": "arm"}],
           "skins": [{"name": "default", "attachments": {"arm": {"arm": {"x": 50, "width": 100, "height": 20}}}}]}
    gap = 40 / np.hypot(100, 20)  # the hand's distance from the art, share of its diagonal
    assert REACH < gap < CHAIN_REACH
    regions = BendingRegions.of(build_rig(doc))
    ref = next(iter_attachments(doc))
    choice = regions.choice(ref)
    assert choice is not None
    direct = upgrade_choice(regions.rig, ref, regions.world(ref, QUAD_UV), QUAD_TRIANGLES)
    assert (choice.bones, choice.why, choice.left_out) == (direct.bones, direct.why, direct.left_out)
    assert "hand" in {regions.rig.bones[i].name for i in {**choice.why, **choice.left_out}}


def _folder_bytes(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def _rows(result) -> list[dict]:
    return [{k: v for k, v in t.row().items() if k != "seconds"} for t in result.targets]


def test_meshes_weighted_on_the_workers_give_the_output_of_this_process_byte_for_byte(tmp_path, monkeypatch):
    """--weights auto with worker processes weights the meshes on them, a few per job: the
    output and the report are those of one process, byte for byte (a mesh weighted on a worker
    comes back to its own place in its document)."""
    import spinemesh.rig.upgraded_meshes as upgraded_meshes
    from conftest import example_projects

    project = next((p for p in example_projects("4.2") if p.name == "mix-and-match"), None)
    if project is None:
        from conftest import unavailable

        unavailable("4.2 example mix-and-match absent")
    monkeypatch.setattr(upgraded_meshes, "MESHES_PER_JOB", 3)  # many jobs, out of order
    calls = []
    monkeypatch.setattr(upgraded_meshes, "weighting_jobs",
                        lambda *a, f=upgraded_meshes.weighting_jobs: calls.append(1) or f(*a))
    skeleton = project / "mix-and-match-pro.json"
    here = upgrade_project(skeleton, tmp_path / "here", Options(weights="auto", jobs=1))
    apart = upgrade_project(skeleton, tmp_path / "apart", Options(weights="auto", jobs=2))
    assert not calls[1:], "one skeleton: its jobs made once, on the run with workers only"
    assert calls, "the run with workers did not weigh on them"
    weighted = [t for t in apart.targets if t.weights and t.weights["status"] == "weighted"]
    assert len(weighted) > upgraded_meshes.MESHES_PER_JOB, "too few meshes weighted to need several jobs"
    assert _rows(here) == _rows(apart)
    assert _folder_bytes(tmp_path / "here") == _folder_bytes(tmp_path / "apart")


def test_a_weighing_job_whose_worker_is_lost_is_weighted_here_the_same_way(tmp_path):
    """A lost worker costs time, not the output: its job's meshes are weighted in this process."""
    from concurrent.futures import Future

    from spinemesh.cluster import WorkerLost, Workers
    from spinemesh.upgrade.bending import settle_bending
    from spinemesh.upgrade.meshing import mesh_tasks
    from spinemesh.upgrade.apply import apply_project

    class LosingWorkers(Workers):
        """Runs each job through pickling, as a process would, but loses the first."""

        lost = 0

        def submit(self, fn, arg, first=False):
            import pickle

            future = Future()
            if not self.lost:
                self.lost += 1
                future.set_exception(WorkerLost("worker died"))
            else:
                future.set_result(fn(pickle.loads(pickle.dumps(arg))))
            return future

    project = find_project(make_bar_project(tmp_path / "p"))
    plans = []
    for workers in (None, LosingWorkers()):
        plan = plan_project(project, Options(weights="auto"), Result())
        meshes = mesh_tasks(plan.tasks, Workers())
        settle_bending(plan, meshes, Workers())  # the bending region meshed here: the weighing job is lost
        apply_project(plan, meshes, workers=workers)
        plans.append(plan)
        assert workers is None or workers.lost == 1
    (a,), (b,) = [[json.dumps(sk.doc) for sk in p.skeletons] for p in plans]
    assert a == b and '"type": "mesh"' in a
    assert _rows_of(plans[0]) == _rows_of(plans[1])


def _rows_of(plan) -> list[dict]:
    return [{k: v for k, v in t.row().items() if k != "seconds"} for sk in plan.skeletons for t in sk.targets]


def test_the_same_solve_twice_is_solved_once_and_the_output_is_that_of_solving_each(tmp_path, monkeypatch):
    """One region in two skins is the same art on the same bones: its weights are solved once
    (solve_weights_once), and the output is the same byte for byte as when every mesh is solved
    on its own (nothing remembered)."""
    from spinemesh.rig import weights as rig_weights

    path = make_bar_project(tmp_path / "p")
    doc = json.loads(path.read_text())
    doc["skins"].append({"name": "other", "attachments": {"bar": copy.deepcopy(doc["skins"][0]["attachments"]["bar"])}})
    path.write_text(json.dumps(doc, indent=1))
    solved = []
    monkeypatch.setattr(rig_weights, "solve_weights", lambda *a, f=rig_weights.solve_weights: solved.append(1) or f(*a))
    outputs = {}
    for remembered in (rig_weights.REMEMBERED_SOLVES, 0):
        monkeypatch.setattr(rig_weights, "REMEMBERED_SOLVES", remembered)
        rig_weights._remembered.clear()
        solved.clear()
        result = upgrade_project(path, tmp_path / f"out{remembered}", Options(weights="auto", jobs=1))
        bent = [t for t in result.targets if t.slot == "bar"]
        assert [t.weights["status"] for t in bent] == ["weighted", "weighted"]
        assert len(bent[0].weights["bones"]) == 2
        outputs[remembered] = (_folder_bytes(tmp_path / f"out{remembered}"), _rows(result), len(solved))
    (once, rows_once, solves_once), (each, rows_each, solves_each) = outputs.values()
    assert solves_once < solves_each and once == each and rows_once == rows_each


def _weighted_worm_and_bar(folder: Path, tmp_path: Path) -> Path:
    """A project of two skeletons: the worm of ``rig_project`` as ``--weights auto`` left it (a
    mesh weighted over its chain, whose habits the learned choice reads) and the bar project."""
    import shutil

    from rig_project import make_worm_project

    upgrade_project(make_worm_project(tmp_path / "worm"), tmp_path / "worm-out", Options(weights="auto", jobs=1))
    shutil.copytree(tmp_path / "worm-out", folder)
    make_bar_project(tmp_path / "bar")
    for name in ("bar.json", "bar.atlas", "bar.png"):
        shutil.copy(tmp_path / "bar" / name, folder / name)
    return folder


def test_the_habits_read_on_worker_processes_are_those_read_here(tmp_path):
    """start_habits hands each skeleton's part of the project's habits to the workers: put
    together they are the habits this process reads, and a part whose worker was lost is read here."""
    from concurrent.futures import Future
    from types import SimpleNamespace

    from spinemesh.cluster import WorkerLost, Workers, open_workers
    from spinemesh.rig.document import build_rig
    from spinemesh.rig.learned import project_habits
    from spinemesh.upgrade.bending import gather_habits, start_habits

    class LosingWorkers(Workers):
        def submit(self, fn, arg, first=False):
            future = Future()
            future.set_exception(WorkerLost("worker died"))
            return future

    folder = _weighted_worm_and_bar(tmp_path / "p", tmp_path)
    docs = [json.loads((folder / name).read_text()) for name in ("worm.json", "bar.json", "worm.json")]
    expected = project_habits([(doc, build_rig(doc)) for doc in docs])
    assert len(expected.keys) == 2  # the worm's mesh, twice
    with open_workers(2) as processes:
        for workers in (None, Workers(), processes, LosingWorkers()):
            skeletons = [SimpleNamespace(doc=doc, rig=build_rig(doc)) for doc in docs]
            plan = SimpleNamespace(habits=start_habits(skeletons, workers), skeletons=skeletons)
            gather_habits(plan)
            habits = plan.habits
            assert all(sk.rig.habits is habits for sk in skeletons)
            assert np.array_equal(habits.tallies, expected.tallies) and habits.tallies.dtype == expected.tallies.dtype
            assert (habits.keys, habits.bound) == (expected.keys, expected.bound)


def test_auto_on_workers_gives_the_output_of_this_process_for_a_project_and_a_library(tmp_path, monkeypatch):
    """The habits read and the regions tested for bending on worker processes (a project, and a
    library of projects planned ahead while others mesh): the output and the report of one
    process, byte for byte. The regions are tested as their meshes arrive: none is left for
    settle_bending to test, and the bending tasks are already sent."""
    import shutil

    from spinemesh.upgrade import apply, upgrade_library

    settled = []

    def settle(plan, *a, f=apply.settle_bending, **k):
        if plan.bending is not None:
            settled.append((len(plan.bending.waiting), len(plan.bending.tasks)))
        return f(plan, *a, **k)

    monkeypatch.setattr(apply, "settle_bending", settle)  # where the apply stage calls it
    library = tmp_path / "lib"
    _weighted_worm_and_bar(library / "both", tmp_path)
    _bar_and_half_project(library / "half")
    shutil.copytree(library / "half", library / "half-again")
    settled.clear()  # the worm's own upgrade
    outputs = {}
    for jobs in (1, 2):
        project = upgrade_project(library / "both", tmp_path / f"project{jobs}", Options(weights="auto", jobs=jobs))
        whole = upgrade_library(library, tmp_path / f"library{jobs}", Options(weights="auto", jobs=jobs))
        outputs[jobs] = (_folder_bytes(tmp_path / f"project{jobs}"), _rows(project),
                         _folder_bytes(tmp_path / f"library{jobs}"), _rows(whole))
    assert outputs[1] == outputs[2]
    # per run: the project (bar bends), then the library's three projects (both, half, half-again)
    assert settled == [(0, 1), (0, 1), (0, 1), (0, 1)] * 2
    rows = {(t.skeleton, t.slot): t for t in upgrade_library(library, tmp_path / "again", Options(weights="auto")).targets}
    assert rows[("both/bar.json", "bar")].weights["meshed_to_bend"]
    assert rows[("half/bar.json", "half")].status == "meshed" and len(rows[("half/bar.json", "half")].weights["bones"]) == 2


def test_a_mesh_whose_weighting_fails_after_vertices_were_added_is_as_it_was(tmp_path, monkeypatch):
    """The weighting keeps a shallow copy of each attachment to put back: vertices added for its
    bones, then a failure, leave the attachment and every list of the document as they were
    (the lists are replaced, never changed in place)."""
    from spinemesh.errors import SpineMeshError
    from spinemesh.rig import upgraded_meshes as upgraded_meshes

    project = make_bar_project(tmp_path / "p")
    result = upgrade_project(project, tmp_path / "meshed", Options(weights="none", min_saving=None))
    doc = json.loads((tmp_path / "meshed" / "bar.json").read_text())
    lists = {id(v): (v, copy.deepcopy(v)) for ref in iter_attachments(doc) for v in ref.attachment.values()
             if isinstance(v, (list, dict))}
    before = copy.deepcopy(doc)
    grown = []

    def failing(rig, ref, options, outcome, choice=None):
        grown.append(len(ref.attachment["uvs"]) > len(next(
            r.attachment for r in iter_attachments(before) if (r.slot, r.name) == (ref.slot, ref.name))["uvs"]))
        raise SpineMeshError("a failure after the vertices were added")

    monkeypatch.setattr(upgraded_meshes, "weight_mesh", failing)
    targets = [t for t in result.targets if t.status == "meshed"]
    upgraded_meshes.weight_upgraded(doc, targets)
    assert any(grown), "no vertices were added: the test proves nothing"
    assert all(t.weights["status"] == "failed" and t.weights["added_vertices"] == 0 for t in targets)
    assert doc == before
    assert all(value == kept for value, kept in lists.values())
