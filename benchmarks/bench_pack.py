"""Page texels, pages and bytes that ``spinemesh pack`` saves, against a rectangle-only repack.

For every atlas of the given projects (default: the 3.8-4.2 examples and the corpus beside the
repository, ``../shared``), side by side:

- *before*: the atlas as exported;
- *(a) pack*: ``spinemesh pack`` on the project as it is (the artists' own meshes);
- *(b) upgrade + pack*: ``spinemesh upgrade`` (default options), then ``pack`` of its output,
  which is what ``upgrade --pack`` runs;
- *(c) rectangles*: the same regions' stored rectangles repacked by ``rectpack`` (MaxRects,
  best short side fit, 90-degree rotation allowed), with the same padding and page rules as
  ``pack`` (no side over the longest original side, no page over the largest original page's
  texels, powers of two where the originals had them, no more pages than before, the
  original kept when it is not beaten).

Page texels are what a GPU holds; bytes are the atlas and page files on disk (PNG as
``pack`` writes them). Time is ``pack``'s CPU time per atlas (one core) (reading pages, placing,
compositing, encoding); (c)'s is rectpack's, for comparison. The summaries are printed for the
examples and the corpus apart, then for both.

Usage::

    .venv/bin/python benchmarks/bench_pack.py [PROJECT ...] [--no-upgrade] [--json rows.json]
        [--pages original any] [--upgraded DIR]

Without projects it runs over the examples and the whole corpus; upgrading the corpus takes a
while, so run that in the background (``nice``).
"""

from __future__ import annotations

import argparse
import json
import math
import shutil
import statistics
import sys
import tempfile
import time
from dataclasses import asdict, dataclass
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from spinemesh.atlas import read_atlas  # noqa: E402
from spinemesh.errors import SpineMeshError  # noqa: E402
from spinemesh.images.sources import AtlasImages  # noqa: E402
from spinemesh.pack.atlas_pack import (  # noqa: E402
    PageRules, candidate_widths, default_padding, is_power_of_two, round_page,
)
from spinemesh.pack.report import PackResult  # noqa: E402
from spinemesh.pack.run import PackOptions, pack_project_into  # noqa: E402
from spinemesh.project import find_project, project_atlases  # noqa: E402

SHARED = REPO.parent / "shared"
VERSIONS = ("3.8", "4.0", "4.1", "4.2")


@dataclass
class Row:
    project: str
    atlas: str
    regions: int = 0
    pages: int = 0
    texels: int = 0
    bytes: int = 0
    a_texels: int = 0
    a_pages: int = 0
    a_bytes: int = 0
    a_outline: int = 0
    a_seconds: float = 0.0
    b_texels: int | None = None
    b_pages: int | None = None
    b_bytes: int | None = None
    b_outline: int | None = None
    b_seconds: float | None = None
    c_texels: int = 0
    c_pages: int = 0
    c_seconds: float = 0.0
    a_footprints: int = 0  # packed: the footprints' texels with their share of the padding (0 when kept)
    b_footprints: int | None = None
    #: other page rules (``--pages``): name -> {"a"/"b": [texels, pages, bytes, footprints, why kept]}
    rules: dict | None = None
    a_reason: str = ""  # the report's reason for (a): why it was kept, or written otherwise ("" when packed)
    b_reason: str | None = None
    pot: bool | None = None  # every original page's sides are powers of two (None: not recorded)


def rectangle_repack(atlas, sizes_before: list[tuple[int, int]]) -> tuple[int, int]:
    """Page texels and pages of the stored rectangles repacked by rectpack under pack's page rules."""
    import rectpack

    geometries = [r.geometry() for r in atlas.regions]
    pad = default_padding(atlas, geometries)
    side = max(max(s) for s in sizes_before)
    max_area = max(w * h for w, h in sizes_before)
    pot = all(is_power_of_two(w) and is_power_of_two(h) for w, h in sizes_before)
    before = sum(w * h for w, h in sizes_before)
    rects = [(g.page_width + pad, g.page_height + pad) for g in geometries]
    area = sum(w * h for w, h in rects)
    widest = max(min(w, h) for w, h in rects)
    best = (before, len(sizes_before))
    for width in candidate_widths(area, widest, side, pot):
        packer = rectpack.newPacker(mode=rectpack.PackingMode.Offline, pack_algo=rectpack.MaxRectsBssf,
                                    sort_algo=rectpack.SORT_AREA, rotation=True)
        for i, (w, h) in enumerate(rects):
            packer.add_rect(w, h, rid=i)
        packer.add_bin(width, side, count=len(sizes_before))
        packer.pack()
        placed = packer.rect_list()
        if len(placed) < len(rects):
            continue
        used: dict[int, list[int]] = {}
        for b, x, y, w, h, _ in placed:
            u = used.setdefault(b, [0, 0])
            u[0], u[1] = max(u[0], x + w - pad), max(u[1], y + h - pad)
        pages = [(round_page(w, side, pot), round_page(h, side, pot)) for w, h in used.values()]
        if any(w * h > max_area for w, h in pages):
            continue
        texels = sum(w * h for w, h in pages)
        if texels < best[0]:
            best = (texels, len(pages))
    return best


def pack_rows(project: Path, scratch: Path, sides: str = "original", larger_files: bool = False) -> dict[str, dict]:
    """``pack`` of one project into ``scratch`` under the page rules ``sides`` (one process): per atlas
    (relative path), its report row. ``larger_files``: as ``--larger-files`` (an atlas whose files
    would take more bytes is written all the same)."""
    out = scratch / "packed"
    shutil.rmtree(out, ignore_errors=True)
    result = PackResult()
    pack_project_into(find_project(project), out, PackOptions(rules=PageRules(sides), larger_files=larger_files),
                      result)
    return {a.atlas: a for a in result.atlases}


def _other_rules(rows: dict[str, Row], project: Path, scratch: Path, key: str, sides: list[str],
                 larger_files: bool = False) -> None:
    """Pack ``project`` again under each page rule of ``sides`` but the original: into ``rows[..].rules``."""
    for name in sides:
        if name == "original":
            continue
        for rel, a in pack_rows(project, scratch / f"{key}-{name}", name, larger_files).items():
            if rel in rows:
                r = rows[rel]
                r.rules = r.rules or {}
                r.rules.setdefault(name, {})[key] = [a.texels_after, a.pages_after, a.bytes_after,
                                                      a.texels_used or 0,
                                                      a.reason]


def bench_project(project: Path, scratch: Path, upgrade: bool, sides: list[str] = ("original",),
                  upgraded: Path | None = None, larger_files: bool = False) -> list[Row]:
    """One project's rows; ``upgraded``: a folder keeping ``upgrade``'s output of each project, reused when
    there; ``larger_files``: pack as ``--larger-files`` does."""
    proj = find_project(project)
    rows: dict[str, Row] = {}
    for path, atlas in project_atlases(proj).items():
        rel = path.relative_to(project).as_posix()
        files = [AtlasImages.page_path(atlas, p.name, project) for p in atlas.pages]
        from PIL import Image

        sizes = []
        for f in files:
            with Image.open(f) as im:
                sizes.append(im.size)
        row = Row(project_label(project), rel, len(atlas.regions), len(atlas.pages), sum(w * h for w, h in sizes),
                  sum(f.stat().st_size for f in set(files)) + path.stat().st_size,
                  pot=all(is_power_of_two(w) and is_power_of_two(h) for w, h in sizes))
        t0 = time.process_time()
        try:
            row.c_texels, row.c_pages = rectangle_repack(read_atlas(path), sizes)
        except SpineMeshError:
            row.c_texels, row.c_pages = row.texels, row.pages
        row.c_seconds = round(time.process_time() - t0, 3)
        rows[rel] = row
    for rel, a in pack_rows(project, scratch / "a", larger_files=larger_files).items():
        if rel in rows:
            r = rows[rel]
            r.a_texels, r.a_pages, r.a_bytes, r.a_outline, r.a_seconds = (
                a.texels_after, a.pages_after, a.bytes_after, a.by_outline, a.cpu_seconds)
            r.a_footprints = a.texels_used or 0
            r.a_reason = a.reason
    _other_rules(rows, project, scratch, "a", sides, larger_files)
    if upgrade:
        from spinemesh.upgrade import Options, upgrade_project

        up = scratch / "upgraded" if upgraded is None else upgraded / project.name
        try:
            if upgraded is None or not (up / ".upgraded").exists():
                shutil.rmtree(up, ignore_errors=True)
                upgrade_project(project, up, Options(jobs=1))
                if upgraded is not None:
                    (up / ".upgraded").write_text("")  # whole: reused by later runs
        except SpineMeshError as e:
            print(f"{project.name}: upgrade refused: {e}", file=sys.stderr)
        else:
            for rel, b in pack_rows(up, scratch / "b", larger_files=larger_files).items():
                if rel in rows:
                    r = rows[rel]
                    r.b_texels, r.b_pages, r.b_bytes, r.b_outline, r.b_seconds = (
                        b.texels_after, b.pages_after, b.bytes_after, b.by_outline, b.cpu_seconds)
                    r.b_footprints = b.texels_used or 0
                    r.b_reason = b.reason
            _other_rules(rows, up, scratch, "b", sides, larger_files)
    return list(rows.values())


def _pct(before: int, after: int | None) -> str:
    return "-" if after is None or not before else f"{after / before - 1:+.1%}"


def table(rows: list[Row]) -> str:
    lines = ["| project | atlas | regions | pages | page texels | (a) pack | (b) upgrade+pack | (c) rectangles | "
             "bytes | (a) bytes | (b) bytes | (a) CPU s | (b) CPU s | (c) CPU s |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        lines.append(f"| {r.project} | {r.atlas} | {r.regions} | {r.pages} | {r.texels:,} | {_pct(r.texels, r.a_texels)} | "
                     f"{_pct(r.texels, r.b_texels)} | {_pct(r.texels, r.c_texels)} | {r.bytes:,} | "
                     f"{_pct(r.bytes, r.a_bytes)} | {_pct(r.bytes, r.b_bytes)} | {r.a_seconds:.2f} | "
                     f"{'-' if r.b_seconds is None else f'{r.b_seconds:.2f}'} | {r.c_seconds:.2f} |")
    return "\n".join(lines)


def bytes_lines(rows: list[Row]) -> list[str]:
    """Bytes on disk (atlas and page files) before and after (a) and (b): in total, and how many
    atlases took more or fewer bytes than before."""
    lines = ["| bytes on disk | before | after | change | atlases with more bytes | with fewer | largest growth |",
             "|---|---:|---:|---:|---:|---:|---:|"]
    for label, key in (("(a) pack as exported", "a_bytes"), ("(b) upgrade + pack", "b_bytes")):
        use = [r for r in rows if getattr(r, key) is not None and r.bytes]
        if not use:
            continue
        before, after = sum(r.bytes for r in use), sum(getattr(r, key) for r in use)
        growth = max((getattr(r, key) / r.bytes - 1 for r in use), default=0.0)
        lines.append(f"| {label} | {before:,} | {after:,} | {after / before - 1:+.1%} | "
                     f"{sum(getattr(r, key) > r.bytes for r in use)} | {sum(getattr(r, key) < r.bytes for r in use)} | "
                     f"{growth:+.1%} |")
    return lines


def summary(rows: list[Row]) -> str:
    def total(key: str) -> int:
        return sum(getattr(r, key) or 0 for r in rows)

    def saving(key: str, of: str = "texels", only=None) -> tuple[float, float, int]:
        use = [r for r in rows if getattr(r, key) is not None and (only is None or only(r))]
        before = sum(getattr(r, of) for r in use)
        after = sum(getattr(r, key) for r in use)
        per = [1 - getattr(r, key) / getattr(r, of) for r in use if getattr(r, of)]
        return (1 - after / before if before else 0.0), (statistics.median(per) if per else 0.0), \
            sum(1 for r in use if getattr(r, key) > getattr(r, of))

    has_b = [r for r in rows if r.b_texels is not None]
    lines = ["| | page texels saved (total) | median atlas | atlases larger | pages before -> after | bytes on disk |",
             "|---|---:|---:|---:|---:|---:|"]
    for label, key, pages, byte_key, only in (
            ("(a) pack as exported", "a_texels", "a_pages", "a_bytes", None),
            ("(b) upgrade + pack", "b_texels", "b_pages", "b_bytes", lambda r: r.b_texels is not None),
            ("(c) rectangles only (rectpack)", "c_texels", "c_pages", None, None),
            ("(c) on the atlases of (b)", "c_texels", "c_pages", None, lambda r: r.b_texels is not None)):
        tot, med, larger = saving(key, only=only)
        use = [r for r in rows if only is None or only(r)]
        byte = f"{-saving(byte_key, 'bytes', only)[0]:+.1%}" if byte_key else "-"
        lines.append(f"| {label} | {tot:.1%} | {med:.1%} | {larger} | {sum(r.pages for r in use)} -> "
                     f"{sum(getattr(r, pages) or 0 for r in use)} | {byte} |")
    for name in sorted({n for r in rows for n in (r.rules or {})}):
        for key, label in (("a", "pack as exported"), ("b", "upgrade + pack")):
            use = [r for r in rows if (r.rules or {}).get(name, {}).get(key)]
            if not use:
                continue
            before = sum(r.texels for r in use)
            after = sum(r.rules[name][key][0] for r in use)
            per = [1 - r.rules[name][key][0] / r.texels for r in use if r.texels]
            nbytes = sum(r.bytes for r in use)
            lines.append(f"| ({key}) {label}, --pages {name} | {1 - after / before:.1%} | "
                         f"{statistics.median(per):.1%} | {sum(r.rules[name][key][0] > r.texels for r in use)} | "
                         f"{sum(r.pages for r in use)} -> {sum(r.rules[name][key][1] for r in use)} | "
                         f"{sum(r.rules[name][key][2] for r in use) / nbytes - 1:+.1%} |")
    lines.append("")
    lines += bytes_lines(rows)
    lines.append("")
    lines += fill_lines(rows)
    saved_a = total("texels") - total("a_texels")
    saved_c = total("texels") - total("c_texels")
    b_rows_before = sum(r.texels for r in has_b)
    saved_b = b_rows_before - sum(r.b_texels for r in has_b)
    saved_cb = b_rows_before - sum(r.c_texels for r in has_b)
    lines.append("")
    lines.append(f"outline over rectangle saving: (a) {saved_a / saved_c if saved_c else math.inf:.2f}x, "
                 f"(b) {saved_b / saved_cb if saved_cb else math.inf:.2f}x")
    times = [r.a_seconds for r in rows] + [r.b_seconds for r in has_b]
    big = [r for r in rows if r.regions >= 200]
    lines.append(f"pack CPU time per atlas: median {statistics.median(times):.2f} s, max {max(times):.2f} s"
                 + (f"; atlases of 200+ regions: max {max(max(r.a_seconds, r.b_seconds or 0) for r in big):.2f} s"
                    if big else ""))
    rect_times = [r.c_seconds for r in rows]
    lines.append(f"rectpack CPU time per atlas: median {statistics.median(rect_times):.2f} s, "
                 f"max {max(rect_times):.2f} s")
    return "\n".join(lines)


def limit_of(reason: str, fill: float) -> str:
    """What decides an atlas's page texels, in a few words, from the report's ``reason``: the bytes
    rules, the footprints' need, the power-of-two page sizes, or the placement (with the ``fill`` a
    packed atlas reached)."""
    if "rectangles' texels only" in reason:
        return "bytes: written as it was, with the rectangles' texels only"
    if "another layout" in reason:
        return f"bytes: packed in the next layout of fewer bytes, {fill:.0%} full"
    if not reason:
        return f"placement: packed, {fill:.0%} full"
    if "lossy WebP" in reason:
        return "bytes: lossy WebP pages would grow written losslessly"
    if "--larger-files" in reason:
        return "bytes: the files would grow"
    if "under the page rules" in reason:
        return "page rule: the pages the rules allow hold less than the footprints need"
    if "regions need" in reason:
        need = reason.split("need ")[1].split(" of")[0] + " of the page texels"
        if "no packing" in reason:
            return f"need: the footprints need {need}"
        if "power-of-two" in reason:
            return f"page rule: the footprints need {need};{reason.split(';', 1)[1]}"
        return f"placement: the footprints need {need}, no fill placed them on fewer"
    if "no fewer than" in reason:
        return "placement: packed, no fewer page texels"
    return reason[:60]


def limits_table(rows: list[Row], rule: str, gaps: list[dict] | None = None) -> str:
    """Per atlas, what ``upgrade --pack`` (b) saved under the page rule ``rule`` and what limits it
    (:func:`limit_of`), with a count per limit. ``gaps``: rows of ``scripts/pack_gap.py --json`` of the
    upgraded projects under the same rule: the footprints' need and what placement alone reaches
    (no bytes rule) join the table."""
    gap = {(g["project"], g["atlas"]): g for g in gaps or []}

    def outcome(r: Row) -> tuple[int, int, str] | None:
        if rule == "original":
            return (r.b_texels, r.b_footprints or 0, r.b_reason or "") if r.b_texels is not None else None
        got = (r.rules or {}).get(rule, {}).get("b")
        return (got[0], got[3], got[4] if len(got) > 4 else "") if got else None

    extra = " footprints with their padding | placement alone saves |" if gap else ""
    lines = [f"| project | atlas | page texels | (b) saved, --pages {rule} |{extra} what limits it |",
             "|---|---|---:|---:|" + ("---:|---:|" if gap else "") + "---|"]
    counts: dict[str, int] = {}
    for r in rows:
        got = outcome(r)
        if got is None:
            continue
        texels, footprints, reason = got
        why = limit_of(reason, footprints / texels if texels else 0.0)
        counts[why.split(":")[0]] = counts.get(why.split(":")[0], 0) + 1
        g = gap.get((r.project.split("/")[-1], r.atlas))
        cells = (f" {(g['kept'] + g['outline']) / g['before']:.0%} | {1 - g['reached'] / g['before']:.1%} |"
                 if g else " - | - |") if gap else ""
        lines.append(f"| {r.project.split('/')[-1]} | {r.atlas} | {r.texels:,} | {1 - texels / r.texels:.1%} |{cells} {why} |")
    lines.append("")
    lines.append("atlases by what limits them: " + ", ".join(f"{k} {v}" for k, v in sorted(counts.items())))
    return "\n".join(lines)


def fill_lines(rows: list[Row]) -> list[str]:
    """How full the pages ``pack`` writes are: footprints (with their share of the padding) over the
    page texels of the atlases it packed, in total and on the median packed atlas, per page rule."""
    lines = ["| fill of the pages written | atlases packed | total | median atlas |", "|---|---:|---:|---:|"]
    sets = [("(a) pack as exported", lambda r: (r.a_texels, r.a_footprints)),
            ("(b) upgrade + pack", lambda r: (r.b_texels, r.b_footprints or 0))]
    for name in sorted({n for r in rows for n in (r.rules or {})}):
        for key, label in (("a", "(a) pack as exported"), ("b", "(b) upgrade + pack")):
            sets.append((f"{label}, --pages {name}",
                         lambda r, n=name, k=key: ((r.rules or {}).get(n, {}).get(k) or [0, 0, 0, 0])[0::3]))
    for label, get in sets:
        # and apart for the atlases of power-of-two pages (under the original rules a page rounds up) and the others
        for part, only in (("", None), (", power-of-two atlases", True), (", other atlases", False)):
            packed = [get(r) for r in rows if get(r)[1] and (only is None or r.pot is only)]
            if packed:
                fills = [f / t for t, f in packed]
                lines.append(f"| {label}{part} | {len(packed)} | "
                             f"{sum(f for _, f in packed) / sum(t for t, _ in packed):.1%} | {statistics.median(fills):.1%} |")
    return lines


def summaries(rows: list[Row]) -> str:
    """:func:`summary` of the examples, of the corpus and of any other projects, one after another."""
    groups: dict[str, list[Row]] = {}
    for r in rows:
        head = r.project.split("/")[0]
        label = {"examples": "Examples (3.8-4.2)", "corpus": "Corpus"}.get(head, "Other projects")
        groups.setdefault(label, []).append(r)
    parts = [f"### {label}: {len({r.project for r in group})} projects, {len(group)} atlases\n\n{summary(group)}"
             for label, group in groups.items()]
    if len(groups) > 1:
        parts.append(f"### All: {len({r.project for r in rows})} projects, {len(rows)} atlases\n\n{summary(rows)}")
    return "\n\n".join(parts)


def ellipse_masks(seed: int, count: int, low: int, high: int) -> list:
    """``count`` filled ellipses ``low`` to ``high`` texels across, each as ``[mask, mask turned 90 degrees]``."""
    import cv2
    import numpy as np

    rng = np.random.default_rng(seed)
    out = []
    for _ in range(count):
        w, h = (int(v) for v in rng.integers(low, high, 2))
        m = np.zeros((h, w), np.uint8)
        cv2.ellipse(m, (w // 2, h // 2), (w // 2 - 1, h // 2 - 1), 0, 0, 360, 1, -1)
        out.append([m.astype(bool), np.ascontiguousarray(np.rot90(m.astype(bool)))])
    return out


def hard_parts(candidates: list, soft: int) -> list | None:
    """Per footprint and turn, its mask shrunk by ``soft`` texels: the rest is a soft ring (None when 0)."""
    import cv2
    import numpy as np

    if soft <= 0:
        return None
    kernel = np.ones((2 * soft + 1, 2 * soft + 1), np.uint8)
    return [[cv2.erode(m.astype(np.uint8), kernel, borderValue=0).astype(bool) for m in masks]
            for masks in candidates]


def placement_timing(count: int = 300, side: int = 2048, seeds: int = 3, soft: int = 0) -> str:
    """CPU seconds to place ``count`` footprints (ellipses, both turns allowed) on ``side`` pages; each
    with a soft ring ``soft`` texels wide (see :func:`hard_parts`)."""
    from spinemesh.pack.place import fill_pages

    lines = [f"| seed | footprints | page | pages used | fill of the used area | CPU s |", "|---:|---:|---|---:|---:|---:|"]
    for seed in range(seeds):
        masks = ellipse_masks(seed, count, 40, 200)
        hard = hard_parts(masks, soft)
        t0 = time.process_time()
        placements, used = fill_pages(masks, side, side, 0, hard=hard)
        seconds = time.process_time() - t0
        area = sum(int(c[0].sum()) for c in masks)
        lines.append(f"| {seed} | {count} | {side}x{side} | {len(used)} | "
                     f"{area / sum(w * h for w, h in used):.1%} | {seconds:.2f} |")
    return "\n".join(lines)


def whole_placement_timing(count: int = 300, side: int = 2048, seeds: int = 3, soft: int = 0) -> str:
    """CPU seconds of every fill ``pack`` tries for one atlas of ``count`` footprints on one ``side`` page.

    Ellipses 40-170 texels across (both turns allowed) fill about 60% of the page, as a full
    atlas page does; the original page is ``side x side``, so the packed one is at most that,
    powers of two or not. ``soft``: each with a soft ring that wide (see :func:`hard_parts`).
    """
    from spinemesh.pack.atlas_pack import _pack_group

    class Item:  # what _pack_group reads of an item: its masks and their hard parts
        def __init__(self, masks, hard):
            self.masks, self.hard_masks = masks, hard or masks

    lines = ["| seed | footprints | original page | powers of two | packed page | fill | CPU s |",
             "|---:|---:|---|---|---|---:|---:|"]
    for seed in range(seeds):
        candidates = ellipse_masks(seed, count, 40, 170)
        hard = hard_parts(candidates, soft) or [None] * count
        items = [Item(masks, h) for masks, h in zip(candidates, hard)]
        area = sum(int(it.masks[0].sum()) for it in items)
        for pot in (True, False):
            t0 = time.process_time()
            _, sizes = _pack_group(items, side, side, side * side, pot, 0, 1)
            seconds = time.process_time() - t0
            lines.append(f"| {seed} | {count} | {side}x{side} | {'yes' if pot else 'no'} | "
                         f"{' + '.join(f'{w}x{h}' for w, h in sizes)} | {area / sum(w * h for w, h in sizes):.1%} | "
                         f"{seconds:.2f} |")
    return "\n".join(lines)


def project_label(project: Path) -> str:
    """``examples/4.2/spineboy`` or ``corpus/jt-mia`` for the development data (example projects of
    different versions share names), else the folder's name."""
    for root, label in ((SHARED / "spine-examples", "examples"), (SHARED / "spine-corpus", "corpus")):
        if project.is_relative_to(root.resolve()):
            return f"{label}/{project.relative_to(root.resolve()).as_posix()}"
    return project.name


def default_projects() -> list[Path]:
    examples = [p for v in VERSIONS for p in sorted((SHARED / "spine-examples" / v).iterdir()) if p.is_dir()]
    corpus = sorted(p for p in (SHARED / "spine-corpus").iterdir() if p.is_dir())
    return examples + corpus


def layouts_table(projects: list[Path], sides: str = "any") -> str:
    """Every layout the fills keep for each atlas of ``projects`` under the page rule ``sides``
    (:func:`spinemesh.pack.atlas_pack.plan_layouts`: the one of fewest page texels, then the
    next ones), each composited and encoded as ``pack`` writes it: its page texels and bytes
    against the atlas as exported, and the CPU seconds of making and encoding it. When the first
    takes more bytes than exported, ``pack`` writes the one of fewest bytes of the others that
    take fewer (``spinemesh.pack.run.next_layout_outcome``)."""
    from spinemesh.images.decode import load_rgba
    from spinemesh.pack.atlas_pack import PackRefused, compose, plan_layouts
    from spinemesh.pack.page_colours import colours_by_settings, packed_page_colours, page_colour
    from spinemesh.pack.page_files import encode_page, page_mode
    from spinemesh.pack.uses import collect_uses

    lines = ["| project | atlas | as exported: page texels | bytes | layout | page texels | bytes | against "
             "exported | CPU s |", "|---|---|---:|---:|---:|---:|---:|---:|---:|"]
    for project in projects:
        proj = find_project(project)
        uses = collect_uses(proj)
        for path, atlas in project_atlases(proj).items():
            files = [AtlasImages.page_path(atlas, p.name, project) for p in atlas.pages]
            texels = [load_rgba(f) for f in files]
            before = sum(f.stat().st_size for f in set(files)) + path.stat().st_size
            head = f"| {project.name} | {path.relative_to(project).as_posix()} | " \
                   f"{sum(t.shape[0] * t.shape[1] for t in texels):,} | {before:,} |"
            try:
                modes = {p.name: page_mode(f) for p, f in zip(atlas.pages, files)}
                group_colour = colours_by_settings(atlas, [page_colour(f.read_bytes()) for f in files])
                layouts = plan_layouts(atlas, texels, uses.regions.get(path, {}), rules=PageRules(sides))
            except PackRefused as e:
                lines.append(f"{head} kept: {e} | | | | |")
                continue
            for rank in range(layouts.count):
                t0 = time.process_time()
                try:
                    packed = compose(layouts, rank)
                    colour = packed_page_colours(packed.atlas, group_colour)
                    size = len(packed.atlas.dumps().encode()) + sum(
                        len(encode_page(page, name, modes.get(name), colour[name]).data)
                        for name, page in packed.pages.items())
                except PackRefused as e:
                    lines.append(f"{head} {rank + 1} | not written: {e} | | | |")
                    continue
                lines.append(f"{head} {rank + 1} | {packed.texels_after:,} | {size:,} | {size / before - 1:+.1%} | "
                             f"{time.process_time() - t0:.2f} |")
    return "\n".join(lines)


def png_encoders(pages: list[Path], levels=(1, 2, 3)) -> str:
    """Bytes and CPU seconds of PNG pages written by Pillow's default and by oxipng at ``levels``,
    every result decoded back and compared texel for texel."""
    import io

    import numpy as np
    import oxipng
    from PIL import Image

    from spinemesh.images.decode import decode_rgba, load_rgba

    cols = ["Pillow (default)"] + [f"oxipng {level}" for level in levels]
    totals = {c: [0, 0.0] for c in cols}
    lines = ["| page | size | original bytes | " + " | ".join(f"{c} bytes | {c} CPU s" for c in cols) + " |",
             "|---|---|---:|" + "---:|---:|" * len(cols)]
    for path in pages:
        rgba = np.ascontiguousarray(load_rgba(path))
        h, w = rgba.shape[:2]
        cells = []
        for c in cols:
            t0 = time.process_time()
            if c.startswith("Pillow"):
                buf = io.BytesIO()
                Image.fromarray(rgba).save(buf, format="PNG")
                data = buf.getvalue()
            else:
                data = oxipng.RawImage(rgba.tobytes(), w, h).create_optimized_png(level=int(c.split()[1]))
            seconds = time.process_time() - t0
            assert np.array_equal(decode_rgba(data), rgba), (path, c)
            totals[c][0] += len(data)
            totals[c][1] += seconds
            cells.append(f"{len(data):,} | {seconds:.2f}")
        lines.append(f"| {path.parent.name}/{path.name} | {w}x{h} | {path.stat().st_size:,} | " + " | ".join(cells) + " |")
    base = totals[cols[0]]
    lines.append(f"| total | | {sum(p.stat().st_size for p in pages):,} | " + " | ".join(
        f"{b:,} ({b / base[0]:.2f}x) | {t:.2f} ({t / base[1]:.1f}x)" for b, t in totals.values()) + " |")
    return "\n".join(lines)


def png_level_pages(projects: list[Path]) -> list[Path]:
    """The PNG atlas pages of ``projects`` (each once), in order: what ``pack`` encodes or
    re-encodes of them. A folder ``pack`` wrote is a project too: its pages are packed pages."""
    pages: list[Path] = []
    for project in projects:
        proj = find_project(project)
        for atlas in project_atlases(proj).values():
            for page in atlas.pages:
                f = AtlasImages.page_path(atlas, page.name, proj.root)
                if f.suffix.lower() == ".png" and f not in pages:
                    pages.append(f)
    return pages


def png_level_child(pages: list[str], level: int) -> list[dict]:
    """In a fresh process (its own oxipng thread pool, sized by ``RAYON_NUM_THREADS``): each page
    through both of ``pack``'s uses of oxipng at ``level``, timed on oxipng's calls alone (wall and
    CPU seconds, its threads' included): written from its texels as a packed page is
    (:func:`spinemesh.pack.page_files.encode_page`: palette, RGB or RGBA as the page was, colour chunks),
    and re-encoded as a kept atlas's page is (:func:`~spinemesh.pack.page_files.reencoded_page`: the
    export's bytes when that is not smaller). ``pack``'s oxipng is as it was on return."""
    from spinemesh.pack import png

    compress, spent = png._compress, [0.0, 0.0]

    def timed(*args, **kwargs):
        w0, c0 = time.perf_counter(), time.process_time()
        try:
            return compress(*args, **kwargs)
        finally:
            spent[0] += time.perf_counter() - w0
            spent[1] += time.process_time() - c0

    level_before, png._compress, png.LEVEL = png.LEVEL, timed, level
    try:
        return [_png_level_row(Path(page), spent) for page in pages]
    finally:
        png._compress, png.LEVEL = compress, level_before


def _png_level_row(path: Path, spent: list) -> dict:
    """One page of :func:`png_level_child`: its texels, export bytes, and per use ``[bytes, wall s,
    CPU s]`` (``spent``: oxipng's seconds, counted by the caller's wrapper)."""
    from spinemesh.images.decode import decode_rgba
    from spinemesh.pack.atlas_pack import PackRefused
    from spinemesh.pack.page_colours import page_colour
    from spinemesh.pack.page_files import encode_page, page_mode, reencoded_page

    data = path.read_bytes()
    rgba = decode_rgba(data, path)
    row = {"page": str(path), "texels": int(rgba.shape[0] * rgba.shape[1]), "export": len(data)}
    for use in ("packed", "kept"):
        spent[:] = [0.0, 0.0]
        if use == "packed":
            size = len(encode_page(rgba, path.name, page_mode(data), page_colour(data)).data)
        else:
            try:
                size = len(reencoded_page(data, rgba, path.name))
            except PackRefused:  # not smaller, or not re-encoded: copied as it is
                size = len(data)
        row[use] = [size, round(spent[0], 3), round(spent[1], 3)]
    return row


def png_levels(projects: list[Path], variants: list[tuple[int, int]]) -> str:
    """oxipng's effort (``level``) and its own threads against what ``pack`` writes today (level 2,
    oxipng's default threads: one per core), on the PNG pages of ``projects``: bytes, wall and CPU
    seconds of oxipng alone, each variant in a fresh process, side by side with its ratio to today's.

    ``variants``: ``(level, threads)``, threads 0 for oxipng's default. Bytes do not depend on the
    threads (the same file either way); time does, and with ``--jobs N`` each of N worker processes
    runs its own oxipng threads.
    """
    import os
    import subprocess

    pages = [str(p) for p in png_level_pages(projects)]
    results = {}
    for level, threads in variants:
        env = dict(os.environ)
        env.pop("RAYON_NUM_THREADS", None)
        if threads:
            env["RAYON_NUM_THREADS"] = str(threads)
        code = (f"import json, sys; sys.path.insert(0, {str(REPO)!r}); sys.path.insert(0, {str(REPO / 'benchmarks')!r}); "
                f"from bench_pack import png_level_child; "
                f"print(json.dumps(png_level_child(json.loads(sys.stdin.read()), {level})))")
        done = subprocess.run([sys.executable, "-c", code], input=json.dumps(pages), capture_output=True, text=True,
                              env=env, check=True)
        results[(level, threads)] = json.loads(done.stdout)
        print(f"  level {level}, threads {threads or 'default'}: done", file=sys.stderr, flush=True)
    base = results[variants[0]]
    texels = sum(r["texels"] for r in base)
    export = sum(r["export"] for r in base)
    lines = [f"{len(pages)} PNG pages, {texels / 1e6:.1f} M texels, {export:,} bytes as exported; oxipng alone, "
             f"ratios to the first row",
             "", "| oxipng | packed page: bytes | wall s | CPU s | kept page re-encoded: bytes | wall s | CPU s |",
             "|---|---:|---:|---:|---:|---:|---:|"]
    first = None
    for (level, threads), rows in results.items():
        sums = {use: [sum(r[use][k] for r in rows) for k in range(3)] for use in ("packed", "kept")}
        first = first or sums
        cells = []
        for use in ("packed", "kept"):
            (b, w, c), (b0, w0, c0) = sums[use], first[use]
            cells += [f"{b:,} ({b / b0 - 1:+.2%})", f"{w:.1f} ({w / w0:.2f}x)", f"{c:.1f} ({c / c0:.2f}x)"]
        lines.append(f"| level {level}, {f'{threads} thread' + ('s' if threads > 1 else '') if threads else 'threads: default'} | "
                     + " | ".join(cells) + " |")
    # a page whose bytes a level changes the most, either way (a packed atlas is kept when its
    # bytes grow past the export's: the level moves that line)
    by_level = {level: rows for (level, threads), rows in results.items() if not threads}
    if len(by_level) > 1:
        (la, ra), (lb, rb) = list(by_level.items())[:2]
        worst = max(zip(ra, rb), key=lambda pair: abs(pair[1]["packed"][0] / pair[0]["packed"][0] - 1))
        lines += ["", f"page whose packed bytes move most from level {la} to {lb}: {Path(worst[0]['page']).name} "
                  f"{worst[0]['packed'][0]:,} -> {worst[1]['packed'][0]:,} ({worst[1]['packed'][0] / worst[0]['packed'][0] - 1:+.1%})"]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("projects", nargs="*", type=Path)
    ap.add_argument("--no-upgrade", action="store_true", help="leave out (b), which upgrades every project first")
    ap.add_argument("--json", type=Path, help="write the rows here (after each project)")
    ap.add_argument("--shard", default="0/1", help="I/N: every N-th project from the I-th (parallel runs)")
    ap.add_argument("--corpus-only", action="store_true", help="default projects: the corpus, not the examples")
    ap.add_argument("--tables-from", type=Path, nargs="+", metavar="JSON", help="print the tables of rows saved by --json")
    ap.add_argument("--placement", action="store_true", help="only time the placement of 300 footprints "
                                                             "on 2048x2048 pages")
    ap.add_argument("--whole-placement", action="store_true", help="only time every fill pack tries for one "
                                                                   "atlas of 300 footprints on a 2048x2048 page")
    ap.add_argument("--upgraded", type=Path, metavar="DIR", help="keep upgrade's output of each project here "
                    "and reuse it in later runs (the upgrade takes most of the time)")
    ap.add_argument("--pages", nargs="+", default=["original"], choices=("original", "any", "power-of-two", "multiple-of-4"),
                    help="page rules to pack under, each reported apart (default: original)")
    ap.add_argument("--larger-files", action="store_true", help="pack as --larger-files does: an atlas whose "
                    "files would take more bytes is written all the same, lossy WebP pages too")
    ap.add_argument("--limits", metavar="RULE", choices=("original", "any", "power-of-two", "multiple-of-4"),
                    help="with --tables-from: per atlas, what (b) saved under this page rule and what limits it")
    ap.add_argument("--gap", type=Path, metavar="JSON", help="with --limits: rows of scripts/pack_gap.py --json "
                    "(the upgraded projects, the same --pages) for the footprints' need and placement alone")
    ap.add_argument("--soft", type=int, default=0, metavar="N", help="with --placement or --whole-placement: "
                    "every footprint's outer N texels are soft (may overlap other soft texels)")
    ap.add_argument("--layouts", metavar="RULE", choices=("original", "any", "power-of-two", "multiple-of-4"),
                    help="only list every layout the fills keep for each atlas of the projects under this page "
                         "rule, with its page texels and bytes as pack writes it")
    ap.add_argument("--png", type=Path, nargs="+", metavar="PAGE", help="only compare the PNG encoders on these "
                    "page images: Pillow's default and oxipng at levels 1-3 (bytes, CPU seconds, ratios)")
    ap.add_argument("--png-levels", type=Path, nargs="+", metavar="PROJECT", help="only compare oxipng's levels "
                    "and threads on the PNG pages of these projects (a folder pack wrote: its packed pages), as "
                    "pack encodes them: bytes, wall and CPU seconds side by side (see --variants)")
    ap.add_argument("--variants", nargs="+", default=["2:0", "1:0"], metavar="LEVEL:THREADS",
                    help="with --png-levels: oxipng level and threads (0: its default, one per core); the first "
                         "is the baseline (default: 2:0 1:0)")
    args = ap.parse_args(argv)
    if args.png_levels:
        variants = [tuple(int(v) for v in spec.split(":")) for spec in args.variants]
        print(png_levels([p.resolve() for p in args.png_levels], variants))
        return 0
    if args.png:
        print(png_encoders(args.png))
        return 0
    if args.layouts:
        print(layouts_table([p.resolve() for p in args.projects], args.layouts))
        return 0
    if args.whole_placement:
        print(whole_placement_timing(soft=args.soft))
        return 0
    if args.placement:
        print(placement_timing(soft=args.soft))
        return 0
    if args.tables_from:
        rows = [Row(**r) for f in args.tables_from for r in json.loads(f.read_text())]
        if args.limits:
            print(limits_table(rows, args.limits, json.loads(args.gap.read_text()) if args.gap else None))
            return 0
        print(table(rows))
        print()
        print(summaries(rows))
        return 0
    projects = [p.resolve() for p in args.projects] or default_projects()
    if args.corpus_only and not args.projects:
        projects = [p for p in projects if p.parent.name == "spine-corpus"]
    shard, shards = (int(v) for v in args.shard.split("/"))
    projects = projects[shard::shards]
    scratch = Path(tempfile.mkdtemp(prefix="bench-pack-"))
    rows: list[Row] = []
    try:
        for project in projects:
            t0 = time.perf_counter()
            try:
                rows += bench_project(project, scratch / project.name, not args.no_upgrade, args.pages,
                                      args.upgraded, args.larger_files)
            except SpineMeshError as e:
                print(f"{project.name}: {e}", file=sys.stderr)
            shutil.rmtree(scratch / project.name, ignore_errors=True)
            print(f"  {project.parent.name}/{project.name}: {time.perf_counter() - t0:.1f} s", file=sys.stderr,
                  flush=True)
            if args.json:
                args.json.write_text(json.dumps([asdict(r) for r in rows], indent=1))
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    print(table(rows))
    print()
    print(summaries(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
