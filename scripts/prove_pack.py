"""Runtime proof of ``spinemesh pack``: a packed project renders like the unpacked one.

For every project folder given (by default every example of 3.8-4.2 and every corpus project)
and every skeleton in it whose Spine version the harness ``../shared/tools/spine-runtime``
renders (3.8, 4.0, 4.1, 4.2):

1. ``spinemesh pack`` the project into a scratch folder (default options; with ``--upgrade``,
   ``spinemesh upgrade`` it first and pack the upgrade, then compare against the upgrade);
2. render the same skeleton file with the original atlas and with the packed one, in the same
   frame: the setup pose, then two frames (0.3 s and 0.7 s) of up to three animations; with
   named skins, the first one too;
3. compare the renders premultiplied: a render passes when no pixel differs by more than
   2/255 (the upgrade proof's tolerance), apart from at most ``MAX_OFF_SHARE`` of its pixels
   (1e-5: float32 UVs over a new page size, see there).

The skeleton files are the very same bytes on both sides (packing changes atlases and pages
only), so any difference comes from the pages.

    .venv/bin/python scripts/prove_pack.py                                # examples + corpus (slow: nice)
    .venv/bin/python scripts/prove_pack.py ../shared/spine-examples/4.2/spineboy --json build/pack-proof.json
"""

from __future__ import annotations

import argparse
import fnmatch
import json
import shutil
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests"))
sys.path.insert(0, str(REPO / "scripts"))

from prove_corpus import (CORPUS, RENDERABLE, TOLERANCE, harness_atlas, harness_copy, pose_list,  # noqa: E402
                          prove_each, renderable, skins_to_render)
from runtime_tool import dump, install, render, render_difference  # noqa: E402

from spinemesh.errors import SpineMeshError  # noqa: E402
from spinemesh.pack.run import PackOptions, PackResult, pack_project_into  # noqa: E402
from spinemesh.project import find_project  # noqa: E402
from spinemesh.skeleton import is_binary_skeleton  # noqa: E402

EXAMPLES = REPO.parent / "shared" / "spine-examples"

#: A render passes with at most this share of its pixels over the tolerance. Packing moves
#: texels and never changes them, but the runtime computes UVs in float32 over the page size
#: (``u = x / width``), so a new page size moves a sample by a tiny fraction of a texel, which
#: can tip a pixel on a triangle's edge: measured on every third corpus project, one pixel of
#: one render (jt-mia, 3/255, a share of 3.9e-7).
MAX_OFF_SHARE = 1e-5

#: Animations sampled per skeleton.
ANIMATIONS = 3


@dataclass
class Row:
    """The proof of one skeleton against one packed atlas."""

    project: str
    skeleton: str
    version: str = ""
    atlas: str = ""
    packed: bool = False            # the atlas was packed (else it was kept, and both sides are equal)
    renders: int = 0
    worst: int = 0
    off: int = 0
    off_share: float = 0.0
    status: str = ""                # pass | FAIL | not rendered
    cause: str = ""
    details: list = field(default_factory=list)


def setup_frame(tool: Path, atlas: Path, skeleton: Path, doc: dict, prefix: Path, skin: str | None) -> Path | None:
    """A frame file around what the setup pose draws (plus 25%), for a skeleton whose file has no
    bounds (the harness frames by them); None when the file has them."""
    bounds = doc.get("skeleton") or {}
    if all(isinstance(bounds.get(k), (int, float)) for k in ("x", "y", "width", "height")):
        return None
    out = prefix.with_suffix(".dump.json")
    dump(tool, atlas, skeleton, None, "", out, skin=skin)
    points = [v for a in json.loads(out.read_text())["poses"][0]["attachments"] for v in a["vertices"]]
    if not points:
        return None
    xs, ys = points[0::2], points[1::2]
    w, h = max(xs) - min(xs), max(ys) - min(ys)
    frame = {"x": min(xs) - w / 8, "y": min(ys) - h / 8, "width": w * 1.25, "height": h * 1.25}
    path = prefix.with_suffix(".frame.json")
    path.write_text(json.dumps({"frame": frame}))
    return path


def prove_skeleton(tool: Path, project: Path, out: Path, skeleton: Path, work: Path, row: Row,
                   packed_atlases: set[str], animations: int = ANIMATIONS) -> Row:
    """Render ``skeleton`` with its original atlas and with the packed one in ``out``; fill in ``row``."""
    doc, atlas = renderable(skeleton, project, row)
    if atlas is None:
        return row
    row.atlas = atlas.relative_to(project).as_posix()
    row.packed = row.atlas in packed_atlases
    if not row.packed:
        row.status, row.cause = "pass", "atlas kept as it was"
        return row
    binary = is_binary_skeleton(skeleton)
    skel = harness_copy(skeleton, binary, work / "s")
    a_atlas = harness_atlas(atlas, work / "atlas-a")
    b_atlas = harness_atlas(out / atlas.relative_to(project), work / "atlas-b")
    poses = pose_list(doc, animations)
    problems = []
    for k, skin in enumerate(skins_to_render(doc)):
        these = (poses if k == 0 else poses.split(",")[0]) or None
        frame = setup_frame(tool, a_atlas, skel, doc, work / f"f{k}", skin)
        a = render(tool, a_atlas, skel, None, "", work / f"a{k}", frame_from=frame, poses=these, skin=skin)
        if frame is None:
            shown = json.loads((work / f"a{k}.frame.json").read_text())["frame"]
            if any(v is None for v in shown.values()):
                row.status, row.cause = "not rendered", "the setup pose draws nothing and the file has no bounds"
                return row
        b = render(tool, b_atlas, skel, None, "", work / f"b{k}", frame_from=work / f"a{k}.frame.json",
                   poses=these, skin=skin)
        if [p.name[2:] for p in a] != [p.name[2:] for p in b]:
            problems.append("renders differ in poses")
        for pa, pb in zip(a, b):
            d = render_difference(pa, pb, tol=TOLERANCE)
            row.renders += 1
            row.worst = max(row.worst, d["worst"])
            row.off += d["off"]
            row.off_share = max(row.off_share, d["off_share"])
            if d["off_share"] > MAX_OFF_SHARE:
                problems.append(f"{pb.name}: worst {d['worst']}, off {d['off']} ({d['off_share']:.2e})")
    row.details = problems
    row.status = "FAIL" if problems else "pass"
    return row


def prove_project(tool: Path, project: Path, work: Path, animations: int = ANIMATIONS,
                  upgrade: bool = False) -> list[Row]:
    """Pack ``project`` (optionally its upgrade) into ``work`` and prove each skeleton."""
    name = project.name
    source = project
    if upgrade:
        from spinemesh.upgrade import Options, upgrade_project

        source = work / "upgraded"
        try:
            upgrade_project(project, source, Options())
        except SpineMeshError as e:
            return [Row(name, "-", status="FAIL", cause=f"upgrade refused the project: {e}")]
    out = work / "out"
    out.mkdir(parents=True, exist_ok=True)
    result = PackResult()
    try:
        pack_project_into(find_project(source), out, PackOptions(), result)
    except SpineMeshError as e:
        return [Row(name, "-", status="FAIL", cause=f"pack refused the project: {e}")]
    packed = {a.atlas for a in result.atlases if a.status == "packed"}
    rows = []
    for skeleton in find_project(source).skeletons:
        rel = skeleton.relative_to(source).as_posix()
        row = Row(name, rel)
        scratch = work / "render" / rel.replace("/", "~")
        scratch.mkdir(parents=True, exist_ok=True)
        try:
            prove_skeleton(tool, source, out, skeleton, scratch, row, packed, animations)
        except (AssertionError, SpineMeshError) as e:  # the harness failed to load or render
            row.status, row.cause = "FAIL", f"harness: {str(e).strip().splitlines()[-1][:300]}"
        rows.append(row)
    return rows


def table(rows: list[Row]) -> str:
    head = ("| project | skeleton | version | atlas | packed | renders | worst /255 | px > 2/255 | status | cause |\n"
            "|---|---|---|---|---|---:|---:|---:|---|---|")
    return "\n".join([head] + [f"| {r.project} | {r.skeleton} | {r.version} | {r.atlas} | {'yes' if r.packed else 'no'} | "
                               f"{r.renders} | {r.worst} | {r.off} | {r.status} | {r.cause} |" for r in rows])


def summary(rows: list[Row]) -> str:
    rendered = [r for r in rows if r.status != "not rendered" and r.packed]
    passed = [r for r in rendered if r.status == "pass"]
    return (f"{len(passed)}/{len(rendered)} skeletons on packed atlases pass, {sum(r.renders for r in rendered)} renders "
            f"({sum(1 for r in rows if r.status == 'not rendered')} not renderable, "
            f"{sum(1 for r in rows if not r.packed and r.status == 'pass')} on atlases kept as they were)")


def default_projects() -> list[Path]:
    examples = [p for v in RENDERABLE for p in sorted((EXAMPLES / v).iterdir()) if p.is_dir()] \
        if EXAMPLES.is_dir() else []
    corpus = sorted(p for p in CORPUS.iterdir() if p.is_dir()) if CORPUS.is_dir() else []
    return examples + corpus


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("projects", nargs="*", type=Path, help="project folders (default: 3.8-4.2 examples and corpus)")
    ap.add_argument("--only", action="append", default=[], help="glob on project names; repeatable")
    ap.add_argument("--upgrade", action="store_true", help="prove upgrade --pack: pack each project's upgrade")
    ap.add_argument("--json", type=Path, help="write the rows here as JSON")
    ap.add_argument("--animations", type=int, default=ANIMATIONS, help="animations sampled per skeleton")
    ap.add_argument("--keep", type=Path, help="keep packs and renders here (default: a temporary folder)")
    args = ap.parse_args(argv)
    projects = [p.resolve() for p in args.projects] or default_projects()
    if args.only:
        projects = [p for p in projects if any(fnmatch.fnmatchcase(p.name, g) for g in args.only)]
    base = Path(tempfile.mkdtemp(prefix="prove-pack-")) if args.keep is None else args.keep
    tool = install(base / "tool")
    rows = prove_each(projects, base, lambda project, work: prove_project(tool, project, work, args.animations,
                                                                          args.upgrade), args.json, args.keep is None, [])
    print(table(rows))
    print()
    print(summary(rows))
    if args.keep is None:
        shutil.rmtree(base, ignore_errors=True)
    return 0 if all(r.status != "FAIL" for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
