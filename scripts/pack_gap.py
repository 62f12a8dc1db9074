"""Where the page texels ``pack`` could save are lost, atlas by atlas.

For every atlas of the given projects (typically ``upgrade``'s output), side by side, as shares
of the page texels before:

- ``art``: every region's drawn texels (alpha above 0) grown by the one-texel ring
  bilinear sampling reads, plus its share of the padding: what an ideal packer would store;
- ``kept``: the footprints of regions that keep their stored rectangle (drawn as regions,
  nine-patches, ...), ``outline``: the footprints of regions packed by their meshes' outline,
  each with its share of the padding (half the gap on every side);
- ``need = kept + outline``: the least area any placement of these footprints takes;
- ``bound``: the smallest page set the page rules allow whose area holds ``need`` (no more
  pages than before, powers of two where the originals were, no page over the largest one);
- ``reached``: what ``pack_atlas`` stores;
- ``next``: with powers of two, the largest page set the rules allow below ``reached`` that
  could still hold ``need``, and the fill (``need`` over it) a placement would have to reach
  to store it; without powers of two any smaller page is allowed, so the fill reached
  (``need`` over ``reached``) is given and every point of fill gained saves texels.

So the loss before ``reached`` splits into: (a) kept regions (``kept`` over their art), (b)
footprint size (``outline`` over its art), (c) placement (``reached`` over ``bound``) and (d)
page quantisation (``bound`` over ``need``).

Usage::

    .venv/bin/python scripts/pack_gap.py PROJECT [PROJECT ...] [--pages any] [--json rows.json]
"""

from __future__ import annotations

import argparse
import functools
import json
import statistics
import sys
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from spinemesh.errors import SpineMeshError  # noqa: E402
from spinemesh.images.decode import load_rgba  # noqa: E402
from spinemesh.images.sources import AtlasImages  # noqa: E402
from spinemesh.pack.atlas_pack import (  # noqa: E402
    RING_TEXELS, PackRefused, PageRules, _items, default_padding, footprint_share, largest_pot_pages_below,
    pack_atlas, page_settings,
)
from spinemesh.pack.outlines import content_box  # noqa: E402
from spinemesh.pack.place import _grow  # noqa: E402
from spinemesh.pack.uses import collect_uses  # noqa: E402
from spinemesh.project import find_project, project_atlases  # noqa: E402


@dataclass
class GapRow:
    project: str
    atlas: str
    regions: int
    by_outline: int
    pages: int
    before: int
    art: int
    art_kept: int
    kept: int
    outline: int
    bound: int
    reached: int
    status: str
    kept_cropped: int = 0
    pot: bool = False
    next_set: int = 0


def min_page_set(need: int, pages: int, max_area: int, pot: bool, smallest: int = 256) -> int:
    """The least total area of at most ``pages`` pages, each at most ``max_area``, that holds ``need``.

    With powers of two every page's area is one (sides 2^a x 2^b); without, any area.
    """
    if not pot:
        return need if need <= pages * max_area else -1
    areas = [1 << k for k in range(smallest.bit_length() - 1, max_area.bit_length()) if 1 << k <= max_area]

    @functools.lru_cache(maxsize=None)
    def best(left: int, n: int) -> int:
        if left <= 0:
            return 0
        if n == 0:
            return 1 << 62
        return min((a if a >= left else a + best(left - a, n - 1)) for a in areas if a * n >= left or a == areas[-1])

    found = best(need, pages)
    return found if found < 1 << 62 else -1


def largest_set_below(limit: int, need: int, pages: int, max_area: int, smallest: int = 256) -> int:
    """The largest total area below ``limit`` of at most ``pages`` power-of-two pages (each from
    ``smallest`` to ``max_area`` texels) that still holds ``need``; 0 if none."""
    best = largest_pot_pages_below(limit, pages, max_area, smallest)
    return best if best >= need else 0


def drawn_area(texels: np.ndarray, grow: int) -> int:
    """Texels of alpha above 0, grown by ``grow`` on every side."""
    drawn = texels[..., 3] > 0
    return int(_grow(drawn, grow).sum()) if drawn.any() else 0


def cropped_area(texels: np.ndarray, half: int) -> int:
    """A stored rectangle cropped to its texels not fully zero, grown by 2 (a transparent ring and
    the sampled ring) and ``half`` on every side."""
    ys, xs = np.nonzero(texels.any(axis=2))
    if ys.size == 0:
        return 0
    return (int(xs.max() - xs.min()) + 1 + 4 + 2 * half) * (int(ys.max() - ys.min()) + 1 + 4 + 2 * half)


def share(mask: np.ndarray, half: int) -> int:
    """A footprint's area with its share of the padding: grown by ``half`` texels on every side."""
    return footprint_share(mask, half)


def atlas_gap(project_name: str, rel: str, atlas, pixels, uses, rules: PageRules | None = None) -> GapRow:
    geometries = [r.geometry(str(atlas.path)) for r in atlas.regions]
    pad = default_padding(atlas, geometries)
    between = max(0, pad - RING_TEXELS)
    half = between / 2
    items = _items(atlas, geometries, pixels, uses, "", True)
    sizes = [(int(p.shape[1]), int(p.shape[0])) for p in pixels]
    before = sum(w * h for w, h in sizes)
    art = art_kept = kept = outline = kept_cropped = 0
    for it in items:
        x0, y0, x1, y1 = content_box(it.geometry)
        wx0, wy0 = it.foot.window[:2]
        stored = it.texels[y0 - wy0:y1 - wy0, x0 - wx0:x1 - wx0]
        # art grown by its sampling ring (1) and half the padding, rounded like the footprints'
        a = drawn_area(stored, 1 + int(round(half)))
        f = share(it.foot.core, int(round(half)))
        art += a
        if it.foot.by_outline:
            outline += f
        else:
            kept += f
            art_kept += a
            kept_cropped += cropped_area(stored, int(round(half))) if "region attachment" in it.foot.reason else f
    rules = rules or PageRules()
    _, max_area, pot = rules.limits(sizes)
    # groups of pages with different settings are packed apart: bound each
    groups: dict[tuple, list[int]] = {}
    for i, p in enumerate(atlas.pages):
        groups.setdefault(page_settings(p), []).append(i)
    bound = 0
    for page_indices in groups.values():
        members = [n for n, r in enumerate(atlas.regions) if r.page in page_indices]
        need = sum(share(items[n].foot.core, int(round(half))) for n in members)
        b = min_page_set(need, len(page_indices), max_area, pot) if need else 0
        bound += b if b >= 0 else sum(sizes[i][0] * sizes[i][1] for i in page_indices)
    try:
        packed = pack_atlas(atlas, pixels, uses, rules=rules)
        reached, status = packed.texels_after, "packed"
    except PackRefused as e:
        reached, status = before, "kept: " + str(e)[:60]
    next_set = largest_set_below(reached, kept + outline, len(pixels), max_area) if pot and len(groups) == 1 else 0
    return GapRow(project_name, rel, len(items), sum(it.foot.by_outline for it in items), len(pixels), before,
                  art, art_kept, kept, outline, min(bound, before), reached, status, kept_cropped, pot, next_set)


def project_gaps(project: Path, rules: PageRules | None = None) -> list[GapRow]:
    proj = find_project(project)
    uses = collect_uses(proj)
    rows = []
    for path, atlas in project_atlases(proj).items():
        rel = path.relative_to(proj.root).as_posix()
        try:
            pixels = [load_rgba(AtlasImages.page_path(atlas, p.name, proj.root)) for p in atlas.pages]
            rows.append(atlas_gap(project.name, rel, atlas, pixels, uses.regions.get(path, {}), rules))
        except (SpineMeshError, PackRefused) as e:
            print(f"{project.name}/{rel}: {e}", file=sys.stderr)
    return rows


def _p(part: int, whole: int) -> str:
    return f"{part / whole:.0%}" if whole else "-"


def next_step(r: GapRow) -> tuple[str, str]:
    """The ``next`` columns: the next smaller allowed page set (share of before) and the fill it needs."""
    need = r.kept + r.outline
    if not r.pot:
        return "any", _p(need, r.reached)
    if not r.next_set:
        return "none", "-"
    return _p(r.next_set, r.before), _p(need, r.next_set)


def table(rows: list[GapRow]) -> str:
    lines = ["| project | atlas | regions | by outline | pages | page texels | art | kept | outline | need | "
             "bound | reached | next | fill for next |",
             "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        need = r.kept + r.outline
        nxt, fill = next_step(r)
        lines.append(f"| {r.project} | {r.atlas} | {r.regions} | {r.by_outline} | {r.pages} | {r.before:,} | "
                     f"{_p(r.art, r.before)} | {_p(r.kept, r.before)} | {_p(r.outline, r.before)} | "
                     f"{_p(need, r.before)} | {_p(r.bound, r.before)} | {_p(r.reached, r.before)} | "
                     f"{nxt} | {fill} |")
    return "\n".join(lines)


def reach_summary(rows: list[GapRow]) -> str:
    """How many atlases a better placement could shrink, by the fill it would have to reach."""
    before = sum(r.before for r in rows)
    pot = [r for r in rows if r.pot and r.next_set]
    npot = [r for r in rows if not r.pot]
    lines = ["| fill a placement must reach | power-of-two atlases with a smaller allowed page set "
             "(texels it saves) | other atlases already at or above it (texels) |", "|---|---:|---:|"]
    for limit in (0.75, 0.80, 0.85, 0.90, 0.95):
        near = [r for r in pot if (r.kept + r.outline) <= limit * r.next_set]
        done = [r for r in npot if (r.kept + r.outline) >= limit * r.reached]
        lines.append(f"| {limit:.0%} | {len(near)} ({sum(r.reached - r.next_set for r in near) / before:.1%}) | "
                     f"{len(done)} of {len(npot)} ({sum(r.before for r in done) / before:.1%}) |")
    return "\n".join(lines)


def summary(rows: list[GapRow]) -> str:
    before = sum(r.before for r in rows)

    def tot(f) -> str:
        return f"{sum(f(r) for r in rows) / before:.1%}"

    def med(f) -> str:
        return f"{statistics.median(f(r) / r.before for r in rows):.1%}"

    parts = [("art (ideal footprints)", lambda r: r.art),
             ("kept rectangles' art", lambda r: r.art_kept),
             ("kept rectangles", lambda r: r.kept),
             ("kept region attachments cropped to what they draw", lambda r: r.kept_cropped),
             ("outline footprints' art", lambda r: r.art - r.art_kept),
             ("outline footprints", lambda r: r.outline),
             ("need = kept + outline", lambda r: r.kept + r.outline),
             ("bound (smallest allowed pages holding need)", lambda r: r.bound),
             ("reached by pack", lambda r: r.reached)]
    lines = [f"{len(rows)} atlases, {before:,} page texels before", "",
             "| share of page texels before | total | median atlas |", "|---|---:|---:|"]
    lines += [f"| {label} | {tot(f)} | {med(f)} |" for label, f in parts]
    a = sum(r.kept - r.art_kept for r in rows)
    b = sum(r.outline - (r.art - r.art_kept) for r in rows)
    c = sum(r.reached - r.bound for r in rows)
    d = sum(r.bound - r.kept - r.outline for r in rows)
    lines += ["", "loss (share of page texels before, total): "
              f"(a) kept regions {a / before:.1%}, (b) footprint size {b / before:.1%}, "
              f"(c) placement {c / before:.1%}, (d) page quantisation {d / before:.1%}; "
              f"saving reached {1 - sum(r.reached for r in rows) / before:.1%}, "
              f"bound {1 - sum(r.bound for r in rows) / before:.1%}"]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("projects", nargs="*", type=Path)
    ap.add_argument("--json", type=Path, help="write the rows here (after each project)")
    ap.add_argument("--tables-from", type=Path, nargs="+", metavar="JSON", help="print the tables of saved rows")
    ap.add_argument("--pages", default="original", choices=("original", "any", "power-of-two", "multiple-of-4"),
                    help="the page rules packed under (default: original); the bytes rules of a written "
                         "atlas (lossy WebP pages, files that would grow) do not apply here")
    args = ap.parse_args(argv)
    rows: list[GapRow] = []
    if args.tables_from:
        rows = [GapRow(**r) for f in args.tables_from for r in json.loads(f.read_text())]
    for project in args.projects:
        rows += project_gaps(project.resolve(), PageRules(args.pages))
        print(f"  {project.name}", file=sys.stderr, flush=True)
        if args.json:
            args.json.write_text(json.dumps([asdict(r) for r in rows], indent=1))
    print(table(rows))
    print()
    print(summary(rows))
    print()
    print(reach_summary(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
