"""Runtime proof on real projects: upgrade each one, render original and upgrade with the official runtime.

For every project folder given (by default every project of ``../shared/spine-corpus``) and
every skeleton in it (``.json`` and ``.skel``) whose Spine version the harness
``../shared/tools/spine-runtime`` renders (3.8, 4.0, 4.1, 4.2):

1. ``spinemesh upgrade`` the project into a scratch folder (default options);
2. render the original and the upgrade in the same frame: the setup pose, then two frames
   (0.3 s and 0.7 s) of up to three animations; with named skins, the first one too;
3. compare the renders premultiplied (``tests/runtime_tool.render_difference``), and the two
   runtime dumps (every mesh vertex inside the region's quad, UVs agreeing, no visible texel
   uncovered).

It prints one row per skeleton: renders compared, worst difference (/255), pixels over the
tolerance (2/255) in all renders together, the largest share of one render's pixels over it,
visible pixels lost and added, and the cause of any failure: one named in ``CAUSES`` after
investigation, or what kept the skeleton from being rendered.

"Visible" is alpha >= 8 (the dump check's ``alpha-tol``); anything fainter that differs counts
in the pixels over the tolerance. The upgrade agrees with that: in normal slots it leaves out
only texels whose premultiplied channels are at most 2/255 (``spinemesh.images.texels.FAINT_TEXEL``),
which move no pixel by more than the tolerance in one layer, so a pixel it loses or adds on its
own is never visible; stacked faint layers can add up, and show as pixels over the tolerance.

    .venv/bin/python scripts/prove_corpus.py                      # whole corpus (slow: run with nice)
    .venv/bin/python scripts/prove_corpus.py --only 'dm-*' --json build/proof.json --keep build/proof
"""

from __future__ import annotations

import argparse
import fnmatch
import json
import re
import shutil
import sys
import tempfile
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path


REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests"))

from spinemesh.errors import SpineMeshError  # noqa: E402
from spinemesh.project import find_project, image_source_for  # noqa: E402
from spinemesh.skeleton import is_binary_skeleton, iter_attachments, load_skeleton, spine_version  # noqa: E402
from spinemesh.upgrade import Options, upgrade_project  # noqa: E402

from runtime_tool import (TIE_PX, compare_dumps, dump, edge_distances, install, render,  # noqa: E402
                          render_difference)

CORPUS = REPO.parent / "shared" / "spine-corpus"

#: Spine versions the harness has a runtime for.
RENDERABLE = ("3.8", "4.0", "4.1", "4.2")

#: A pixel is off when its premultiplied colour or alpha differs by more than this (/255).
TOLERANCE = 2

#: A render passes with at most this share of its pixels off...
MAX_OFF_SHARE = 1e-3

#: ...except with clipping attachments: the harness cuts every triangle against an anti-aliased
#: clip path, so a mesh (many more, smaller pieces than a quad) blends differently along it.
CLIPPED_OFF_SHARE = 0.02

#: Animation sample times (seconds) and how many animations are sampled.
TIMES = (0.3, 0.7)
ANIMATIONS = 3

#: Differences over the tolerance that were investigated and are not fixed, with their cause,
#: by (project, skeleton path). Measured sizes are in the README's runtime-proof section.
CAUSES: dict[tuple[str, str], str] = {
    ("pail-crowd-w3", "man2/world_3_man_2.json"):
        "dump check only: in Dance@0.7 the propeller's quad is scaled to zero width (area 6.6e-4), "
        "where its UV estimate is ill-conditioned; the renders match (worst 1/255)",
    ("dq-ui", "BigWinWindow.json"):
        "setup pose, 40 pixels at the visibility threshold (alpha 8 against 0: 22 lost, 18 added) and 434 "
        "pixels (0.008%) over 2/255, worst 8/255 (28 and 416 with a whole texel of sampling margin), all "
        "sampled ones under eight stacked additive particle layers "
        "(b_dots..b_dots8): each faint sample rounds to 0 or 1/255 by its triangle's interpolation, and "
        "eight layers add up to 8/255",
}


@dataclass
class Row:
    """The proof of one skeleton."""

    project: str
    skeleton: str
    version: str = ""
    renders: int = 0
    worst: int = 0                  # largest premultiplied difference, /255
    off: int = 0                    # pixels over TOLERANCE, all renders together
    off_share: float = 0.0          # largest share of one render's pixels over TOLERANCE
    lost: int = 0                   # visible in the original (alpha >= 8), empty in ours
    added: int = 0                  # visible in ours, empty (alpha 0) in the original
    ties: int = 0                   # of those lost or added, rasterisation ties on a quad edge (TIE_PX)
    dump_ok: bool | None = None
    meshed: int = 0                 # region attachments of this skeleton that became meshes
    kept: int = 0                   # left regions on purpose (the report says why)
    regions: int = 0
    status: str = ""                # pass | FAIL | not rendered
    cause: str = ""
    details: list = field(default_factory=list)

    @property
    def passed(self) -> bool:
        return self.status == "pass"


def harness_copy(path: Path, binary: bool, work: Path) -> Path:
    """``path`` under a name the harness reads right (it takes ``*.json`` as JSON, anything else as binary).

    Unity's ``.json.txt`` / ``.skel.bytes`` and binaries named ``.json`` are linked under a
    plain ``.json`` or ``.skel`` name in ``work``; other files are used as they are.
    """
    name = path.name.lower()
    if binary != name.endswith(".json") or name.endswith(".skel"):
        return path
    link = work / (path.name.split(".")[0] + (".skel" if binary else ".json"))
    link.parent.mkdir(parents=True, exist_ok=True)
    if link.is_symlink() or link.exists():
        link.unlink()
    link.symlink_to(path.resolve())
    return link


def harness_atlas(atlas: Path, dest: Path) -> Path:
    """``atlas`` as the harness can read it whole: its pages must be PNG there.

    The harness decodes premultiplied pages (to upload the texels as they are stored) and,
    in the dump check, every page with its own PNG decoder; other formats (WebP, JPEG) are
    decoded here and written as PNG beside a copy of the atlas naming them (the same texels:
    WebP is decoded without premultiplying). Original and upgrade are rendered from the
    same copy. Atlases with PNG pages only are used as they are.
    """
    from PIL import Image

    from spinemesh.atlas import read_atlas

    parsed = read_atlas(atlas)
    convert = [p for p in parsed.pages if not p.name.lower().endswith(".png")]
    if not convert:
        return atlas
    dest.mkdir(parents=True, exist_ok=True)
    for page in parsed.pages:
        src = atlas.parent / page.name
        if page in convert:
            page.name = page.name.rsplit(".", 1)[0] + ".png"
            (dest / page.name).parent.mkdir(parents=True, exist_ok=True)
            with Image.open(src) as im:
                im.convert("RGBA").save(dest / page.name)
        elif not (dest / page.name).exists():
            (dest / page.name).parent.mkdir(parents=True, exist_ok=True)
            (dest / page.name).symlink_to(src.resolve())
    out = dest / atlas.name
    out.write_text(parsed.dumps(), encoding="utf-8")
    return out


def pose_list(doc: dict, count: int = ANIMATIONS) -> str:
    """``--poses`` for the harness: TIMES of the first ``count`` animations (names it can parse)."""
    anims = [a for a in (doc.get("animations") or {}) if not any(c in a for c in ",@")][:count]
    return ",".join(f"{a}@{t:g}" for a in anims for t in TIMES)


def skins_to_render(doc: dict) -> list[str | None]:
    """The default skin, plus the first named skin if there is one."""
    skins = doc.get("skins")
    names = [s.get("name") for s in skins if isinstance(s, dict)] if isinstance(skins, list) else list(skins or {})
    named = [n for n in names if n and n != "default" and not any(c in n for c in ",@")]
    return [None] + named[:1]


def atlas_for(doc: dict, skeleton: Path, project_root: Path) -> tuple[Path | None, str]:
    """The one atlas the runtime should load (the one spinemesh meshed from), or why there is none."""
    source = image_source_for(doc, skeleton, find_project(project_root))
    atlases = getattr(source, "atlases", None)
    if not atlases:
        return None, "no atlas holds its images"
    if len(atlases) > 1:
        return None, f"its images come from {len(atlases)} atlases; the harness loads one"
    return atlases[0].path, ""


def renderable(skeleton: Path, project: Path, row) -> tuple[dict, Path | None]:
    """``(document, atlas the harness loads)`` of ``skeleton``; without an atlas, ``row`` says why
    it is not rendered. Fills ``row.version``."""
    doc = load_skeleton(skeleton)
    row.version = spine_version(doc)
    if row.version[:3] not in RENDERABLE:
        row.status, row.cause = "not rendered", f"Spine {row.version or '?'}: the harness has no runtime for it"
        return doc, None
    atlas, why = atlas_for(doc, skeleton, project)
    if atlas is None:
        row.status, row.cause = "not rendered", why
    return doc, atlas


def prove_skeleton(tool: Path, project: Path, out: Path, skeleton: Path, work: Path, row: Row,
                   animations: int = ANIMATIONS) -> Row:
    """Render and dump ``skeleton`` and its upgrade in ``out``; fill in ``row``."""
    doc, atlas = renderable(skeleton, project, row)
    if atlas is None:
        return row
    ours = out / skeleton.relative_to(project)
    if not ours.is_file():
        row.status, row.cause = "FAIL", "the upgrade wrote no skeleton"
        return row
    binary = is_binary_skeleton(skeleton)
    a_skel = harness_copy(skeleton, binary, work / "a")
    b_skel = harness_copy(ours, binary, work / "b")
    b_atlas = out / atlas.relative_to(project)
    if b_atlas.read_bytes() == atlas.read_bytes():
        # The upgrade copies atlases and pages unchanged: both sides render from one copy.
        atlas = b_atlas = dump_atlas = harness_atlas(atlas, work / "atlas")
    else:
        # --repack rewrote the atlas: ours renders from it, and the dump check compares the
        # original skeleton and ours both on it (a re-packed region's quad is its whole image).
        atlas = harness_atlas(atlas, work / "atlas-a")
        b_atlas = dump_atlas = harness_atlas(b_atlas, work / "atlas-b")
    clipped = any(r.type == "clipping" for r in iter_attachments(doc))
    max_share = CLIPPED_OFF_SHARE if clipped else MAX_OFF_SHARE
    poses = pose_list(doc, animations)
    problems, dumps_ok = [], True
    for k, skin in enumerate(skins_to_render(doc)):
        tag = f"{k}"
        these = (poses if k == 0 else poses.split(",")[0]) or None
        a = render(tool, atlas, a_skel, None, "", work / f"a{tag}", poses=these, skin=skin)
        b = render(tool, b_atlas, b_skel, None, "", work / f"b{tag}", frame_from=work / f"a{tag}.frame.json",
                   poses=these, skin=skin)
        dump(tool, atlas, a_skel, None, "", work / f"a{tag}.dump.json", poses=these, skin=skin)
        dump(tool, b_atlas, b_skel, None, "", work / f"b{tag}.dump.json", poses=these, skin=skin)
        checked = work / f"a{tag}.dump.json"
        if dump_atlas != atlas:
            checked = work / f"a{tag}.repacked.dump.json"
            dump(tool, dump_atlas, a_skel, None, "", checked, poses=these, skin=skin)
        if [p.name[len(tag) + 1:] for p in a] != [p.name[len(tag) + 1:] for p in b]:
            problems.append("renders differ in poses")
        shown = json.loads((work / f"a{tag}.frame.json").read_text())
        if any(v is None for v in shown["frame"].values()):
            # No bounds in the file and nothing drawn in the setup pose: nothing to frame.
            row.status, row.cause = "not rendered", "the setup pose draws nothing and the file has no bounds"
            return row
        drawn = {re.sub(r"[^\w@.+-]", "~", pose["label"]): pose["attachments"]
                 for pose in json.loads((work / f"a{tag}.dump.json").read_text())["poses"]}
        for pa, pb in zip(a, b):
            d = render_difference(pa, pb, tol=TOLERANCE, where=100_000)
            row.renders += 1
            row.worst = max(row.worst, d["worst"])
            row.off += d["off"]
            row.off_share = max(row.off_share, d["off_share"])
            row.lost += d["lost"]
            row.added += d["added"]
            changed = d["lost_where"] + d["added_where"]
            label = pa.name[len(tag) + 2:-len(".png")]
            ties = edge_distances(changed, drawn.get(label, []), shown["frame"], shown["ppu"]) <= TIE_PX
            row.ties += int(ties.sum())
            if d["off_share"] > max_share or not ties.all():
                problems.append(f"{pb.name}: worst {d['worst']}, off {d['off']} ({d['off_share']:.2e}), "
                                f"lost {d['lost']} at {d['lost_where'][:5]}, added {d['added']} at "
                                f"{d['added_where'][:5]}, {int(ties.sum())} of them ties on a quad edge")
        ok, text = compare_dumps(tool, checked, work / f"b{tag}.dump.json")
        if not ok:
            dumps_ok = False
            fails = [line for line in text.splitlines() if line.startswith("FAIL")] or text.strip().splitlines()[-1:]
            problems.append("dump: " + " | ".join(fails)[:600])
    row.dump_ok = dumps_ok
    row.details = problems
    row.status = "FAIL" if problems else "pass"
    if problems:
        row.cause = CAUSES.get((row.project, row.skeleton), "not explained")
    return row


def prove_project(tool: Path, project: Path, work: Path, mesh_cache: dict | None = None,
                  animations: int = ANIMATIONS, options: Options | None = None) -> list[Row]:
    """Upgrade ``project`` (a folder, or one skeleton file) into ``work`` and prove each skeleton.

    Returns one :class:`Row` per skeleton.
    """
    out = work / "out"
    given = project
    skeletons = find_project(project).skeletons
    if project.is_file():
        project = project.parent
    name = project.name
    versions = {}
    for skeleton in skeletons:
        try:
            versions[skeleton] = spine_version(load_skeleton(skeleton))
        except SpineMeshError:
            versions[skeleton] = "?"
    if not any(v[:3] in RENDERABLE for v in versions.values()):
        # Nothing the harness can render: not worth meshing here.
        return [Row(name, s.relative_to(project).as_posix(), v, status="not rendered",
                    cause=f"Spine {v}: the harness has no runtime for it") for s, v in versions.items()]
    try:
        result = upgrade_project(given, out, options or Options(), mesh_cache=mesh_cache)
    except SpineMeshError as e:
        return [Row(name, "-", status="FAIL", cause=f"upgrade refused the project: {e}")]
    rows = []
    for skeleton in skeletons:
        rel = skeleton.relative_to(project).as_posix()
        row = Row(name, rel)
        mine = [t for t in result.targets if t.skeleton == rel]
        row.regions = len(mine)
        row.meshed = sum(t.status == "meshed" for t in mine)
        row.kept = sum(t.status == "kept" for t in mine)
        failed = {t.reason for t in mine if t.status == "failed"}
        scratch = work / "render" / rel.replace("/", "~")
        scratch.mkdir(parents=True, exist_ok=True)
        try:
            prove_skeleton(tool, project, out, skeleton, scratch, row, animations)
        except (AssertionError, SpineMeshError) as e:  # the harness failed to load or render
            row.status, row.cause = "FAIL", f"harness: {str(e).strip().splitlines()[-1][:300]}"
        if failed and row.status == "pass":
            row.cause = "left regions: " + "; ".join(sorted(failed))[:300]
        rows.append(row)
    return rows


def table(rows: list[Row]) -> str:
    """Markdown table of the rows."""
    head = ("| project | skeleton | version | renders | worst /255 | px > 2/255 | max share | lost | added | "
            "edge ties | dump | meshed | status | cause |\n|---|---|---|---:|---:|---:|---:|---:|---:|---:|---|---|---|---|")
    lines = [head]
    for r in rows:
        dump_ok = "-" if r.dump_ok is None else ("ok" if r.dump_ok else "FAIL")
        lines.append(f"| {r.project} | {r.skeleton} | {r.version} | {r.renders} | {r.worst} | {r.off} | "
                     f"{r.off_share:.2e} | {r.lost} | {r.added} | {r.ties} | {dump_ok} | {r.meshed}/{r.regions} | "
                     f"{r.status} | {r.cause} |")
    return "\n".join(lines)


def summary(rows: list[Row]) -> str:
    rendered = [r for r in rows if r.status != "not rendered"]
    passed = [r for r in rendered if r.passed]
    return (f"{len(passed)}/{len(rendered)} rendered skeletons pass ({len(rows) - len(rendered)} not renderable), "
            f"{sum(r.renders for r in rendered)} renders, {sum(r.meshed for r in rows)}/{sum(r.regions for r in rows)} "
            f"regions meshed")


def prove_each(projects: list[Path], base: Path, prove, json_path: Path | None, clean: bool, rows: list) -> list:
    """Prove project after project (``prove(project, work)`` gives its rows) in ``base/<name>``.

    Prints each row's status and each project's time as it goes, saves every row so far to
    ``json_path`` after each project, and removes each project's scratch folder when ``clean``.
    """
    for project in projects:
        t0 = time.perf_counter()
        work = base / project.name
        shutil.rmtree(work, ignore_errors=True)
        new = prove(project, work)
        rows += new
        for r in new:
            print(f"{r.project}/{r.skeleton}: {r.status} {r.cause} {r.details[:3]}", file=sys.stderr, flush=True)
        print(f"  {project.name}: {time.perf_counter() - t0:.1f} s", file=sys.stderr, flush=True)
        if json_path:
            json_path.parent.mkdir(parents=True, exist_ok=True)
            json_path.write_text(json.dumps([asdict(r) for r in rows], indent=1))
        if clean:
            shutil.rmtree(work, ignore_errors=True)
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("projects", nargs="*", type=Path, help="project folders (default: every corpus project)")
    ap.add_argument("--only", action="append", default=[], help="glob on project names; repeatable")
    ap.add_argument("--json", type=Path, help="write the rows here as JSON")
    ap.add_argument("--smallest-first", action="store_true", help="prove small projects (bytes on disk) first")
    ap.add_argument("--shard", default="0/1", help="I/N: prove every N-th project from the I-th (parallel runs)")
    ap.add_argument("--mesh-all", action="store_true",
                    help="mesh every region, also those upgrade keeps by default as not worth meshing")
    ap.add_argument("--repack", action="store_true", help="upgrade with --repack (sequences trimmed differently)")
    ap.add_argument("--animations", type=int, default=ANIMATIONS, help="animations sampled per skeleton")
    ap.add_argument("--resume", action="store_true", help="keep the rows already in --json, prove the rest")
    ap.add_argument("--keep", type=Path, help="keep upgrades and renders here (default: a temporary folder)")
    args = ap.parse_args(argv)
    # absolute: the harness runs in the tool's folder, where a relative path means something else
    projects = [p.resolve() for p in args.projects] or sorted(p for p in CORPUS.iterdir() if p.is_dir())
    if args.only:
        projects = [p for p in projects if any(fnmatch.fnmatchcase(p.name, g) for g in args.only)]
    if args.smallest_first:
        projects.sort(key=lambda p: sum(f.stat().st_size for f in p.rglob("*") if f.is_file()))
    shard, shards = (int(v) for v in args.shard.split("/"))
    projects = projects[shard::shards]
    base = Path(tempfile.mkdtemp(prefix="prove-corpus-")) if args.keep is None else args.keep
    tool = install(base / "tool") if not (base / "tool" / "node_modules").is_dir() else base / "tool"
    if tool is None:
        print("Node/npm or the spine-runtime tool is unavailable", file=sys.stderr)
        return 2
    rows, cache = [], {}
    if args.resume and args.json and args.json.is_file():
        rows = [Row(**r) for r in json.loads(args.json.read_text())]
        done = {r.project for r in rows}
        projects = [p for p in projects if p.name not in done]
    options = Options(repack=args.repack, **({"min_saving": None} if args.mesh_all else {}))
    rows = prove_each(projects, base, lambda project, work: prove_project(tool, project, work, cache, args.animations,
                                                                          options), args.json, args.keep is None, rows)
    print(table(rows))
    print()
    print(summary(rows))
    if args.keep is None:
        shutil.rmtree(base, ignore_errors=True)
    return 0 if all(r.passed or r.status == "not rendered" for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
