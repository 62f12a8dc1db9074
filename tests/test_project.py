"""Project discovery and the choice of atlases for each skeleton."""

from __future__ import annotations

from spinemesh.images import AtlasImages, FolderImages
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
