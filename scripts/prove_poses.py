"""Pose proof: our sampler (spinemesh.anim) against the official runtime, every animation.

For every skeleton (``.json`` and ``.skel``) of the official examples 3.8 to 4.2 and of the
corpus whose Spine version the harness ``../shared/tools/spine-runtime`` plays (3.8, 4.0,
4.1, 4.2), and every 4.3 corpus skeleton (official spine-core 4.3 through
``tests/runtime43/pose.mjs``, which plays poses the same way), with the default skin and the
first named skin, every animation is sampled at
``--times`` by the harness (a looping AnimationState stepped in 1/60 s from 0) and by
:class:`spinemesh.anim.Sampler`, and the two dumps are compared: the largest difference of
any bone's world transform (``a, b, c, d, worldX, worldY``) and of any drawn attachment's
world vertex, in world units, and anything else that differs (the attachment drawn, the draw
order, the colour).

4.2 physics constraints are stepped by the sampler as by the runtime; their bones count in
the bone and vertex columns like any other, and the ``physics`` column repeats the largest
error of the bones they move (``-``: the skeleton has none). Bones our sampler flags as not
reproduced are left out of the columns; such a row is ``partial``, with the reason.

One row per skeleton and skin; a skeleton passes when both errors are at most 0.01 and
nothing else differs.

    .venv/bin/python scripts/prove_poses.py                          # examples and corpus
    .venv/bin/python scripts/prove_poses.py --examples --only 'spineboy*' --times 0.2,0.5
"""

from __future__ import annotations

import argparse
import fnmatch
import json
import sys
import tempfile
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests"))
sys.path.insert(0, str(REPO / "scripts"))

from spinemesh.anim import Sampler, atlas_regions  # noqa: E402
from spinemesh.anim.dump import advance_clock, js_number, pose_errors  # noqa: E402
from spinemesh.atlas import read_atlas  # noqa: E402
from spinemesh.errors import SpineMeshError  # noqa: E402
from spinemesh.project import find_project  # noqa: E402
from spinemesh.skeleton import is_binary_skeleton, load_skeleton, spine_version  # noqa: E402

from conftest import CORPUS, EXAMPLES  # noqa: E402
from prove_corpus import atlas_for, harness_atlas, harness_copy, skins_to_render  # noqa: E402
from runtime_tool import PORT_38_PATHS, dump, install, install43, node, unlike_official_38  # noqa: E402

#: Versions the harness plays; 4.3 plays through tests/runtime43.
PLAYED = ("3.8", "4.0", "4.1", "4.2", "4.3")
TIMES = (0.1, 0.37, 0.8, 1.53)
GOAL = 0.01


@dataclass
class Row:
    source: str                     # examples | corpus
    skeleton: str
    skin: str = ""
    version: str = ""
    animations: int = 0
    poses: int = 0
    bone: float = 0.0
    vertex: float = 0.0
    physics: float | None = None    # largest error on bones we flag (physics), None without any
    worst: str = ""
    unproved: list = field(default_factory=list)   # bones our sampler flags (not compared), why
    status: str = ""                # pass | partial (some bones flagged, not compared) | FAIL | not played
    cause: str = ""
    problems: list = field(default_factory=list)


def skeleton_files(root: Path, versions=PLAYED) -> list[tuple[Path, Path]]:
    """``(project folder, skeleton file)`` for every skeleton under ``root``'s projects."""
    out = []
    if root == EXAMPLES:
        projects = [p for v in versions if (root / v).is_dir() for p in sorted((root / v).iterdir()) if p.is_dir()] \
            if root.is_dir() else []
    else:
        projects = sorted(p for p in root.iterdir() if p.is_dir()) if root.is_dir() else []
    for project in projects:
        try:
            found = find_project(project).skeletons
        except SpineMeshError:
            continue
        out += [(project, s) for s in found]
    return out


def _playable(name: str) -> bool:
    return not any(c in name for c in ",@")   # the harness's --poses cannot name these


def _dump43(tool43: Path, atlas: Path, skeleton: Path, out: Path, poses: str, skin: str | None) -> None:
    r = node(tool43, "pose.mjs", atlas, skeleton, out, poses, *([skin] if skin else []))
    assert r.returncode == 0, f"4.3 pose dump of {skeleton} failed: {r.stderr[-2000:]}"


def prove_skeleton(tool: Path, source: str, project: Path, skeleton: Path, work: Path, times,
                   tool43: Path | None = None) -> list[Row]:
    """Rows (one per skin) for one skeleton file."""
    rel = skeleton.relative_to(project.parent if source == "corpus" else project.parent.parent).as_posix()
    row = Row(source, rel)
    try:
        doc = load_skeleton(skeleton)
    except SpineMeshError as e:
        row.status, row.cause = "not played", f"unreadable: {e}"
        return [row]
    row.version = spine_version(doc)
    if row.version[:3] not in PLAYED:
        row.status, row.cause = "not played", f"Spine {row.version or '?'}: the harness has no runtime for it"
        return [row]
    atlas, why = atlas_for(doc, skeleton, project)
    if atlas is None:
        row.status, row.cause = "not played", why
        return [row]
    regions = atlas_regions(read_atlas(atlas, strict=False))
    anims = [a for a in (doc.get("animations") or {}) if _playable(a)]
    if not anims:
        row.status, row.cause = "not played", "no animation"
        return [row]
    harness_skeleton = harness_copy(skeleton, is_binary_skeleton(skeleton), work)
    harness_atlas_path = harness_atlas(atlas, work / "atlas")
    poses = ",".join(f"{a}@{js_number(t)}" for a in anims for t in times)
    rows = []
    for skin in skins_to_render(doc):
        r = Row(source, rel, skin or "", row.version, len(anims))
        out = work / f"dump-{len(rows)}.json"
        try:
            if row.version.startswith("4.3"):
                _dump43(tool43, harness_atlas_path, harness_skeleton, out, poses, skin)
            else:
                dump(tool, harness_atlas_path, harness_skeleton, None, "", out, poses=poses, skin=skin)
        except AssertionError as e:
            r.status, r.cause = "not played", f"harness: {str(e).strip().splitlines()[-1][:200]}"
            rows.append(r)
            continue
        theirs = json.loads(out.read_text())["poses"]
        sampler = Sampler(doc, skin, regions)
        active = {c.name for c in sampler.rig.constraints if c.kind == "path" and c.active}
        compare(sampler, theirs, r, unlike_official_38(doc, active))
        rows.append(r)
    return rows


def compare(sampler: Sampler, theirs: list[dict], row: Row, port: set[str] = frozenset()) -> None:
    """Fill ``row`` from the harness's poses and ours at the same times. ``port``: bones the
    harness's 3.8 port poses unlike the official runtime (``runtime_tool.unlike_official_38``),
    left out with what they draw, as bones our sampler flags are."""
    clock = 0.0   # the harness plays every pose on one skeleton, whose clock runs on
    for pose in theirs:
        mine = sampler.pose(pose["anim"], pose["time"], clock=clock)
        if pose["anim"] is not None:
            clock = advance_clock(clock, pose["time"])
        ours = mine.to_dump()
        skip = set(mine.why) | port
        if port:
            _leave_out_attachments_of(sampler, mine, ours, port)
        # Bones the skin does not use: the runtime leaves them unposed (nothing draws with them).
        inactive = {n for n, a in zip(mine.bones, mine.active) if not a}
        e = pose_errors(ours, pose, skip | inactive)
        row.poses += 1
        if e["bone"] > row.bone or e["vertex"] > row.vertex:
            row.worst = f"{pose['label']}: {e['worst_bone']} / {e['worst_slot']}"
        row.bone, row.vertex = max(row.bone, e["bone"]), max(row.vertex, e["vertex"])
        row.problems += [f"{pose['label']}: {p}" for p in e["problems"]][:3]
        for name in sorted(skip - inactive):
            if name not in {u[0] for u in row.unproved}:
                row.unproved.append((name, mine.why.get(name, PORT_38_PATHS)))
        physics = {sampler.bone_names[i] for i in sampler.physics_bones} - inactive
        if physics:
            moved = pose_errors(ours, {**pose, "bones": {n: m for n, m in pose["bones"].items() if n in physics},
                                       "attachments": []})
            row.physics = max(row.physics or 0.0, moved["bone"])
    ok = row.bone <= GOAL and row.vertex <= GOAL and not row.problems
    row.status = "FAIL" if not ok else "partial" if row.unproved else "pass"
    if row.unproved:
        row.cause = f"{len(row.unproved)} bones not compared: {row.unproved[0][1]}"


def _leave_out_attachments_of(sampler: Sampler, pose, dumped: dict, bones: set[str]) -> None:
    """Mark not exact (so not compared) each drawn attachment of ``dumped`` (``pose.to_dump()``)
    whose vertices follow one of ``bones``: its slot's bone, or a bone it is weighted to."""
    for drawn, entry in zip(pose.slots, dumped["attachments"]):
        att = sampler.attachment(sampler.slot_names.index(drawn.slot), drawn.key)
        geometry = att.geometry if att is not None else None
        followed = ({sampler.bone_names[int(b)] for b in geometry.bone} if geometry is not None and geometry.weighted
                    else {drawn.bone})
        if followed & bones:
            entry["exact"] = False


def table(rows: list[Row]) -> str:
    lines = [f"{'skeleton':58s} {'skin':12s} {'ver':7s} {'anims':>5s} {'poses':>5s} {'bone':>9s} {'vertex':>9s} "
             f"{'physics':>9s}  status"]
    for r in rows:
        phys = "-" if r.physics is None else f"{r.physics:9.4f}"
        lines.append(f"{r.skeleton[-58:]:58s} {r.skin[:12]:12s} {r.version[:7]:7s} {r.animations:5d} {r.poses:5d} "
                     f"{r.bone:9.5f} {r.vertex:9.5f} {phys:>9s}  {r.status} {r.cause}{(' ' + r.worst) if r.status == 'FAIL' else ''}"
                     f"{(' ' + '; '.join(r.problems[:2])) if r.problems else ''}")
    return "\n".join(lines)


def summary(rows: list[Row]) -> str:
    played = [r for r in rows if r.status != "not played"]
    passed = [r for r in played if r.status == "pass"]
    partial = [r for r in played if r.status == "partial"]
    phys = [r.physics for r in played if r.physics is not None]
    return (f"{len(passed)}/{len(played)} skeleton-skins pass, {len(partial)} partial "
            f"({len(rows) - len(played)} not played), "
            f"{sum(r.poses for r in played)} poses; max bone error {max((r.bone for r in played), default=0):.5f}, "
            f"max vertex error {max((r.vertex for r in played), default=0):.5f} world units (physics-free bones); "
            f"{len(phys)} with physics, largest error on the bones physics moves {max(phys, default=0):.5f}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--examples", action="store_true", help="the official examples only")
    ap.add_argument("--corpus", action="store_true", help="the corpus only")
    ap.add_argument("--only", action="append", default=[], help="glob on project names; repeatable")
    ap.add_argument("--times", default=",".join(map(str, TIMES)), help="sample times in seconds")
    ap.add_argument("--json", type=Path, help="write the rows here as JSON")
    ap.add_argument("--tool", type=Path, help="an installed copy of the harness (default: install one)")
    ap.add_argument("--tool43", type=Path, help="an installed copy of tests/runtime43 (default: install one)")
    args = ap.parse_args(argv)
    times = [float(t) for t in args.times.split(",")]
    sources = [("examples", EXAMPLES)] if args.examples else [("corpus", CORPUS)] if args.corpus else \
        [("examples", EXAMPLES), ("corpus", CORPUS)]
    base = Path(tempfile.mkdtemp(prefix="prove-poses-"))
    tool = args.tool.resolve() if args.tool else install(base / "tool")
    tool43 = args.tool43.resolve() if args.tool43 else install43(base / "tool43")
    rows: list[Row] = []
    for source, root in sources:
        for project, skeleton in skeleton_files(root):
            if args.only and not any(fnmatch.fnmatchcase(project.name, g) for g in args.only):
                continue
            t0 = time.perf_counter()
            work = base / "work" / f"{len(rows)}"
            work.mkdir(parents=True, exist_ok=True)
            new = prove_skeleton(tool, source, project, skeleton, work, times, tool43)
            rows += new
            for r in new:
                print(f"{r.skeleton} [{r.skin}]: {r.status} bone {r.bone:.5f} vertex {r.vertex:.5f} {r.cause} "
                      f"{r.worst if r.status == 'FAIL' else ''} {r.problems[:2]} ({time.perf_counter() - t0:.1f} s)",
                      file=sys.stderr, flush=True)
            if args.json:
                args.json.parent.mkdir(parents=True, exist_ok=True)
                args.json.write_text(json.dumps([asdict(r) for r in rows], indent=1))
    print(table(rows))
    print()
    print(summary(rows))
    return 0 if all(r.status != "FAIL" for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
