"""Project discovery and the choice of atlases for each skeleton."""

from __future__ import annotations

from spinemesh.images.sources import AtlasImages, FolderImages
from spinemesh.project import find_project, image_source_for, needed_images
from spinemesh.skeleton import load_skeleton


def test_find_project_folder(examples):
    proj = find_project(examples / "4.2/spineboy")
    names = sorted(p.name for p in proj.skeletons)
    assert names == ["spineboy-ess.json", "spineboy-ess.skel", "spineboy-pro.json", "spineboy-pro.skel"]
    assert sorted(p.name for p in proj.atlases) == ["spineboy-pma.atlas", "spineboy-run.atlas", "spineboy.atlas"]
    assert [p.name for p in proj.image_folders] == ["images"]


def test_atlas_choice_prefers_straight_alpha_and_full_coverage(examples):
    path = examples / "4.2/dragon/dragon-ess.json"
    doc = load_skeleton(path)
    source = image_source_for(doc, path, find_project(path))
    assert isinstance(source, AtlasImages)
    assert [a.path.name for a in source.atlases] == ["dragon.atlas"]
    assert all(name in source for name in needed_images(doc))


def test_images_folder_without_atlas(tmp_path, examples):
    import shutil

    shutil.copy(examples / "4.2/spineboy/spineboy-ess.json", tmp_path)
    shutil.copytree(examples / "4.2/spineboy/images", tmp_path / "images")
    path = tmp_path / "spineboy-ess.json"
    doc = load_skeleton(path)
    source = image_source_for(doc, path, find_project(tmp_path))
    assert isinstance(source, FolderImages)
    assert all(name in source for name in needed_images(doc))


def test_unity_names_in_the_corpus(corpus):
    """Unity exports: .atlas.txt and .json.txt / .skel.bytes are found."""
    found_atlas_txt = found_unity_skel = False
    for proj_dir in sorted(p for p in corpus.iterdir() if p.is_dir()):
        proj = find_project(proj_dir)
        found_atlas_txt |= any(p.name.endswith(".atlas.txt") for p in proj.atlases)
        found_unity_skel |= any(p.name.endswith((".json.txt", ".skel.bytes")) for p in proj.skeletons)
    assert found_atlas_txt and found_unity_skel


def test_every_corpus_project_has_skeletons_that_load(corpus):
    """Each corpus project, whatever its engine's file names (Godot's ``.spine-json``
    included), yields at least one skeleton, and every skeleton loads; a file that is
    neither is not taken for one."""
    from collections import Counter

    from spinemesh.skeleton import load_skeleton, spine_version

    versions: Counter = Counter()
    godot = 0
    for proj_dir in sorted(p for p in corpus.iterdir() if p.is_dir()):
        proj = find_project(proj_dir)
        assert proj.skeletons, proj_dir
        for path in proj.skeletons:
            godot += path.name.endswith(".spine-json")
            versions[spine_version(load_skeleton(path))[:3]] += 1
    print(f"skeletons by version: {dict(sorted(versions.items()))}")
    assert godot >= 1
    assert sum(versions.values()) >= 200


def _demo(tmp_path):
    import shutil
    from pathlib import Path

    dest = tmp_path / "p"
    shutil.copytree(Path(__file__).resolve().parents[1] / "examples" / "demo", dest)
    return dest


def test_one_policy_for_broken_atlases(tmp_path):
    """A broken atlas is reported once and left out; a bad region fails only itself."""
    from spinemesh.errors import AtlasError
    from spinemesh.project import project_atlases

    p = _demo(tmp_path)
    (p / "broken.atlas").write_bytes(b"\xff\xfe junk")
    (p / "pageless.atlas").write_text("gone.png\nsize: 4, 4\nr\n  bounds: 0, 0, 1, 1\n")
    text = (p / "demo.atlas").read_text()
    (p / "demo.atlas").write_text(text.replace("bounds: 105, 2, 81, 81", "bounds: 105, 2, -81, 81"))
    proj = find_project(p)
    atlases = project_atlases(proj)
    assert [a.name for a in atlases] == ["demo.atlas"]
    assert any("broken.atlas" in m and "not UTF-8" in m for m in proj.problems)
    assert any("pageless.atlas" in m and "gone.png" in m for m in proj.problems)
    assert any("demo-head" in m and "negative" in m for m in proj.problems)
    source = image_source_for(load_skeleton(p / "demo.json"), p / "demo.json", proj)
    assert source.get("demo-body").rgba.shape == (160, 120, 4)
    import pytest

    with pytest.raises(AtlasError, match="negative"):
        source.get("demo-head")


def test_symlinks_leading_outside_are_skipped(tmp_path):
    p = _demo(tmp_path)
    (tmp_path / "secret.txt").write_text("secret")
    (p / "notes.txt").symlink_to(tmp_path / "secret.txt")
    (p / "inside.txt").symlink_to(p / "demo.atlas")
    (p / "outside").symlink_to(tmp_path, target_is_directory=True)
    proj = find_project(p)
    names = {f.name for f in proj.files}
    assert "notes.txt" not in names and "inside.txt" in names
    assert not any(f.relative_to(p).parts[0] == "outside" for f in proj.files)
    assert sum("outside the project" in m for m in proj.problems) == 2


def test_images_hint_is_contained_by_real_path(tmp_path):
    """``../p-evil/`` once passed a string-prefix test for project ``p``."""
    import json
    import shutil

    p = _demo(tmp_path)
    (p / "demo.atlas").unlink()
    shutil.move(p / "images", tmp_path / "p-evil")
    doc = json.loads((p / "demo.json").read_text())
    doc["skeleton"]["images"] = "../p-evil/"
    proj = find_project(p)
    assert image_source_for(doc, p / "demo.json", proj) is None
    assert any("p-evil" in m for m in proj.problems)
    doc["skeleton"]["images"] = "D:/artist/images/"  # an absolute hint from another machine: passed over
    (tmp_path / "p-evil").rename(p / "images")
    proj = find_project(p)
    source = image_source_for(doc, p / "demo.json", proj)
    assert isinstance(source, FolderImages) and source.folder.name == "images" and not proj.problems


def test_skeletons_sharing_an_atlas_decode_each_page_once(corpus, tmp_path, monkeypatch):
    """Nine skeletons on one atlas page: one decode for the whole plan, not one per skeleton."""
    import spinemesh.images.decode as decode
    from spinemesh.upgrade import Options, upgrade_project

    decoded = []
    load = decode.load_rgba
    monkeypatch.setattr(decode, "load_rgba", lambda path: decoded.append(path) or load(path))
    result = upgrade_project(corpus / "stake-symbols", tmp_path / "out", Options(dry_run=True))
    assert result.counts().get("would mesh", 0) > 50
    assert len(decoded) == len(set(decoded)) == 1
