"""One atlas packed anew: footprints placed on pages, texels copied under them, regions rewritten.

:func:`pack_atlas` is pure: parsed atlas, page texels and the regions' uses in, new atlas text
model and page images out, or :class:`PackRefused` with the reason (the caller then keeps the
original atlas). Rules:

- pages keep their fields (format, filter, repeat, pma, scale); only ``size`` changes. Regions
  of pages whose fields differ are packed apart, onto pages of their own fields;
- no page is larger than the largest original page; sides are powers of two when every
  original page's were;
- footprints stay apart by the padding: at least the original pages' (measured), at least
  :data:`MIN_PADDING`, and :data:`MIPMAP_PADDING` under a ``MipMap*`` filter; only their soft
  texels (all zero, away from anything visible: :func:`~spinemesh.pack.outlines.hard_texels`)
  may meet, and overlap, other footprints' soft texels;
- a region may be turned by 90 degrees where it was stored upright or turned by 90 (every
  runtime reads ``rotate``), and the stored rectangle is cropped to the footprint where every
  mesh's runtime maps UVs over the original image (offsets rewritten to match);
- the result is kept only when it stores fewer page texels than the original.
"""

from __future__ import annotations

import copy
import dataclasses
import math
import time
from dataclasses import dataclass, field

import numpy as np

from ..atlas import Atlas, AtlasPage, AtlasRegion, Entry, RegionGeometry
from ..files.names import portable_name
from .outlines import Footprint, footprint, grown_for_mipmaps, hard_texels, stored_index, window_texels
from .place import PAGE_SHAPES, _grow, fill_pages
from .uses import RegionUses, rectangle_reason

#: Fewest texels between what two regions draw (stored rectangles, or texels meshes touch), as
#: packers' default padding: each footprint holds the one-texel ring bilinear sampling reads
#: around what it draws, so footprints themselves may then touch.
MIN_PADDING = 2

#: Padding under a ``MipMap*`` filter: keeps the first mipmap levels from mixing neighbours.
MIPMAP_PADDING = 4

#: Texels of the padding that the footprints' own rings already hold (one on each side).
RING_TEXELS = 2

#: Region fields that say where and how it is stored; rewritten here.
GEOMETRY_KEYS = {"bounds", "offsets", "xy", "size", "orig", "offset", "rotate"}


class PackRefused(Exception):
    """The atlas keeps its original pages; the message says why."""


@dataclass
class RegionOutcome:
    """How one region was packed."""

    name: str
    by_outline: bool
    reason: str = ""


@dataclass
class PackedAtlas:
    """The packed atlas: its model, its page images (by page name) and what happened to each region."""

    atlas: Atlas
    pages: dict[str, np.ndarray]
    regions: list[RegionOutcome]
    padding: int
    texels_before: int
    texels_after: int
    pages_before: int
    seconds: float = 0.0
    rotated: int = 0
    groups: list[str] = field(default_factory=list)
    #: texels of the packed pages under a footprint grown by half the padding between footprints
    #: (:func:`footprint_share`; texels two footprints share count once): over ``texels_after``,
    #: how full the packed pages are
    footprint_texels: int = 0


def is_power_of_two(n: int) -> bool:
    return n > 0 and n & (n - 1) == 0


#: What sides a packed page may have (:class:`PageRules`).
PAGE_SIDES = ("original", "any", "power-of-two", "multiple-of-4")


@dataclass(frozen=True)
class PageRules:
    """The pages a packed atlas may have.

    ``sides``: ``original`` (the default): powers of two where every original page's sides are,
    else any; ``any``: any size (WebGL 2, OpenGL ES 3, Unity, Godot, every desktop GPU of the
    last decade sample and mipmap such pages); ``power-of-two``: powers of two always (WebGL 1
    mipmaps and repeats only those); ``multiple-of-4``: any multiple of 4 (block-compressed
    GPU formats, BC/DXT, ETC and ASTC 4x4, store blocks of 4x4 texels). ``max_side``: the longest side a page may have (then a
    page may take ``max_side`` squared texels); default: the longest original side, and no page
    of more texels than the largest original page.
    """

    sides: str = "original"
    max_side: int | None = None

    def limits(self, sizes: list[tuple[int, int]]) -> tuple[int, int, bool]:
        """``(longest side, most texels of a page, powers of two)`` for an atlas of pages ``sizes``."""
        if self.sides not in PAGE_SIDES:
            raise ValueError(f"page sides {self.sides!r}: one of {', '.join(PAGE_SIDES)}")
        side = self.max_side or max(max(s) for s in sizes)
        area = side * side if self.max_side else max(w * h for w, h in sizes)
        pot = (all(is_power_of_two(w) and is_power_of_two(h) for w, h in sizes) if self.sides == "original"
               else self.sides == "power-of-two")
        if pot and not is_power_of_two(side):
            side = 1 << (side.bit_length() - 1)  # the largest power of two within the limit
            area = min(area, side * side)
        if self.step > 1:
            side -= side % self.step  # a used side rounded up to a multiple stays within it
        return side, area, pot

    @property
    def step(self) -> int:
        """What every side is a multiple of (besides powers of two)."""
        return 4 if self.sides == "multiple-of-4" else 1


#: Rectangles compared with every other at once by :func:`measured_padding`.
PADDING_BLOCK = 64


def measured_padding(geometries: list[RegionGeometry]) -> int:
    """The fewest texels between two stored rectangles of one page that do not overlap (0 if none).

    Two rectangles count when they face each other (their spans overlap on one axis); the
    gap is measured on the other. Rectangles that overlap (polygon-packed pages) are passed
    over.
    """
    if len(geometries) < 2:
        return 0
    b = np.array([(g.x, g.y, g.x + g.page_width, g.y + g.page_height) for g in geometries], np.int64)
    b = np.unique(b, axis=0)
    if len(b) < 2:
        return 0
    x0, y0, x1, y1 = (b[:, i] for i in range(4))
    least = None
    # every pair, a block of rows at a time: memory stays a few MB for 10,000 regions on a page
    for lo in range(0, len(b), PADDING_BLOCK):
        r = slice(lo, lo + PADDING_BLOCK)
        gap_x = np.maximum(x0[None, :] - x1[r, None], x0[r, None] - x1[None, :])
        gap_y = np.maximum(y0[None, :] - y1[r, None], y0[r, None] - y1[None, :])
        facing_x = (gap_y < 0) & (gap_x >= 0)  # side by side
        facing_y = (gap_x < 0) & (gap_y >= 0)  # one above the other
        for gaps in (gap_x[facing_x], gap_y[facing_y]):
            if gaps.size:
                least = int(gaps.min()) if least is None else min(least, int(gaps.min()))
    return least or 0


def page_settings(page: AtlasPage) -> tuple:
    """What a page's regions share besides its size: its fields, ``size`` left out."""
    return tuple((e.key, tuple(v.strip().lower() for v in e.values)) for e in page.entries if e.key != "size")


def page_size(page: AtlasPage, pixels: np.ndarray) -> tuple[int, int]:
    return int(pixels.shape[1]), int(pixels.shape[0])


def uses_mipmaps(page: AtlasPage) -> bool:
    v = page.get("filter")
    return bool(v) and any("mipmap" in f.lower() for f in v)


def orientations(degrees: int, rotate: bool) -> list[int]:
    """Quarter turns a region may be stored at: its own first, then the other of 0 and 90 degrees."""
    k = degrees // 90
    if rotate and k in (0, 1):
        return [k, 1 - k]
    return [k]


def candidate_widths(areas: int, widest: int, max_w: int, pot: bool) -> list[int]:
    """Page widths worth a try: the largest allowed and a few near the square the area needs."""
    side = math.sqrt(max(1, areas) * 1.15)
    if pot:
        widths = {max_w}
        w = 1 << max(0, math.ceil(math.log2(max(side, widest))))
        for candidate in (w, w * 2):
            if widest <= candidate <= max_w:
                widths.add(candidate)
    else:
        widths = {max_w} | {int(min(max_w, max(widest, side * f))) for f in (1.0, 1.3)}
    return sorted(widths, reverse=True)


#: Page sizes tried, smallest first, when pages must have power-of-two sides.
POT_TRIES = 6


def _powers(limit: int) -> list[int]:
    """Powers of two up to ``limit``, from 16."""
    return [1 << k for k in range(4, max(4, limit.bit_length()) + 1) if 1 << k <= limit]


def round_page(used: int, limit: int, pot: bool) -> int:
    if not pot:
        return max(1, used)
    return min(limit, 1 << max(0, math.ceil(math.log2(max(1, used)))))


@dataclass
class _Item:
    region: AtlasRegion
    geometry: RegionGeometry
    foot: Footprint
    texels: np.ndarray            # upright window texels, (h, w, 4)
    turns: list[int]              # quarter turns it may be stored at
    masks: list[np.ndarray] = field(default_factory=list)
    hard_masks: list[np.ndarray] = field(default_factory=list)  # the masks themselves where all is hard


def _item_masks(item: _Item, core: np.ndarray) -> list[np.ndarray]:
    """``core`` (a mask over the footprint's window) as stored at each allowed turn, the window's bounding box kept."""
    return [np.ascontiguousarray(np.rot90(core, k)) for k in item.turns]


def _item_hard(item: _Item) -> np.ndarray:
    """The footprint's hard texels (upright): every texel of a region that keeps its rectangle (a quad
    reads all of it; kept simple), else those near a texel not all zero (:func:`hard_texels`)."""
    return hard_texels(item.foot.core, item.texels) if item.foot.by_outline else item.foot.core


def _stored_geometry(item: _Item, k: int, x: int, y: int) -> RegionGeometry:
    """The region's new geometry once its window is stored turned ``k`` times with its top-left at ``(x, y)``."""
    wx0, wy0, wx1, wy1 = item.foot.window
    cx0, cy0, cx1, cy1 = item.foot.content
    ww, wh = wx1 - wx0, wy1 - wy0
    corners = [stored_index(i - wx0, j - wy0, ww, wh, k) for i in (cx0, cx1 - 1) for j in (cy0, cy1 - 1)]
    row = min(r for r, _ in corners)
    col = min(c for _, c in corners)
    g = item.geometry
    w, h = cx1 - cx0, cy1 - cy0
    return RegionGeometry(x + col, y + row, w, h, cx0, g.original_height - cy1, g.original_width,
                          g.original_height, 90 * k)


def geometry_entries(region: AtlasRegion, g: RegionGeometry, syntax: str, style: Entry) -> list[Entry]:
    """``region``'s entries with its geometry replaced by ``g``; other fields keep their order after it.

    ``style``: an entry of the atlas whose indent, colon and separator the new entries copy.
    """

    def entry(key: str, values: list[str]) -> Entry:
        return Entry(key, values, style.indent, style.sep, style.colon)

    whole = g.offset_x == 0 and g.offset_y == 0 and g.original_width == g.width and g.original_height == g.height
    if syntax == "4":
        geometry = [entry("bounds", [str(g.x), str(g.y), str(g.width), str(g.height)])]
        if not whole:
            geometry.append(entry("offsets", [str(g.offset_x), str(g.offset_y), str(g.original_width),
                                              str(g.original_height)]))
        if g.degrees:
            geometry.append(entry("rotate", [str(g.degrees)]))
    else:
        rotate = "true" if g.degrees == 90 else str(g.degrees) if g.degrees else "false"
        geometry = [entry("rotate", [rotate]), entry("xy", [str(g.x), str(g.y)]),
                    entry("size", [str(g.width), str(g.height)]),
                    entry("orig", [str(g.original_width), str(g.original_height)]),
                    entry("offset", [str(g.offset_x), str(g.offset_y)])]
    return geometry + [e for e in region.entries if e.key not in GEOMETRY_KEYS]


def _page_sizes(used: list[tuple[int, int]], max_w: int, max_h: int, pot: bool) -> list[tuple[int, int]]:
    return [(round_page(w, max_w, pot), round_page(h, max_h, pot)) for w, h in used]


def _by_widths(candidates, max_w: int, max_h: int, max_area: int, pot: bool, padding: int, max_pages: int,
               best=None, order: list[int] | None = None, hard=None):
    """First fit on pages of a few widths (the last page narrower where it can be), footprints in ``order``
    (default: :func:`~spinemesh.pack.place.fill_pages`'s), hard parts ``hard`` (default: all hard).

    Returns the best ``(texels, placements, sizes)``, ``best`` (the best so far) when none beats it.
    """

    def widths_for(members: list[int], limit: int) -> list[int]:
        widest = max(min(m.shape[1] for m in candidates[i]) for i in members)
        area = sum(int(candidates[i][0].sum()) + padding * sum(candidates[i][0].shape) for i in members)
        return candidate_widths(area, widest, limit, pot)

    def texels(used: list[tuple[int, int]]) -> int:
        return sum(w * h for w, h in _page_sizes(used, max_w, max_h, pot))

    needed = sum(int(c[0].sum()) for c in (hard or candidates))
    for width in widths_for(list(range(len(candidates))), max_w):
        height = max_h
        if best is not None and max_pages == 1:
            # only a page of fewer texels than the best so far is worth finishing: cap its height
            height = min(max_h, (best[0] - 1) // width)
            if pot:
                height = 1 << max(0, height.bit_length() - 1)
            if width * height < needed:
                continue
        placements, used = fill_pages(candidates, width, height, padding, order=order, max_pages=max_pages,
                                      budget=None if best is None else best[0], hard=hard)
        if any(p is None for p in placements) or len(used) > max_pages:
            continue
        if len(used) > 1:  # the last page holds the rest: it may do with a narrower page
            last = [i for i, p in enumerate(placements) if p.page == len(used) - 1]
            for narrower in widths_for(last, width):
                if narrower >= width:
                    continue
                again, used_again = fill_pages([candidates[i] for i in last], narrower, max_h, padding,
                                               hard=None if hard is None else [hard[i] for i in last])
                if len(used_again) == 1 and all(again) and texels(used_again) < texels(used[-1:]):
                    for i, p in zip(last, again):
                        placements[i] = dataclasses.replace(p, page=len(used) - 1)
                    used[-1] = used_again[0]
        sizes = _page_sizes(used, max_w, max_h, pot)
        if any(w * h > max_area for w, h in sizes):
            continue
        total = sum(w * h for w, h in sizes)
        if best is None or total < best[0]:
            best = (total, placements, sizes)
    return best


def _tightest(candidates, max_w: int, max_h: int, max_area: int, pot: bool, padding: int, max_pages: int,
              budget: int | None = None, hard=None, shape: str = "square", order: list[int] | None = None):
    """Every footprint where it grows its page's used area least (see :func:`fill_pages`): ``(texels, placements, sizes)``.

    Pages take whatever shape packs best, up to the longest side and the largest page's texels;
    each page after the first starts small again, so a last page holding the rest stays small.
    ``shape``: how places rank the pages they leave without powers of two
    (:data:`~spinemesh.pack.place.PAGE_SHAPES`); ``order``: the footprints' (default largest box first).
    """
    placements, used = fill_pages(candidates, max_w, max_h, padding, order=order, max_pages=max_pages, tight=True,
                                  max_area=max_area, pot=pot, budget=budget, hard=hard, shape=shape)
    if any(p is None for p in placements):
        return None
    sizes = _page_sizes(used, max_w, max_h, pot)
    if any(w * h > max_area for w, h in sizes):
        return None
    return sum(w * h for w, h in sizes), placements, sizes


def _whole_pot_pages(candidates, max_w: int, max_h: int, max_area: int, padding: int, max_pages: int, best,
                     hard=None):
    """Power-of-two page sizes tried whole, smallest first, from the least area that could hold the footprints.

    Powers of two round a used height up to the next one; a page of exactly the size may
    still hold everything. Each size is tried with both placements; the first that holds
    everything is kept when it beats ``best`` (``(texels, placements, sizes)`` or None). ``hard``: the
    footprints' hard parts (see :func:`~spinemesh.pack.place.fill_pages`).
    """
    needed = sum(int(c[0].sum()) for c in (hard or candidates))
    sizes = sorted(((w, h) for w in _powers(max_w) for h in _powers(max_h)
                    if needed / max_pages <= w * h <= max_area and (best is None or w * h * max_pages < best[0])),
                   key=lambda s: (s[0] * s[1], abs(s[0] - s[1])))
    for w, h in sizes[:POT_TRIES]:
        for tight in (False, True):
            placements, used = fill_pages(candidates, w, h, padding, max_pages=max_pages, tight=tight, pot=True,
                                          budget=None if best is None else best[0], hard=hard)
            if any(p is None for p in placements):
                continue
            found = _page_sizes(used, w, h, True)
            total = sum(a * b for a, b in found)
            if best is None or total < best[0]:
                return total, placements, found
            return best
    return best


def largest_pot_pages_below(limit: int, pages: int, max_area: int, smallest: int = 256) -> int:
    """The most texels below ``limit`` that at most ``pages`` power-of-two pages (each of
    ``smallest`` to ``max_area`` texels) can take; 0 if none.

    A sum of powers of two is largest under a bound when it keeps the bound's highest bits: so
    take as many whole pages of ``max_area`` as fit, then the top bits of the rest, one a page.
    """
    best = 0
    top = limit - 1
    for whole in range(min(pages, top // max_area), -1, -1):
        rest = top - whole * max_area
        total = whole * max_area
        for _ in range(pages - whole):
            if rest < smallest:
                break
            bit = min(1 << (rest.bit_length() - 1), max_area)
            total += bit
            rest -= bit
        best = max(best, total)
    return best


def kept_note(needed: int, texels: int | None, pages: int, max_area: int, pot: bool) -> str:
    """Why an atlas keeps its pages, in plain words: what its regions need against what it has,
    and, for power-of-two pages, what the next smaller page set the rules allow holds.

    The note speaks to a user: "regions" (what they see in the atlas), not footprints (this
    module's word for what a region takes on a page).

    ``needed``: the footprints' hard texels (the least any placement takes); ``texels``: the
    atlas's page texels (None: no bound was given, so the footprints did not fit at all).
    """
    if texels is None:
        return f"its regions do not fit on {pages} page{'s' if pages > 1 else ''} of the largest original size"
    share = f"its regions need {needed / texels:.0%} of the page texels"
    if needed >= texels:
        return share + ", so no packing stores fewer"
    if needed > pages * max_area:  # the page rules (--max-page), not the fills, left no room
        held = "one page of at most" if pages == 1 else f"{pages} pages of at most"
        return (f"its regions need {needed:,} texels, more than {held} {max_area:,} texels "
                f"hold{'s' if pages == 1 else ''} under the page rules (--max-page, --pages)")
    if not pot:
        return share + ", and no fill tried placed them on fewer"
    below = largest_pot_pages_below(texels, pages, max_area, smallest=16 * 16)
    if below == 0:
        return share + "; no smaller power-of-two page exists under the page rules"
    what = "page holds" if pages == 1 else "pages hold"
    # a need under what the smaller pages hold reads as a packing forgotten: say the fills failed
    tried = "" if needed >= below else f", and no fill tried placed them on {'it' if pages == 1 else 'them'}"
    return share + f"; the next smaller power-of-two {what} {below / texels:.0%}{tried}"


def other_orders(candidates) -> list[list[int]]:
    """Orders besides the largest box first that a group of several pages is filled in: most texels
    first, then longest side first (the first also for the tightest fit by width + height, see
    :func:`fill_plan`).

    With several pages the order decides what is left for the last page, which often takes
    the whole of a smaller page: one large footprint left over can double it.
    """
    n = range(len(candidates))
    by_texels = sorted(n, key=lambda i: (-int(candidates[i][0].sum()), i))
    by_side = sorted(n, key=lambda i: (-max(candidates[i][0].shape), -candidates[i][0].size, i))
    return [by_texels, by_side]


#: Most footprints of a group for which the tightest fit also ranks pages by other shapes
#: (:func:`fill_plan`): each such fill costs about as much as the first, and every atlas of the
#: corpus they packed smaller has 80 regions or fewer, so larger groups are spared them (a page of
#: 300 footprints stays within 5 CPU s).
SHAPE_FILLS_UP_TO = 100


def fill_plan(pot: bool, soft: bool, max_pages: int, footprints: int = 0) -> list[tuple]:
    """The fills tried for one group, in order: ``(kind, every texel hard, how)`` each.

    ``how``: for ``widths``, the index of an order of :func:`other_orders` (None: largest box
    first); for ``tightest``, None or ``(page shape, order index or None)``.

    The tightest fit on pages of any shape; first fit on pages of a few widths; for powers of
    two, whole page sizes from the smallest, and both again with every texel hard (the greedy
    fill takes other places when footprints may overlap, and a footprint it then no longer fits
    doubles a page: 4.2 stretchyman); a group of several power-of-two pages, first fit on a few
    widths again in :func:`other_orders` (on pages of any size the last page shrinks to what it
    holds: other orders saved nothing there, as measured; whole page sizes in other orders saved
    nothing either, at twice the time on the dragon example); without powers of two, last, the
    tightest fit again with places ranked by the page's width + height and by its area
    (:data:`~spinemesh.pack.place.PAGE_SHAPES`), and by width + height with the footprints of
    most texels first: each packs some atlases best, as measured (with powers of two the
    rounded page ranks places first, and these saved nothing), for groups of at most
    :data:`SHAPE_FILLS_UP_TO` footprints. ``soft``: some footprint has soft texels;
    ``footprints``: how many the group has.
    """
    plan = [("tightest", False, None)]
    for all_hard in (False, True) if pot and soft else (False,):
        plan.append(("widths", all_hard, None))
        if pot:
            plan.append(("whole", all_hard, None))
    if pot and max_pages > 1:
        plan += [("widths", False, k) for k in range(len(other_orders([])))]
    if not pot and footprints <= SHAPE_FILLS_UP_TO:  # last: the fills before find what they found, these improve on it
        plan += [("tightest", False, (shape, None)) for shape in PAGE_SHAPES[1:]]
        plan.append(("tightest", False, ("perimeter", 0)))
    return plan


def run_fill(fill: tuple, candidates, hard, max_w: int, max_h: int, max_area: int, pot: bool, padding: int,
             max_pages: int, best):
    """One fill of :func:`fill_plan`: the best of ``best`` (``(texels, placements, sizes)``) and what it finds."""
    kind, all_hard, order = fill
    variant = None if all_hard else hard
    if kind == "tightest":
        shape, index = order or (PAGE_SHAPES[0], None)
        found = _tightest(candidates, max_w, max_h, max_area, pot, padding, max_pages,
                          None if best is None else best[0], variant, shape,
                          None if index is None else other_orders(candidates)[index])
        return found if found is not None and (best is None or found[0] < best[0]) else best
    if kind == "whole":
        return _whole_pot_pages(candidates, max_w, max_h, max_area, padding, max_pages, best, variant)
    orders = None if order is None else other_orders(candidates)[order]
    return _by_widths(candidates, max_w, max_h, max_area, pot, padding, max_pages, best, orders, variant)


#: Layouts besides the one of fewest page texels that a group keeps (:func:`group_layouts`): when
#: the best layout's files would take more bytes than the atlas as exported, the next ones are
#: encoded in turn (``spinemesh.pack.run``), each costing an encode and a proof.
NEXT_LAYOUTS = 3


def group_layouts(items: list[_Item], max_w: int, max_h: int, max_area: int, pot: bool, padding: int,
                  max_pages: int, ceiling: int | None = None, fills=None, on_fill=None,
                  keep: int = 1 + NEXT_LAYOUTS) -> list[tuple[list, list[tuple[int, int]]]]:
    """The layouts of one group worth writing, fewest page texels first: ``[(placements, page sizes)]``.

    Tries every fill of :func:`fill_plan` in order; each layout kept is a *record*, one that
    stores fewer texels than every fill before it (the first on a tie), so the first is the
    packing of fewest texels and the others are what the fills before it reached (at most
    ``keep`` in all). Never more pages than the group had (each page is a texture switch, often
    a draw call). ``ceiling``: page texels a packing must stay under to be of use (the atlas's
    own): fills that reach it stop early. ``fills``: runs the fills elsewhere, ``fills(plan,
    args, best)`` -> each one's result, in order (:class:`~spinemesh.pack.parallel.FillRunner`:
    each fill stops at the best of those before it that ended, so the records are the same);
    default here, one after another, each stopping as soon as it cannot beat the best so far.
    ``on_fill(done, planned)``: told how many fills there are (``on_fill(0, n)``), then as each
    ends (``on_fill()``).

    Raises
    ------
    PackRefused
        When no fill beats ``ceiling`` (or none holds every footprint).
    """
    candidates = [it.masks for it in items]
    hard = [it.hard_masks for it in items]
    needed = sum(int(c[0].sum()) for c in hard)  # soft texels may all overlap: the hard ones are the least
    if all(h is m for it in items for h, m in zip(it.hard_masks, it.masks)):
        hard = None  # every texel hard: footprints may not overlap at all
    if ceiling is not None and needed >= ceiling:  # no placement can beat it: spare every fill
        raise PackRefused(kept_note(needed, ceiling, max_pages, max_area, pot))
    for it, masks in zip(items, candidates):
        if not any(m.shape[0] <= max_h and m.shape[1] <= max_w and m.size <= max_area for m in masks):
            h, w = masks[0].shape
            raise PackRefused(f"region {it.region.name!r} takes {w}x{h} texels with its padding, more than "
                              f"the largest page allowed ({max_w}x{max_h}, {max_area:,} texels)")
    best = None if ceiling is None else (ceiling, None, None)
    plan = fill_plan(pot, hard is not None, max_pages, len(candidates))
    args = (candidates, hard, max_w, max_h, max_area, pot, padding, max_pages)
    records = []
    if on_fill:
        on_fill(0, len(plan))
    results = _one_after_another(plan, args, best, on_fill) if fills is None else fills(plan, args, best)
    for found in results:
        if beats(found, best):
            best = found
            records.append(found)
    if not records:
        raise PackRefused(kept_note(needed, ceiling, max_pages, max_area, pot))
    return [(placements, sizes) for _, placements, sizes in reversed(records[-keep:])]


def beats(found, best) -> bool:
    """Whether a fill's result ``found`` (``(texels, placements, sizes)``, or a bound handed back:
    placements None) is a packing of fewer page texels than ``best`` (None: no bound)."""
    return found is not None and found[1] is not None and (best is None or found[0] < best[0])


def _one_after_another(plan: list[tuple], args: tuple, best, on_fill=None):
    """Each fill of ``plan`` here, in order, each bounded by the best before it: their results."""
    for fill in plan:
        found = run_fill(fill, *args, best)
        if beats(found, best):
            best = found
        yield found
        if on_fill:
            on_fill()


def _pack_group(items: list[_Item], max_w: int, max_h: int, max_area: int, pot: bool, padding: int,
                max_pages: int, ceiling: int | None = None, fills=None, on_fill=None):
    """Best packing of one group: ``(placements, page sizes)`` with fewest texels (:func:`group_layouts`)."""
    return group_layouts(items, max_w, max_h, max_area, pot, padding, max_pages, ceiling, fills, on_fill, keep=1)[0]


@dataclass
class AtlasLayouts:
    """An atlas's footprints placed, not yet composited: per group of pages (pages of the same
    fields, :func:`page_settings`) its layouts worth writing, fewest page texels first
    (:func:`group_layouts`). :func:`compose` makes a :class:`PackedAtlas` of any of them."""

    atlas: Atlas
    items: list[_Item] | None  # None once released (:meth:`release`)
    geometries: list[RegionGeometry]
    padding: int
    rules: PageRules
    page_names: object
    #: per group: (its index, its original page indices, its regions' indices, its layouts)
    groups: list[tuple[int, list[int], list[int], list]]
    texels_before: int
    seconds: float
    #: what made ``items`` (pages' texels, uses, pinned, rotate): made again after :meth:`release`
    made_from: tuple = ()

    @property
    def count(self) -> int:
        """How many layouts :func:`compose` can make: the most any group has."""
        return max((len(layouts) for *_, layouts in self.groups), default=1)

    def release(self) -> None:
        """Let the footprints' masks go (a few hundred MB for an atlas of 60 large pages) while the
        packed pages are encoded and proven; :func:`compose` makes them again if it needs them."""
        self.items = None

    def footprints(self) -> list[_Item]:
        """The regions' footprints, made again (the same, :func:`_items`) when released."""
        if self.items is None:
            self.items = _items(self.atlas, self.geometries, *self.made_from)
        return self.items


def page_groups(atlas: Atlas) -> list[tuple[int, list[int], list[int]]]:
    """The groups of ``atlas``'s pages placed each on its own (pages of the same fields,
    :func:`page_settings`) that hold regions, in the order they are placed: ``(group index,
    its page indices, its regions' indices)`` each."""
    by_settings: dict[tuple, list[int]] = {}
    for i, p in enumerate(atlas.pages):
        by_settings.setdefault(page_settings(p), []).append(i)
    groups = []
    for gi, page_indices in enumerate(by_settings.values()):
        members = [n for n, r in enumerate(atlas.regions) if r.page in page_indices]
        if members:
            groups.append((gi, page_indices, members))
    return groups


def plan_layouts(atlas: Atlas, pixels: list[np.ndarray], uses: dict[str, RegionUses],
                 pinned: str = "", rotate: bool = True, padding: int | None = None,
                 page_names=None, rules: PageRules = PageRules(), fills=None, on_fill=None,
                 keep: int = 1 + NEXT_LAYOUTS) -> AtlasLayouts:
    """Place ``atlas``'s footprints anew: the layouts :func:`compose` makes packed atlases of.

    Parameters
    ----------
    atlas : Atlas
        Parsed atlas; not changed.
    pixels : list of ndarray
        Per page, its texels as stored, (H, W, 4) uint8; kept (not copied) for :func:`compose`.
    uses : dict
        Region name -> :class:`RegionUses` (:func:`spinemesh.pack.uses.collect_uses`).
    pinned : str
        When set, every region keeps its rectangle for this reason.
    rotate : bool
        Let regions be turned by 90 degrees.
    padding : int, optional
        Texels between footprints; default: see the module notes.
    page_names : callable, optional
        ``page_names(group_index, page_index_in_group, template_page)`` -> the new page's file name;
        default: the original pages' names in order, then ``<name>-<n>.<ext>``.
    rules : PageRules
        The pages it may have; default: as the original's (see the module notes).
    fills, on_fill : callable, optional
        Where the fills run, and who is told as each ends (see :func:`group_layouts`).
    keep : int
        Layouts kept per group, the one of fewest texels first (default: it and :data:`NEXT_LAYOUTS`).

    Raises
    ------
    PackRefused
        When the atlas cannot be packed, or no fill stores fewer texels.
    """
    t0 = time.process_time()
    if atlas.problems:
        raise PackRefused(f"the atlas has regions that cannot be read ({atlas.problems[0]})")
    sizes = [page_size(p, px) for p, px in zip(atlas.pages, pixels)]
    texels_before = sum(w * h for w, h in sizes)
    geometries = [r.geometry(str(atlas.path)) for r in atlas.regions]
    pad = padding if padding is not None else default_padding(atlas, geometries)
    items = _items(atlas, geometries, pixels, uses, pinned, rotate)
    # by default "no larger than the largest original page": no side longer than its longest
    # side, no page of more texels than it has (a page may turn from wide to tall)
    max_side, max_area, pot = rules.limits(sizes)
    groups = []
    for gi, page_indices, members in page_groups(atlas):
        layouts = group_layouts([items[n] for n in members], max_side, max_side, max_area, pot,
                                max(0, pad - RING_TEXELS), len(page_indices), texels_before, fills, on_fill, keep)
        groups.append((gi, page_indices, members, layouts))
    return AtlasLayouts(atlas, items, geometries, pad, rules, page_names, groups, texels_before,
                        time.process_time() - t0, (pixels, uses, pinned, rotate))


def compose(layouts: AtlasLayouts, rank: int = 0) -> PackedAtlas:
    """The packed atlas of ``layouts``: each group's layout of that ``rank`` (0: fewest page texels;
    a group of fewer layouts its last), its texels copied onto new pages, its regions rewritten.

    Raises
    ------
    PackRefused
        When it would store no fewer page texels than the atlas has.
    """
    t0 = time.process_time()
    atlas = layouts.atlas
    out, new_pages, region_page, covered = _composite(layouts, rank)
    texels_after = sum(int(p.shape[0]) * int(p.shape[1]) for p in new_pages.values())
    if texels_after >= layouts.texels_before:
        raise PackRefused(f"packed, its pages would take {texels_after:,} texels, no fewer than the "
                          f"{layouts.texels_before:,} they take now")
    rotated = _rewrite_regions(out, region_page, layouts.geometries, atlas)
    outcomes = [RegionOutcome(it.region.name, it.foot.by_outline, it.foot.reason) for it in layouts.footprints()]
    return PackedAtlas(out, new_pages, outcomes, layouts.padding, layouts.texels_before, texels_after,
                       len(atlas.pages), layouts.seconds + time.process_time() - t0, rotated,
                       footprint_texels=covered)


def pack_atlas(atlas: Atlas, pixels: list[np.ndarray], uses: dict[str, RegionUses],
               pinned: str = "", rotate: bool = True, padding: int | None = None,
               page_names=None, rules: PageRules = PageRules(), fills=None, on_fill=None) -> PackedAtlas:
    """Pack ``atlas`` anew by its regions' footprints: the layout of fewest page texels
    (:func:`plan_layouts`, then :func:`compose`; the parameters are :func:`plan_layouts`'s).

    Raises
    ------
    PackRefused
        When the atlas cannot be packed, or packing would store no fewer texels.
    """
    return compose(plan_layouts(atlas, pixels, uses, pinned, rotate, padding, page_names, rules, fills, on_fill,
                                keep=1))


def footprint_share(mask: np.ndarray, half: int) -> int:
    """A footprint's texels with its share of the padding: ``mask`` grown by ``half`` texels on every side."""
    return int(_grow(mask, half).sum()) if half else int(mask.sum())


def default_padding(atlas: Atlas, geometries: list[RegionGeometry]) -> int:
    """The original pages' measured padding, at least :data:`MIN_PADDING` (:data:`MIPMAP_PADDING` with mipmaps)."""
    measured = max((measured_padding([g for r, g in zip(atlas.regions, geometries) if r.page == i])
                    for i in range(len(atlas.pages))), default=0)
    mip = any(uses_mipmaps(p) for p in atlas.pages)
    return max(measured, MIPMAP_PADDING if mip else MIN_PADDING)


def _items(atlas: Atlas, geometries: list[RegionGeometry], pixels: list[np.ndarray], uses: dict[str, RegionUses],
           pinned: str, rotate: bool) -> list[_Item]:
    """Every region's footprint, its texels and the turns it may take, in atlas order."""
    first_of_name: dict[str, AtlasRegion] = {}
    for r in atlas.regions:
        first_of_name.setdefault(r.name, r)
    items: list[_Item] = []
    for r, g in zip(atlas.regions, geometries):
        if g.page_width and g.page_height:
            px = pixels[r.page]
            if g.x < 0 or g.y < 0 or g.x + g.page_width > px.shape[1] or g.y + g.page_height > px.shape[0]:
                raise PackRefused(f"region {r.name!r} lies outside its page")
        reason = rectangle_reason(r, first_of_name[r.name] is r, uses.get(r.name), pinned)
        foot = footprint(g, RegionUses(pinned=reason) if reason else uses.get(r.name))
        if uses_mipmaps(atlas.pages[r.page]):
            foot = grown_for_mipmaps(g, foot)
        texels = window_texels(pixels[r.page], g, foot.window)
        item = _Item(r, g, foot, texels, orientations(g.degrees, rotate))
        item.masks = _item_masks(item, foot.core)
        hard = _item_hard(item)
        item.hard_masks = item.masks if hard.sum() == foot.core.sum() else _item_masks(item, hard)
        items.append(item)
    return items


def _composite(layouts: AtlasLayouts, rank: int):
    """Composite the texels of each group's layout of ``rank`` (:func:`compose`) onto new pages.

    Returns the new atlas (pages rewritten, regions not yet), its page images by name, per
    region index its new page index and geometry, and the texels of the new pages under a
    footprint grown by half the padding.
    """
    atlas, items = layouts.atlas, layouts.footprints()
    out = copy.deepcopy(atlas)
    out.pages = []
    new_pages: dict[str, np.ndarray] = {}
    taken: list[np.ndarray] = []  # per new page, its texels under a footprint grown by half the padding
    half = int(round(max(0, layouts.padding - RING_TEXELS) / 2))
    region_page: dict[int, tuple[int, RegionGeometry]] = {}
    taken_names: set[str] = set()
    step = layouts.rules.step
    for gi, page_indices, members, group in layouts.groups:
        template = atlas.pages[page_indices[0]]
        placements, page_sizes = group[min(rank, len(group) - 1)]
        page_sizes = [(w + -w % step, h + -h % step) for w, h in page_sizes]
        first = len(out.pages)
        for pi, (w, h) in enumerate(page_sizes):
            name = (layouts.page_names(gi, pi, template) if layouts.page_names else
                    _page_name(atlas, page_indices, pi, taken_names))
            taken_names.add(name)
            entries = [Entry(e.key, [str(w), str(h)] if e.key == "size" else list(e.values), e.indent, e.sep, e.colon)
                       for e in template.entries]
            out.pages.append(AtlasPage(name, entries))
            new_pages[name] = np.zeros((h, w, 4), np.uint8)
            taken.append(np.zeros((h, w), bool))
        for n, place in zip(members, placements):
            item = items[n]
            k = item.turns[place.orientation]
            hard = item.hard_masks[place.orientation]
            texels = np.rot90(item.texels, k)
            h, w = hard.shape
            view = new_pages[out.pages[first + place.page].name][place.y:place.y + h, place.x:place.x + w]
            # only the hard texels: rectangles may overlap where footprints do not, footprints where both
            # are soft, and soft texels are zero on the original page as on the new one
            solid = hard is item.masks[place.orientation] and hard.all()
            if solid:
                view[...] = texels  # a solid box (a kept rectangle): copied whole, far faster
            else:
                view[hard] = texels[hard]
            region_page[n] = (first + place.page, _stored_geometry(item, k, place.x, place.y))
            page_taken = taken[first + place.page]
            x0, y0 = place.x - half, place.y - half
            cx0, cy0 = max(0, x0), max(0, y0)
            cx1, cy1 = min(page_taken.shape[1], x0 + w + 2 * half), min(page_taken.shape[0], y0 + h + 2 * half)
            if solid:  # a box grown is a box
                page_taken[cy0:cy1, cx0:cx1] = True
            else:
                grown = _grow(item.masks[place.orientation], half)
                page_taken[cy0:cy1, cx0:cx1] |= grown[cy0 - y0:cy1 - y0, cx0 - x0:cx1 - x0]
    return out, new_pages, region_page, sum(int(t.sum()) for t in taken)


def _rewrite_regions(out: Atlas, region_page: dict, geometries: list[RegionGeometry], atlas: Atlas) -> int:
    """Give ``out``'s regions their new pages and geometry, in page order; how many were turned."""
    style = next((e for r in atlas.regions for e in r.entries if len(e.values) > 1),
                 Entry("", [], "  " if atlas.syntax == "3" else "", ", ", ": "))
    rotated = 0
    for n, r in enumerate(out.regions):
        page_index, g = region_page[n]
        r.page = page_index
        r.entries = geometry_entries(r, g, out.syntax, style)
        rotated += g.degrees != geometries[n].degrees
    # the regions are written page by page (Atlas.dumps): order them so
    first_before: dict[str, AtlasRegion] = {}
    for r in out.regions:
        first_before.setdefault(r.name, r)
    out.regions = sorted(out.regions, key=lambda r: r.page)
    first_after: dict[str, AtlasRegion] = {}
    for r in out.regions:
        first_after.setdefault(r.name, r)
    if any(first_after[name] is not r for name, r in first_before.items()):
        raise PackRefused("regions of the same name would change order, and runtimes use the first")
    return rotated


def _page_name(atlas: Atlas, page_indices: list[int], index: int, taken: set[str]) -> str:
    """The original page names of the group in order; beyond them ``<first page>-<n>.<ext>``."""
    if index < len(page_indices):
        return atlas.pages[page_indices[index]].name
    base = atlas.pages[page_indices[0]].name
    stem, dot, ext = base.rpartition(".")
    if not dot:
        stem, ext = base, "png"
    n = index + 1
    # Hero-2.png beside hero.png's second page: one file on a macOS or Windows disk
    names = {portable_name(name) for name in {p.name for p in atlas.pages} | taken}
    while portable_name(f"{stem}-{n}.{ext}") in names:
        n += 1
    return f"{stem}-{n}.{ext}"
