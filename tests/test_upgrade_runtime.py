"""Proof with the official Spine runtime: upgraded projects load and render like the originals.

For every example project of 3.8, 4.0, 4.1 and 4.2, from both ``.json`` and ``.skel``:

- the upgraded skeleton loads in the runtime of its version;
- its renders of the setup pose and of two frames of its first animation match the
  original's: at least 99.9% of pixels within 2/255 (7/255 for the projects in ``FAINT_ART``,
  and 2% for clipped ones, see ``CLIPPED_OFF_SHARE``, each with its cause);
- no pixel that is visible (alpha >= 8) in the original render disappears, apart from the
  pixels on a region quad's edge that the rasteriser may give either way (``TIE_PX``);
- the runtime's dump shows every mesh vertex inside the region's quad with matching UVs and
  no visible texel left uncovered (``compare.mjs`` on the two dumps).

Rendering is what costs (seconds per pose for the large examples), so each skeleton is
rendered once: a ``.skel`` whose document is the same as its ``.json`` twin's (read by our
readers, see :func:`same_document`) is not rendered again. Its upgraded file must then read
as the same document as the upgraded ``.json``, and the runtime must still load it and pass
the dump comparison. Twins that differ are both rendered.

Every case renders, except the ones named in ``NOT_RENDERED`` with their cause (the README
names them too).
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import pytest

from spinemesh.project import find_project, image_source_for, skeletons_to_read
from spinemesh.skeleton import iter_attachments, load_skeleton
from spinemesh.upgrade import Options, upgrade_project

from conftest import example_projects
from runtime_tool import TIE_PX, compare_dumps, dump, edge_distances, first_animation, render, render_difference

#: The bundled demo (ours: stripped whitespace, a rotated region, a sequence) and the examples.
DEMO = Path(__file__).resolve().parents[1] / "examples" / "demo"
CASES = [DEMO] + [p for v in ("3.8", "4.0", "4.1", "4.2") for p in example_projects(v)]
TIMES = "0.3,0.7"

#: A visible pixel may vanish (or appear) only as a rasterisation tie: its centre within
#: ``TIE_PX`` of an edge of a region's quad, where the mesh's outline runs along the quad's
#: edge between other end points (see ``runtime_tool.edge_distances``).

#: With clipping attachments the runtime cuts every triangle against the clip polygon, so a
#: mesh is drawn as many more, smaller pieces than a quad; their edges along the anti-aliased
#: clip path blend differently. The share of pixels off by more than 2/255 is then allowed to
#: reach this, while the no-lost-pixel and dump checks stay as strict as everywhere else.
CLIPPED_OFF_SHARE = 0.02

#: Meshes shared by all cases: the versions' examples are mostly the same art, meshed once.
MESHES: dict = {}

#: Art fainter than the mesher's alpha threshold (alpha < 8, paper section 3) lies outside the
#: mesh by design. Where a project has wide faint areas, it changes up to about 1% of pixels,
#: each by at most 7/255 (a faint layer missing over others); there the tolerance is 7/255.
FAINT_ART = {"snowglobe": "glass highlight and floor shadows painted with alpha < 8"}

#: Cases the runtime cannot render, by ``version/project``, with the cause.
NOT_RENDERED = {
    "3.8/spinosaurus": "ships skeletons only (no atlas, no images): every region is reported and stays one",
    "4.0/spinosaurus": "ships skeletons only (no atlas, no images): every region is reported and stays one",
    "4.1/spinosaurus": "ships skeletons only (no atlas, no images): every region is reported and stays one",
    "4.2/spinosaurus": "ships an images folder but no atlas: meshed from the images (checked for full "
                       "coverage here), but the runtime tool loads skeletons with atlases only",
}

#: Numbers the ``.json`` export rounds to 2 decimals, so a twin's float32 may differ by half a step.
EXPORT_ROUNDING = 0.0051
#: Mesh vertices are placed from the region's x, y, rotation and scale, which the ``.json``
#: export rounds: upgraded twins may differ by this much (skeleton units) where the rounding
#: is amplified by the region's size.
MESH_PLACEMENT = 0.05
#: Values the ``.json`` export leaves out because they are the defaults (a binary writes them).
DEFAULTS = (None, "", True, "ffffffff", "FFFFFFFF")
#: Editor-only (nonessential) fields, written to one format and not the other.
NONESSENTIAL = ("visible", "color", "hash")


def _default(value) -> bool:
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return min(abs(value), abs(value - 1)) <= EXPORT_ROUNDING
    return value in DEFAULTS


def same_document(a, b, tol: float = EXPORT_ROUNDING) -> bool:
    """Whether two skeleton documents say the same, up to what the two formats store differently.

    Key order, defaults present on one side only, editor-only fields and the ``.json``
    export's rounding (numbers within ``tol``) do not count; any other difference does.
    """
    if isinstance(a, bool) or isinstance(b, bool):
        return a == b
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        return math.isclose(a, b, rel_tol=1e-6, abs_tol=tol)
    if type(a) is not type(b):
        return False
    if isinstance(a, dict):
        ka = {k for k in a if k != "_skel"}
        kb = {k for k in b if k != "_skel"}
        for k in ka ^ kb:
            if k not in NONESSENTIAL and not _default(a[k] if k in a else b[k]):
                return False
        return all(k in NONESSENTIAL or same_document(a[k], b[k], tol) for k in ka & kb)
    if isinstance(a, list):
        return len(a) == len(b) and all(same_document(x, y, tol) for x, y in zip(a, b))
    return a == b


def test_same_document_tells_twins_apart():
    a = {"skeleton": {"hash": "x", "spine": "4.2"}, "bones": [{"name": "root", "x": 1.25}]}
    b = {"bones": [{"name": "root", "x": 1.2500001, "y": 0.0}], "skeleton": {"spine": "4.2", "hash": "y"},
         "_skel": {}}
    assert same_document(a, b)
    assert not same_document(a, {**b, "bones": [{"name": "root", "x": 1.3}]})
    assert not same_document(a, {**b, "bones": [{"name": "other", "x": 1.25}]})
    assert not same_document(a, {**b, "bones": [{"name": "root", "x": 1.25, "y": 3.0}]})


def _case_id(project: Path) -> str:
    return f"{project.parent.name}/{project.name}"


def _atlas_for(skeleton: Path, project_root: Path) -> Path | None:
    """The atlas the runtime should load: the one spinemesh meshed from (same choice)."""
    source = image_source_for(load_skeleton(skeleton), skeleton, find_project(project_root))
    atlases = getattr(source, "atlases", None)
    return atlases[0].path if atlases else None


def _twin(skeleton: Path) -> Path | None:
    """The ``.skel`` beside a ``.json`` of the same name."""
    skel = skeleton.with_suffix(".skel")
    return skel if skeleton.suffix == ".json" and skel.is_file() else None


def _renders_match(runtime, atlas, skeleton, ours_atlas, ours, project, tmp_path) -> tuple[int, list[str]]:
    """Render the original and ours in the same frame; the renders made, and the problems."""
    doc = load_skeleton(skeleton)
    anim = first_animation(doc)
    clipped = any(r.type == "clipping" for r in iter_attachments(doc))
    max_off = CLIPPED_OFF_SHARE if clipped else 1e-3
    prefix = f"a-{skeleton.name}"
    a = render(runtime, atlas, skeleton, anim, TIMES, tmp_path / prefix)
    b = render(runtime, ours_atlas, ours, anim, TIMES, tmp_path / f"b-{skeleton.name}",
               frame_from=tmp_path / f"{prefix}.frame.json")
    assert a and [p.name[2:] for p in a] == [p.name[2:] for p in b]
    # the original's quads, per pose, to tell rasterisation ties from art lost or added
    dump(runtime, atlas, skeleton, anim, TIMES, tmp_path / f"{prefix}.dump.json")
    drawn = {re.sub(r"[^\w@.+-]", "~", pose["label"]): pose["attachments"]
             for pose in json.loads((tmp_path / f"{prefix}.dump.json").read_text())["poses"]}
    shown = json.loads((tmp_path / f"{prefix}.frame.json").read_text())
    problems = []
    for pa, pb in zip(a, b):
        d = render_difference(pa, pb, tol=7 if project.name in FAINT_ART else 2, where=100_000)
        changed = d["lost_where"] + d["added_where"]
        label = pa.name[len(prefix) + 1:-len(".png")]
        ties = edge_distances(changed, drawn.get(label, []), shown["frame"], shown["ppu"]) <= TIE_PX
        if d["off_share"] > max_off or not ties.all():
            problems.append(f"{pb.name}: off {d['off_share']:.2e}, worst {d['worst']}, lost {d['lost']} at "
                            f"{d['lost_where'][:5]}, added {d['added']} at {d['added_where'][:5]}, "
                            f"{int(ties.sum())} of them ties on a quad edge")
    return len(b), problems


def _dumps_match(runtime, atlas, skeleton, ours_atlas, ours, tmp_path) -> list[str]:
    anim = first_animation(load_skeleton(skeleton))
    da, db = tmp_path / f"a-{skeleton.name}.dump.json", tmp_path / f"b-{skeleton.name}.dump.json"
    if not da.is_file():  # a rendered skeleton's original was dumped with its renders
        dump(runtime, atlas, skeleton, anim, TIMES, da)
    dump(runtime, ours_atlas, ours, anim, TIMES, db)
    ok, text = compare_dumps(runtime, da, db)
    return [] if ok else [f"{skeleton.name} dump: {text}"]


@pytest.mark.parametrize("project", CASES, ids=_case_id)
def test_upgraded_project_renders_like_the_original(project, spine_runtime, tmp_path):
    out = tmp_path / "out"
    result = upgrade_project(project, out, Options(), mesh_cache=MESHES)
    assert not result.errors, result.errors
    failed = [t for t in result.targets if t.status == "failed"]
    if _case_id(project) in NOT_RENDERED and not list(project.glob("*.atlas*")) and not (project / "images").is_dir():
        # The runtime cannot load these either. The upgrade must report every region and leave it one.
        assert result.targets and len(failed) == len(result.targets) and result.partial
        assert all("no atlas or images folder" in t.reason for t in failed)
        return
    assert not failed, [(t.skeleton, t.name, t.reason) for t in failed]
    # vine has no region attachments: nothing is meshed, renders must match all the same. A region
    # may be kept by a rule of the mesher (a mesh would save too little), with its reason.
    assert all(t.status == "kept" and t.reason for t in result.targets if t.status != "meshed")
    assert all(t.coverage == 1.0 for t in result.targets if t.status == "meshed")
    assert not result.targets or any(t.status == "meshed" for t in result.targets)

    renders, problems = 0, []
    for skeleton in skeletons_to_read(sorted(p for p in project.iterdir() if p.suffix in (".json", ".skel"))):
        twin = _twin(skeleton)
        # Twins that differ are both rendered; equal ones once.
        twin_alone = twin is not None and not same_document(load_skeleton(skeleton), load_skeleton(twin))
        if twin is not None and not twin_alone:
            # The upgraded twins must say the same too (same meshes; vertices placed from the
            # .json's rounded region fields may move by a few hundredths), so the render of one
            # stands for both.
            assert same_document(load_skeleton(out / skeleton.name), load_skeleton(out / twin.name),
                                 MESH_PLACEMENT), twin
        atlas = _atlas_for(skeleton, project)
        if atlas is None:
            assert _case_id(project) in NOT_RENDERED, f"{skeleton}: no atlas to render with"
            continue
        ours_atlas = out / atlas.relative_to(project)
        for path in [skeleton] + ([twin] if twin is not None else []):
            if path is skeleton or twin_alone:
                made, found = _renders_match(spine_runtime, atlas, path, ours_atlas, out / path.name, project, tmp_path)
                renders += made
                problems += found
            problems += _dumps_match(spine_runtime, atlas, path, ours_atlas, out / path.name, tmp_path)
    assert not problems, "\n".join(problems)
    assert renders > 0 or _case_id(project) in NOT_RENDERED, "nothing was rendered"
