"""``spinemesh upgrade``: geometry with known answers, options, failures and file safety."""

from __future__ import annotations

import hashlib
import json
import math
import os
import subprocess
import sys

import numpy as np
import pytest

from spinemesh.demo import make_demo_project
from spinemesh.errors import SpineMeshError
from spinemesh.skeleton import iter_attachments, load_skeleton
from spinemesh.upgrade import Options, mesh_attachment, region_quad_transform, upgrade_project
from spinemesh.attachment_geometry import spine_triangles


@pytest.fixture()
def demo(tmp_path):
    return make_demo_project(tmp_path / "demo")


def _tree_digest(folder):
    h = hashlib.sha256()
    for p in sorted(folder.rglob("*")):
        if p.is_file():
            h.update(str(p.relative_to(folder)).encode() + p.read_bytes())
    return h.hexdigest()


def test_quad_transform_known_answer():
    region = {"x": 10, "y": 20, "rotation": 90, "width": 100, "height": 50}
    a = region_quad_transform(region)
    # The image's top-left (u, v) = (0, 0) is at local (-50, 25); turned 90 degrees: (-25, -50).
    assert np.allclose(a @ [0, 0, 1], [10 - 25, 20 - 50])
    assert np.allclose(a @ [0.5, 0.5, 1], [10, 20])
    scaled = region_quad_transform({"scaleX": 2, "scaleY": -1, "width": 10, "height": 10})
    assert np.allclose(scaled @ [1, 1, 1], [10, 5])


def test_mesh_attachment_keeps_fields_and_places_vertices_on_the_quad():
    region = {"name": "n", "path": "p", "color": "ff0000ff", "x": 3, "rotation": 30, "scaleX": 1.5,
              "width": 40, "height": 20, "sequence": {"count": 2}}
    verts = np.array([[0, 0], [40, 0], [40, 20], [0, 20], [20, 10]], float)
    tris = spine_triangles(verts, 4, np.zeros((0, 2), int))
    mesh = mesh_attachment(region, verts, tris, 4, np.array([[0, 4]]), 40, 20)
    assert list(mesh) == ["name", "type", "path", "color", "uvs", "triangles", "vertices", "hull",
                          "sequence", "edges", "width", "height"]
    assert mesh["type"] == "mesh" and mesh["hull"] == 4 and mesh["edges"] == [0, 8]
    assert mesh["uvs"][:4] == [0, 0, 1, 0] and mesh["uvs"][8:] == [0.5, 0.5]
    pos = np.array(mesh["vertices"]).reshape(-1, 2)
    c, s = math.cos(math.radians(30)), math.sin(math.radians(30))
    corner = np.array([-0.5 * 40 * 1.5, 0.5 * 20])  # uv (0, 0)
    assert np.allclose(pos[0], [c * corner[0] - s * corner[1] + 3, s * corner[0] + c * corner[1]], atol=1e-3)
    assert np.allclose(pos[4], [3, 0], atol=1e-3)


def test_full_triangulation_count_and_filled_hole():
    ring = [[0, 0], [10, 0], [10, 10], [0, 10]]
    hole = [[4, 4], [6, 4], [6, 6], [4, 6]]
    verts = np.array(ring + hole, float)
    hole_edges = np.array([[4, 5], [5, 6], [6, 7], [7, 4]])
    tris = spine_triangles(verts, 4, hole_edges)
    assert len(tris) == 2 * 8 - 4 - 2
    assert spine_triangles(np.array(ring + [[20, 20]], float), 4, np.zeros((0, 2), int)) is None


def test_demo_upgrade_json_and_skel(demo, tmp_path):
    before = _tree_digest(demo)
    out = tmp_path / "out"
    result = upgrade_project(demo, out, Options())
    assert not result.partial, [(t.name, t.reason) for t in result.targets if t.status == "failed"]
    assert {(t.name, t.reason.split(":")[0]) for t in result.targets if t.status == "kept"} == {
        ("demo-arm", "not worth meshing")}
    assert _tree_digest(demo) == before, "the input was modified"
    assert {"demo.json", "demo-binary.skel", "demo.atlas", "demo.png"} <= {p.name for p in out.iterdir()}
    for name in ("demo.json", "demo-binary.skel"):
        doc = load_skeleton(out / name)
        types = {r.name: r.attachment for r in iter_attachments(doc)}
        # the arm is a plain rectangle: a mesh cannot draw fewer pixels, so it stays a region
        assert types.pop("demo-arm").get("type", "region") == "region", name
        assert all(a["type"] == "mesh" for a in types.values()), name
        spark = types["spark"]
        assert spark["sequence"]["count"] == 3 and spark["path"] == "demo-spark/frame"
        for att in types.values():
            n = len(att["uvs"]) // 2
            assert len(att["triangles"]) // 3 == 2 * n - att["hull"] - 2
            assert all(0 <= u <= 1 for u in att["uvs"])
    # Everything but the attachments is unchanged.
    a = json.loads((demo / "demo.json").read_text())
    b = json.loads((out / "demo.json").read_text())
    assert {k: v for k, v in a.items() if k != "skins"} == {k: v for k, v in b.items() if k != "skins"}


def test_sequence_mesh_covers_every_frame(demo, tmp_path):
    from spinemesh.images.sources import FolderImages
    from spinemesh.metrics import coverage, opaque_mask

    out = tmp_path / "out"
    upgrade_project(demo, out, Options())
    spark = next(r.attachment for r in iter_attachments(load_skeleton(out / "demo.json")) if r.name == "spark")
    uv = np.array(spark["uvs"]).reshape(-1, 2)
    tris = np.array(spark["triangles"]).reshape(-1, 3)
    for frame in ("demo-spark/frame1", "demo-spark/frame2", "demo-spark/frame3"):
        rgba = FolderImages(demo / "images").get(frame).rgba
        px = uv * (rgba.shape[1], rgba.shape[0])
        assert coverage(px, tris, opaque_mask(rgba)) == 1.0, frame


def test_options_only_exclude_min_size_dry_run(demo, tmp_path):
    r = upgrade_project(demo, tmp_path / "a", Options(only=["ring"], dry_run=True))
    status = {(t.skeleton, t.name): t.status for t in r.targets}
    assert status[("demo.json", "demo-ring")] == "would mesh"
    assert status[("demo.json", "demo-head")] == "kept"
    assert not (tmp_path / "a").exists(), "a dry run writes nothing"
    r = upgrade_project(demo, tmp_path / "b", Options(exclude=["demo-spark/*"], min_size=95))
    reasons = {t.name: t.reason for t in r.targets if t.skeleton == "demo.json"}
    assert "exclude" in reasons["spark"] and "min-size" in reasons["demo-head"] and reasons["demo-body"] == ""


def test_missing_image_is_reported_and_left_a_region(demo, tmp_path):
    doc = json.loads((demo / "demo.json").read_text())
    doc["skins"][0]["attachments"]["head"]["ghost"] = {"width": 10, "height": 10}
    (demo / "demo.json").write_text(json.dumps(doc))
    out = tmp_path / "out"
    r = subprocess.run([sys.executable, "-m", "spinemesh", "upgrade", str(demo), "--out", str(out),
                        "--report", str(tmp_path / "report.json")], capture_output=True, text=True,
                       env=dict(os.environ, COLUMNS="200"))
    assert r.returncode == 3, r.stderr
    assert "Traceback" not in r.stderr and "ghost" in r.stderr
    rows = json.loads((tmp_path / "report.json").read_text())["attachments"]
    ghost = next(t for t in rows if t["name"] == "ghost" and t["skeleton"] == "demo.json")
    assert ghost["status"] == "failed" and "ghost" in ghost["reason"]
    meshed = [t for t in rows if t["status"] == "meshed"]
    assert meshed and all(t["coverage"] == 1.0 and t["vertices"] > 3 for t in meshed)
    kept = json.loads((out / "demo.json").read_text())["skins"][0]["attachments"]["head"]["ghost"]
    assert "type" not in kept  # still a region


def test_output_inside_the_project_is_refused(demo):
    with pytest.raises(SpineMeshError, match="inside the input"):
        upgrade_project(demo, demo / "out", Options())
    with pytest.raises(SpineMeshError):
        upgrade_project(demo, demo, Options())


def test_jobs_give_the_same_result(demo, tmp_path):
    upgrade_project(demo, tmp_path / "one", Options(jobs=1))
    upgrade_project(demo, tmp_path / "two", Options(jobs=2))
    assert (tmp_path / "one/demo.json").read_bytes() == (tmp_path / "two/demo.json").read_bytes()
    assert (tmp_path / "one/demo-binary.skel").read_bytes() == (tmp_path / "two/demo-binary.skel").read_bytes()


def test_mesh_cache_meshes_each_image_once(demo, tmp_path, monkeypatch):
    import spinemesh.upgrade.meshing as run

    cache = {}
    upgrade_project(demo, tmp_path / "one", Options(), mesh_cache=cache)
    assert cache

    def no_meshing(item):
        raise AssertionError(f"meshed again: {item.key}")

    monkeypatch.setattr(run, "mesh_one", no_meshing)
    upgrade_project(demo, tmp_path / "two", Options(), mesh_cache=cache)
    assert (tmp_path / "one/demo.json").read_bytes() == (tmp_path / "two/demo.json").read_bytes()
    with pytest.raises(AssertionError, match="meshed again"):  # other settings are other meshes
        upgrade_project(demo, tmp_path / "three", Options(preset="paper"), mesh_cache=cache)


def test_images_folder_written_for_the_editor(demo, tmp_path):
    upgrade_project(demo, tmp_path / "out", Options(images_out=tmp_path / "img"))
    assert (tmp_path / "img/demo-body.png").exists() and (tmp_path / "img/demo-spark/frame3.png").exists()


def test_real_skel_in_skel_out(examples, tmp_path):
    r = upgrade_project(examples / "4.2/spineboy/spineboy-ess.skel", tmp_path / "out", Options())
    assert not r.partial
    doc = load_skeleton(tmp_path / "out/spineboy-ess.skel")
    types = [a.type for a in iter_attachments(doc)]
    assert types.count("mesh") == 26 and "region" not in types


@pytest.mark.parametrize("which", ["demo", "4.2/coin"])
def test_same_bytes_from_two_separate_processes(which, demo, tmp_path, request):
    """Determinism across processes: other hash seeds, one run with worker processes, same bytes."""
    project = demo if which == "demo" else request.getfixturevalue("examples") / which
    digests = []
    for seed, jobs in (("1", "1"), ("2", "2")):
        out = tmp_path / f"run-{seed}"
        r = subprocess.run([sys.executable, "-m", "spinemesh", "upgrade", str(project), "--out", str(out),
                            "--jobs", jobs], capture_output=True, text=True,
                           env=dict(os.environ, PYTHONHASHSEED=seed, COLUMNS="200"))
        assert r.returncode == 0, r.stderr
        digests.append(_tree_digest(out))
    assert digests[0] == digests[1]


def test_a_folder_of_projects_is_mirrored_with_one_report(tmp_path):
    """``upgrade LIBRARY --out OUT``: every project lands at its own path under OUT; one report."""
    from spinemesh.upgrade import is_library, upgrade_library, write_report

    library = tmp_path / "library"
    make_demo_project(library / "heroes" / "knight")
    make_demo_project(library / "props")
    (library / "notes.txt").write_text("not a project")
    assert is_library(library) and not is_library(library / "props")
    out = tmp_path / "out"
    result = upgrade_library(library, out, Options(jobs=2))
    assert not result.partial, result.errors
    assert {"heroes/knight/demo.json", "heroes/knight/demo-binary.skel", "props/demo.json"} <= set(result.written)
    for project in ("heroes/knight", "props"):
        assert (out / project / "demo.atlas").is_file()
        one = upgrade_project(library / project, tmp_path / "alone" / project, Options())
        assert not one.partial
        assert (out / project / "demo.json").read_bytes() == (tmp_path / "alone" / project / "demo.json").read_bytes()
    assert not (out / "notes.txt").exists()  # files outside every project are not copied
    write_report(result, tmp_path / "report.json")
    rows = json.loads((tmp_path / "report.json").read_text())["attachments"]
    assert {r["skeleton"].rsplit("/", 1)[0] for r in rows} == {"heroes/knight", "props"}


def test_a_library_run_decodes_pages_on_its_workers_and_leaves_no_memory_behind(tmp_path, monkeypatch):
    """With local workers the pages are decoded by them (this process decodes none but a page
    that fails there, to report its own error), the output is that of one process, and no
    memory of theirs is left, after a run or after one stopped by Ctrl-C."""
    from conftest import memory_files_left, shared_memory_segments
    from spinemesh.images import decode
    from spinemesh.upgrade import upgrade_library
    from spinemesh.upgrade.progress import Progress

    library = tmp_path / "library"
    for name in ("a", "b", "c"):
        make_demo_project(library / name)
    (library / "c" / "demo.png").write_bytes(b"\x89PNG\r\n\x1a\n not a page")
    shm = shared_memory_segments()
    here, parent, real = [], os.getpid(), decode.load_rgba
    monkeypatch.setattr(decode, "load_rgba", lambda path: (os.getpid() == parent and here.append(path)) or real(path))
    alone = upgrade_library(library, tmp_path / "alone", Options())
    decoded_alone, here[:] = list(here), []
    result = upgrade_library(library, tmp_path / "workers", Options(jobs=2))
    assert _tree_digest(tmp_path / "workers") == _tree_digest(tmp_path / "alone")
    assert result.errors == alone.errors and [t.reason for t in result.targets] == [t.reason for t in alone.targets]
    assert any("cannot decode image" in t.reason for t in result.targets)
    # the bad page is tried once per region drawn from it, with workers or not; the others never here
    assert here == [p for p in decoded_alone if p.parent.name == "c"] and len(decoded_alone) > len(here) > 0
    assert memory_files_left() == [] and shared_memory_segments() == shm

    class CtrlC(Progress):
        """Ctrl-C as the second project is read: the first one's pages are decoding or decoded."""
        reads = 0

        def add(self, phase, steps, project=None):
            self.reads += phase == "read"
            if self.reads == 2:
                raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        upgrade_library(library, tmp_path / "stopped", Options(jobs=2), progress=CtrlC())
    assert memory_files_left() == [] and shared_memory_segments() == shm


def test_one_projects_pages_are_decoded_by_the_workers_that_mesh_it(tmp_path, monkeypatch):
    """``upgrade project/ --jobs 2`` opens its workers before planning, and they decode the
    pages (two skeletons, each on a page of its own) while this process plans: none is
    decoded here, and the output is that of one process."""
    import shutil

    from conftest import memory_files_left
    from spinemesh.images import decode

    project = tmp_path / "project"
    make_demo_project(project, with_images_folder=False)
    shutil.copy(project / "demo.png", project / "demo2.png")
    shutil.copy(project / "demo.json", project / "demo2.json")
    (project / "demo2.atlas").write_text((project / "demo.atlas").read_text().replace("demo.png", "demo2.png"))
    here, parent, real = [], os.getpid(), decode.load_rgba
    monkeypatch.setattr(decode, "load_rgba", lambda path: (os.getpid() == parent and here.append(path)) or real(path))
    alone = upgrade_project(project, tmp_path / "alone", Options())
    assert sorted(p.name for p in set(here)) == ["demo.png", "demo2.png"]  # without workers: here
    here[:] = []
    result = upgrade_project(project, tmp_path / "workers", Options(jobs=2))
    assert here == []
    assert _tree_digest(tmp_path / "workers") == _tree_digest(tmp_path / "alone")
    assert [(t.status, t.reason) for t in result.targets] == [(t.status, t.reason) for t in alone.targets]
    assert sum(t.status == "meshed" for t in result.targets) > 0
    assert memory_files_left() == []
