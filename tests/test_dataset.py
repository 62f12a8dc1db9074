"""`spinemesh dataset`: extracted images equal the 4.2 originals, meshes equal the artists' UVs,
no duplicates, splits by game, broken projects skipped, re-runs add nothing."""

from __future__ import annotations

import json
import shutil
from collections import defaultdict
from pathlib import Path

import cv2
import numpy as np
import pytest
from typer.testing import CliRunner

from spinemesh.atlas import read_atlas
from spinemesh.cli import app
from spinemesh.dataset import build_dataset, content_id, find_projects, open_dataset, split_of
from spinemesh.dataset.format import INDEX, PROJECTS
from spinemesh.images.decode import load_rgba
from spinemesh.images.texels import premultiply
from spinemesh.skeleton import image_paths, iter_attachments, load_skeleton


def _broken_corpus(tmp: Path, examples: Path) -> Path:
    """A corpus with one project whose skeletons are corrupted (a copy of 4.2/coin)."""
    broken = tmp / "broken-corpus" / "coin-broken"
    shutil.copytree(examples / "4.2" / "coin", broken)
    for p in broken.iterdir():
        p.chmod(0o644)
    for p in broken.glob("*.json"):
        p.write_bytes(p.read_bytes()[: p.stat().st_size // 2])
    for p in broken.glob("*.skel"):
        p.write_bytes(p.read_bytes()[:100])
    return broken.parent


@pytest.fixture(scope="module")
def built(examples, tmp_path_factory):
    """All 4.2 examples plus one corrupted project, built with two workers."""
    tmp = tmp_path_factory.mktemp("ds")
    broken = _broken_corpus(tmp, examples)
    out = tmp / "ds"
    summary = build_dataset([examples / "4.2", broken], out, jobs=2)
    return out, summary, examples


def _rows(out: Path) -> list[dict]:
    return list(open_dataset(out).rows())


def test_every_project_but_the_broken_one_yields_samples(built):
    out, summary, examples = built
    projects = {p["project"]: p for p in open_dataset(out).projects()}
    broken = projects.pop("broken-corpus/coin-broken")
    assert broken["samples_added"] == 0 and broken["errors"]
    assert any("invalid JSON" in e for e in broken["errors"])
    assert set(projects) == {f"4.2/{p.name}" for p in (examples / "4.2").iterdir() if p.is_dir()}
    by_project = defaultdict(int)
    for row in _rows(out):
        by_project[row["project"]] += 1
    # spinosaurus draws no image of its own; every other project gives samples.
    assert {p for p in projects if by_project[p] == 0} <= {"4.2/spinosaurus"}
    assert summary.samples == sum(by_project.values()) > 700
    assert summary.by_type["mesh"] > 250 and summary.by_type["region"] > 300


def test_images_match_the_original_images(built):
    """Same criteria as the atlas tests: exact at scale 1, +-1 premultiplied for pma,
    IoU of alpha > 128 against the resized original for scaled atlases."""
    out, _, examples = built
    ds = open_dataset(out)
    atlases = {}
    exact = pma = 0
    ious = []
    for row in ds.rows():
        folder = examples / row["project"]
        orig = load_rgba(folder / "images" / (row["name"] + ".png"))
        got = ds.load_image(row)
        src = folder / row["source"]
        if src.suffix == ".atlas":
            atlas = atlases.setdefault(src, read_atlas(src))
            page = atlas.pages[atlas.find(row["name"]).page]
            is_pma, scale = page.pma, page.scale
        else:
            is_pma, scale = False, 1.0
        assert row["scale"] == scale
        assert got.shape == (row["height"], row["width"], 4)
        if scale == 1 and not is_pma:
            assert got.shape == orig.shape, row["name"]
            assert np.array_equal(got[..., 3], orig[..., 3]), row["name"]
            seen = orig[..., 3] > 0
            assert np.array_equal(got[..., :3][seen], orig[..., :3][seen]), row["name"]
            exact += 1
        elif scale == 1:
            assert np.abs(premultiply(got).astype(int) - premultiply(orig).astype(int)).max() <= 1
            pma += 1
        else:
            resized = cv2.resize(orig, (got.shape[1], got.shape[0]), interpolation=cv2.INTER_AREA)
            a, b = got[..., 3] > 128, resized[..., 3] > 128
            union = (a | b).sum()
            ious.append((a & b).sum() / union if union else 1.0)  # shadows: no alpha > 128 at all
    assert exact > 100 and exact + pma > 700
    # Every 4.2 example keeps its originals in images/: a downscaled atlas (raptor, at 0.5)
    # is never read where that folder holds the image.
    assert not ious, f"{len(ious)} samples cut from a downscaled atlas"


def test_masks_are_alpha_above_128(built):
    out, _, _ = built
    ds = open_dataset(out)
    for row in list(ds.rows())[::7]:
        assert np.array_equal(ds.load_mask(row), ds.load_image(row)[..., 3] > 128)


def test_mesh_vertices_are_the_artists_uvs_times_image_size(built):
    out, _, examples = built
    ds = open_dataset(out)
    docs = {}
    checked = 0
    for row in ds.rows():
        mesh = ds.load_mesh(row)
        if row["type"] == "region":
            assert mesh is None and row["n_vertices"] == 0
            continue
        assert len(mesh["vertices"]) == row["n_vertices"] > 0
        if row["attachment"] != "mesh":
            continue
        path = examples / row["project"] / row["skeleton"]
        doc = docs.setdefault(path, load_skeleton(path))
        att = next(r.attachment for r in iter_attachments(doc) if [r.skin, r.slot, r.name] == row["ref"])
        uvs = np.asarray(att["uvs"], float).reshape(-1, 2)
        np.testing.assert_allclose(mesh["vertices"], uvs * (row["width"], row["height"]), atol=1e-3)
        assert mesh["triangles"].ravel().tolist() == att["triangles"]
        assert mesh["hull"].tolist() == list(range(att["hull"]))
        assert (mesh["edges"].ravel() * 2).tolist() == att.get("edges", [])
        w, h = row["width"], row["height"]
        assert (mesh["vertices"] >= -1).all() and (mesh["vertices"] <= (w + 1, h + 1)).all()
        checked += 1
    assert checked > 250


def test_no_duplicate_content_and_ids_are_content_hashes(built):
    out, _, _ = built
    ds = open_dataset(out)
    rows = list(ds.rows())
    assert len({r["id"] for r in rows}) == len(rows)
    for row in rows[::5]:
        assert content_id(ds.load_image(row)) == row["id"]


def test_splits_keep_each_game_on_one_side(built):
    out, _, _ = built
    sides = defaultdict(set)
    for row in _rows(out):
        sides[row["game"]].add(row["split"])
        assert row["split"] == split_of(row["game"])
    assert all(len(s) == 1 for s in sides.values())
    val = [g for g, s in sides.items() if s == {"val"}]
    assert 0 < len(val) < len(sides) / 2


def test_rerun_adds_nothing_and_retries_broken_projects(built):
    out, _, examples = built
    before = (out / INDEX).read_bytes()
    again = build_dataset([examples / "4.2", out.parent / "broken-corpus"], out, jobs=1)
    assert again.samples == 0 and again.projects == 0
    retried = build_dataset([examples / "4.2", out.parent / "broken-corpus"], out, retry_failed=True)
    assert retried.samples == 0 and retried.projects >= 1
    assert (out / INDEX).read_bytes() == before


def test_a_killed_run_resumes_cleanly(examples, tmp_path):
    out = tmp_path / "ds"
    corpus = examples / "4.2"
    build_dataset([corpus / "coin", corpus / "owl"], out)
    rows = _rows(out)
    # As if killed while appending: a torn index row, and the last project not marked done.
    with open(out / INDEX, "ab") as f:
        f.write(b'{"id": "torn')
    (out / "shards" / ".half-written.tar.tmp").write_bytes(b"x" * 700)
    lines = (out / PROJECTS).read_bytes().splitlines(keepends=True)
    (out / PROJECTS).write_bytes(b"".join(lines[:-1]))
    again = build_dataset([corpus / "coin", corpus / "owl"], out)
    assert again.samples == 0 and again.projects == 1
    assert _rows(out) == rows
    assert not list((out / "shards").glob("*.tmp"))
    assert all(line.endswith(b"\n") for line in (out / INDEX).read_bytes().splitlines(keepends=True))


def test_binary_skeletons_give_the_same_samples_as_json(examples, tmp_path):
    proj = tmp_path / "skel-only" / "spineboy"
    proj.mkdir(parents=True)
    src = examples / "4.2" / "spineboy"
    for p in list(src.glob("*.skel")) + list(src.glob("*.atlas")) + list(src.glob("*.png")):
        shutil.copy(p, proj / p.name)
    # The same image sources on both sides (originals beside a downscaled atlas are preferred).
    shutil.copytree(src / "images", proj / "images")
    build_dataset([proj.parent], tmp_path / "a")
    build_dataset([src], tmp_path / "b")
    a, b = _rows(tmp_path / "a"), _rows(tmp_path / "b")
    assert len(a) > 30
    assert {r["id"] for r in a} == {r["id"] for r in b}


def test_projects_are_found_at_any_depth(examples):
    found = find_projects(examples)
    assert examples / "4.2" / "spineboy" in found and examples / "3.6" / "spineboy" in found
    assert not any(p.parent in found for p in found)


def test_cli_dataset_and_stats(examples, tmp_path):
    out = tmp_path / "ds"
    r = CliRunner().invoke(app, ["dataset", str(examples / "4.2" / "owl"), "--out", str(out), "-j", "1"])
    assert r.exit_code == 0, r.output
    assert "new samples" in r.output and "region" in r.output
    # One game: one side of the split is empty, and the run says so.
    assert "warning: no game" in r.output
    r = CliRunner().invoke(app, ["dataset", str(examples / "4.2" / "owl"), "--out", str(out), "-j", "1"])
    assert r.exit_code == 0, r.output
    n = sum(1 for _ in open_dataset(out).rows())
    assert "nothing new" in r.output and f"{n:,} samples" in r.output
    r = CliRunner().invoke(app, ["dataset-stats", str(out)])
    assert r.exit_code == 0, r.output
    n = sum(1 for _ in open_dataset(out).rows())
    assert f"{n:,} samples" in r.output
    for name in ("samples_per_game", "type_share", "vertex_counts", "image_sizes"):
        data = (out / "stats" / f"{name}.png").read_bytes()
        assert data.startswith(b"\x89PNG") and len(data) > 5000


def test_not_a_dataset_is_a_clear_error(tmp_path):
    from spinemesh.errors import SpineMeshError

    with pytest.raises(SpineMeshError, match="meta.json"):
        open_dataset(tmp_path)
    (tmp_path / "meta.json").write_text(json.dumps({"format": "other"}))
    with pytest.raises(SpineMeshError, match="unsupported"):
        open_dataset(tmp_path)


def test_sequence_frames_are_expanded(built):
    out, _, _ = built
    names = {r["name"] for r in _rows(out) if r["project"] == "4.2/dragon"}
    assert {f"left-wing{i:02d}" for i in range(1, 10)} <= names
    assert {f"right-wing{i:02d}" for i in range(1, 10)} <= names


def test_a_game_with_only_a_3_8_binary_skeleton(corpus, tmp_path):
    """bmyq-bigwin ships a 3.8 .skel and no JSON; its meshes come out in pixels."""
    s = build_dataset([corpus / "bmyq-bigwin"], tmp_path / "ds")
    rows = _rows(tmp_path / "ds")
    assert s.samples == len(rows) > 10 and not s.errors
    assert {r["version"] for r in rows} == {"3.8.99"}
    assert {r["game"] for r in rows} == {"igs-jackhung/baimayinqiang-demo-spine"}
    # 49 mesh attachments draw 3 images, 993 regions 27 more: one sample per image.
    doc = load_skeleton(corpus / "bmyq-bigwin" / "BinWin_Omen.skel")
    drawn = defaultdict(set)
    for ref in iter_attachments(doc):
        for p in image_paths(ref):
            drawn[p].add(ref.type)
    meshes = [r for r in rows if r["type"] == "mesh"]
    assert sorted(r["name"] for r in meshes) == sorted(p for p, t in drawn.items() if "mesh" in t)
    assert len(rows) <= len(drawn)
    ds = open_dataset(tmp_path / "ds")
    for r in meshes:
        v = ds.load_mesh(r)["vertices"]
        assert (v >= -1).all() and (v <= (r["width"] + 1, r["height"] + 1)).all()


def test_shard_offsets_are_where_a_tar_reader_finds_each_member(tmp_path):
    import tarfile

    from spinemesh.dataset.format import write_shard

    members = [(f"{i:032x}.png", bytes(range(256)) * i + b"x" * (i % 7)) for i in range(6)]
    offsets = write_shard(tmp_path / "s.tar", members)
    with tarfile.open(tmp_path / "s.tar") as tar:
        assert offsets == {m.name: (m.offset_data, m.size) for m in tar.getmembers()}
    data = (tmp_path / "s.tar").read_bytes()
    for name, payload in members:
        start, size = offsets[name]
        assert data[start:start + size] == payload
