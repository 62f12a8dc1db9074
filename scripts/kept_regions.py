"""What the regions ``upgrade`` keeps as regions cost ``upgrade --pack``, and what meshing them would save.

``upgrade`` keeps a region a region when a mesh would not pay (:mod:`spinemesh.mesher.worth`:
the art fills the region, scattered islands, a hull that saves too little or needs too many
vertices) and for reasons of its own (sequence frames trimmed differently, ...); ``pack``
then keeps those regions' stored rectangles. This script upgrades every given project twice,
with the default options and with the worth rules off (``Options.min_saving = None``: every
region the rules keep is meshed, whatever its vertex count), and prints, as shares of the
page texels before (each footprint with half the padding, as ``scripts/pack_gap.py`` counts):

- the kept rectangles by why they are kept (upgrade's reason for region attachments, pack's
  otherwise), and for the regions kept by a worth rule, the footprints their meshes would have
  (:func:`spinemesh.pack.outlines.mesh_footprint`) and how many vertices those meshes need;
- how many of them a rule "mesh it when its footprint saves at least this share of its
  rectangle" would mesh, and what it would save;
- ``pack_gap``'s need, bound and reached for both upgrades: what packing reaches once they are
  meshed; and the page texels ``pack`` saves after each, as ``benchmarks/bench_pack.py``'s (b)
  counts them.

Usage::

    .venv/bin/python scripts/kept_regions.py PROJECT [PROJECT ...] [--json rows.json]
    .venv/bin/python scripts/kept_regions.py --tables-from rows.json
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import statistics
import sys
import tempfile
from collections import defaultdict
from dataclasses import asdict, dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "scripts"))

from pack_gap import GapRow, project_gaps, share  # noqa: E402

from spinemesh.errors import SpineMeshError  # noqa: E402
from spinemesh.images.decode import load_rgba  # noqa: E402
from spinemesh.images.sources import AtlasImages  # noqa: E402
from spinemesh.pack.atlas_pack import RING_TEXELS, _items, default_padding  # noqa: E402
from spinemesh.pack.uses import collect_uses  # noqa: E402
from spinemesh.project import find_project, project_atlases  # noqa: E402

#: The worth rules, by a phrase of the reason each writes (spinemesh.mesher.worth), in its order.
WORTH_RULES = (
    ("the art fills", "worth rule 1: the art fills the region"),
    ("separate islands of art", "worth rule 2: scattered islands"),
    ("fewer pixels than the region", "worth rule 3: the hull saves too few pixels"),
    ("vertices (more than", "worth rule 3: too many hull vertices for the pixels saved"),
)

#: Shares of its rectangle a meshed region's footprint must save, for the threshold table.
THRESHOLDS = (0.0, 0.1, 0.25, 0.5)


@dataclass
class KeptRow:
    """One region that keeps its stored rectangle after ``upgrade`` with the default options.

    Attributes
    ----------
    project, atlas, region : str
    why : str
        Why it is kept: a worth rule's label, upgrade's other reason, or pack's reason.
    before : int
        The atlas's page texels before.
    rectangle : int
        Its rectangle footprint's texels, with half the padding.
    footprint : int
        Its footprint's texels, with half the padding, once meshed with the worth rules off;
        0 when it keeps its rectangle then too.
    vertices : int
        The most vertices of a mesh drawing it, with the worth rules off (0: not meshed).
    """

    project: str
    atlas: str
    region: str
    why: str
    before: int
    rectangle: int
    footprint: int = 0
    vertices: int = 0


@dataclass
class ProjectRows:
    """Everything measured on one project: its kept regions and pack_gap's rows of both upgrades."""

    kept: list[KeptRow] = field(default_factory=list)
    gap_default: list[GapRow] = field(default_factory=list)
    gap_relaxed: list[GapRow] = field(default_factory=list)
    #: per atlas (``project/atlas``): page texels before, after ``pack`` of each upgrade (as
    #: ``benchmarks/bench_pack.py``'s (b) counts them: lossy WebP atlases kept)
    packed: dict[str, list[int]] = field(default_factory=dict)


def worth_rule(reason: str) -> str:
    """The label of the worth rule that wrote ``reason``, or ``""`` when none did."""
    for phrase, label in WORTH_RULES:
        if phrase in reason:
            return label
    return ""


def general(reason: str) -> str:
    """``reason`` without what names one region, skeleton or count, nor its explanation, to group like reasons."""
    reason = re.sub(r" \([^()]*\)$", "", reason).split(";")[0].split(", so ")[0]
    return re.sub(r"[0-9][0-9,.]*", "N", reason)


def upgrade_reasons(result) -> dict[str, str]:
    """Region (image path) -> why ``upgrade`` kept an attachment drawing it, the first such reason."""
    why: dict[str, str] = {}
    for t in result.targets:
        if t.status in ("kept", "failed", "skipped"):
            for path in t.paths:
                why.setdefault(path, worth_rule(t.reason) or f"{t.status}: {general(t.reason)}")
    return why


def upgrade_both(project: Path, scratch: Path) -> tuple[Path, Path, dict[str, str]]:
    """``project`` upgraded with the default options and with the worth rules off, and upgrade's reasons.

    Returns
    -------
    (default, relaxed, reasons)
        The two output folders, and per region the reason the default upgrade kept it.
    """
    from spinemesh.upgrade import Options, upgrade_project

    default, relaxed = scratch / "default" / project.name, scratch / "relaxed" / project.name
    for out in (default, relaxed):
        shutil.rmtree(out, ignore_errors=True)
    result = upgrade_project(project, default, Options(jobs=1))
    upgrade_project(project, relaxed, Options(jobs=1, min_saving=None))
    return default, relaxed, upgrade_reasons(result)


def _atlas_items(root: Path) -> dict:
    """The project at ``root``, atlas by atlas (path relative to ``root``).

    Returns
    -------
    dict
        ``rel -> (page texels, half the padding, items, vertices)``: the items as ``pack``
        makes them (:func:`spinemesh.pack.atlas_pack._items`), and per region drawn by meshes
        only, the most vertices of one of them.
    """
    proj = find_project(root)
    uses = collect_uses(proj)
    out = {}
    for path, atlas in project_atlases(proj).items():
        pixels = [load_rgba(AtlasImages.page_path(atlas, p.name, proj.root)) for p in atlas.pages]
        geometries = [r.geometry(str(path)) for r in atlas.regions]
        half = int(round(max(0, default_padding(atlas, geometries) - RING_TEXELS) / 2))
        items = _items(atlas, geometries, pixels, uses.regions.get(path, {}), "", True)
        meshes = {name: max(len(m.uvs) for m in u.meshes) for name, u in uses.regions.get(path, {}).items()
                  if u.meshes and not u.pinned}
        out[path.relative_to(proj.root).as_posix()] = (sum(p.shape[0] * p.shape[1] for p in pixels), half, items,
                                                        meshes)
    return out


def kept_rows(name: str, default: Path, relaxed: Path, reasons: dict[str, str]) -> list[KeptRow]:
    """Every region the default upgrade's pack keeps by its rectangle, with its footprint once meshed."""
    after = _atlas_items(relaxed)
    rows = []
    for rel, (before, half, items, _) in _atlas_items(default).items():
        _, _, relaxed_items, vertices = after[rel]
        for it, again in zip(items, relaxed_items):
            if it.foot.by_outline:
                continue
            region = it.region.name
            why = reasons.get(region, "") if "region attachment" in it.foot.reason else ""
            row = KeptRow(name, rel, region, why or general(it.foot.reason), before, share(it.foot.core, half))
            if again.region.name == region and again.foot.by_outline:
                row.footprint, row.vertices = share(again.foot.core, half), vertices.get(region, 0)
            rows.append(row)
    return rows


def packed_texels(root: Path, scratch: Path) -> dict[str, tuple[int, int]]:
    """Per atlas (path relative to ``root``): page texels before and after ``pack`` of the project at ``root``."""
    from spinemesh.pack.report import PackResult
    from spinemesh.pack.run import PackOptions, pack_project_into

    out = scratch / "packed"
    shutil.rmtree(out, ignore_errors=True)
    result = PackResult()
    try:
        pack_project_into(find_project(root), out, PackOptions(), result)
    finally:
        shutil.rmtree(out, ignore_errors=True)
    return {a.atlas: (a.texels_before, a.texels_after) for a in result.atlases}


def measure(project: Path, scratch: Path) -> ProjectRows:
    """Both upgrades of one project, its kept regions, and pack_gap's rows and pack's page texels of each."""
    default, relaxed, reasons = upgrade_both(project, scratch)
    try:
        rows = ProjectRows(kept_rows(project.name, default, relaxed, reasons),
                           project_gaps(default), project_gaps(relaxed))
        first, second = packed_texels(default, scratch), packed_texels(relaxed, scratch)
        rows.packed = {f"{project.name}/{rel}": [before, after, second[rel][1]]
                       for rel, (before, after) in first.items() if rel in second}
        return rows
    finally:
        shutil.rmtree(default, ignore_errors=True)
        shutil.rmtree(relaxed, ignore_errors=True)


def _p(part: int, whole: int) -> str:
    return f"{part / whole:.2%}" if whole else "-"


def reasons_table(rows: list[KeptRow], before: int) -> str:
    """Kept rectangles by why, and what the worth rules' regions would take once meshed."""
    groups: dict[str, list[KeptRow]] = defaultdict(list)
    for r in rows:
        groups[r.why].append(r)
    lines = ["| why kept | regions | rectangles | meshed with the worth rules off: footprints | saved | "
             "most vertices |", "|---|---:|---:|---:|---:|---:|"]
    for why, group in sorted(groups.items(), key=lambda kv: -sum(r.rectangle for r in kv[1])):
        rect = sum(r.rectangle for r in group)
        meshed = [r for r in group if r.footprint]
        foot = sum(r.footprint for r in meshed) + sum(r.rectangle for r in group if not r.footprint)
        cells = (f"{_p(foot, before)} | {_p(rect - foot, before)} | {max(r.vertices for r in meshed)}"
                 if meshed else "- | - | -")
        lines.append(f"| {why} | {len(group)} | {_p(rect, before)} | {cells} |")
    return "\n".join(lines)


def threshold_table(rows: list[KeptRow], before: int) -> str:
    """A rule "mesh a kept region when its footprint saves this share of its rectangle": what it meshes and saves."""
    labels = {label for _, label in WORTH_RULES}
    meshed = [r for r in rows if r.footprint and r.why in labels]
    lines = ["| footprint saves at least | regions meshed | their rectangles | their footprints | saved | "
             "vertices: median, most |", "|---:|---:|---:|---:|---:|---:|"]
    for t in THRESHOLDS:
        pick = [r for r in meshed if r.footprint <= (1 - t) * r.rectangle]
        rect, foot = sum(r.rectangle for r in pick), sum(r.footprint for r in pick)
        verts = f"{statistics.median(r.vertices for r in pick):.0f}, {max(r.vertices for r in pick)}" if pick else "-"
        lines.append(f"| {t:.0%} | {len(pick)} | {_p(rect, before)} | {_p(foot, before)} | "
                     f"{_p(rect - foot, before)} | {verts} |")
    return "\n".join(lines)


def gap_table(default: list[GapRow], relaxed: list[GapRow]) -> str:
    """pack_gap's totals and medians for both upgrades, side by side."""
    before = sum(r.before for r in default)
    parts = [("kept rectangles", lambda r: r.kept), ("outline footprints", lambda r: r.outline),
             ("need = kept + outline", lambda r: r.kept + r.outline),
             ("bound (smallest allowed pages holding need)", lambda r: r.bound),
             ("reached by pack", lambda r: r.reached)]
    lines = ["| share of page texels before | default upgrade: total | median atlas | worth rules off: total | "
             "median atlas |", "|---|---:|---:|---:|---:|"]
    for label, f in parts:
        cells = [f"{sum(f(r) for r in rs) / before:.2%} | {statistics.median(f(r) / r.before for r in rs):.1%}"
                 for rs in (default, relaxed)]
        lines.append(f"| {label} | {cells[0]} | {cells[1]} |")
    relaxed_of = {(r.project, r.atlas): r for r in relaxed}
    pairs = [(d, relaxed_of[d.project, d.atlas]) for d in default if (d.project, d.atlas) in relaxed_of]
    # an atlas whose packing changes, or whose need falls by a thousandth of all page texels or more
    changed = [(d, r) for d, r in pairs
               if d.reached != r.reached or (d.kept + d.outline) - (r.kept + r.outline) >= before / 1000]
    lines += ["", f"atlases whose packed page texels or need change (by 0.1% of all page texels): {len(changed)}"]
    lines += [f"- {d.project}/{d.atlas} ({d.before / before:.1%} of all page texels): need "
              f"{_p(d.kept + d.outline, d.before)} -> {_p(r.kept + r.outline, r.before)}, reached "
              f"{_p(d.reached, d.before)} -> {_p(r.reached, r.before)}"
              + ("" if r.status == "packed" else " (kept as it was)") for d, r in changed]
    return "\n".join(lines)


def packed_table(packed: dict[str, list[int]]) -> str:
    """``pack``'s page texels saved after each upgrade, lossy WebP atlases kept (bench_pack.py's (b))."""
    if not packed:
        return ""
    rows = list(packed.values())
    before = sum(r[0] for r in rows)
    lines = ["| pack after | page texels saved (total) | median atlas | atlases larger | page texels |",
             "|---|---:|---:|---:|---:|"]
    for label, i in (("the default upgrade", 1), ("the upgrade with the worth rules off", 2)):
        after = sum(r[i] for r in rows)
        median = statistics.median(1 - r[i] / r[0] for r in rows if r[0])
        lines.append(f"| {label} | {1 - after / before:.2%} | {median:.1%} | {sum(r[i] > r[0] for r in rows)} | "
                     f"{after:,} |")
    return "\n".join(lines)


def report(rows: ProjectRows) -> str:
    before = sum(r.before for r in rows.gap_default)
    parts = [f"{len(rows.gap_default)} atlases, {before:,} page texels before",
             reasons_table(rows.kept, before), threshold_table(rows.kept, before),
             gap_table(rows.gap_default, rows.gap_relaxed), packed_table(rows.packed)]
    return "\n\n".join(p for p in parts if p)


def _load(paths: list[Path]) -> ProjectRows:
    rows = ProjectRows()
    for f in paths:
        saved = json.loads(f.read_text())
        rows.kept += [KeptRow(**r) for r in saved["kept"]]
        rows.gap_default += [GapRow(**r) for r in saved["gap_default"]]
        rows.gap_relaxed += [GapRow(**r) for r in saved["gap_relaxed"]]
        rows.packed.update(saved.get("packed", {}))
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("projects", nargs="*", type=Path)
    ap.add_argument("--json", type=Path, help="write the rows here (after each project)")
    ap.add_argument("--tables-from", type=Path, nargs="+", metavar="JSON", help="print the tables of saved rows")
    args = ap.parse_args(argv)
    rows = _load(args.tables_from) if args.tables_from else ProjectRows()
    scratch = Path(tempfile.mkdtemp(prefix="kept-regions-"))
    try:
        for project in args.projects:
            try:
                part = measure(project.resolve(), scratch)
            except SpineMeshError as e:
                print(f"{project.name}: {e}", file=sys.stderr)
                continue
            rows.kept += part.kept
            rows.gap_default += part.gap_default
            rows.gap_relaxed += part.gap_relaxed
            rows.packed.update(part.packed)
            print(f"  {project.name}", file=sys.stderr, flush=True)
            if args.json:
                args.json.write_text(json.dumps(asdict(rows), indent=1))
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    print(report(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
