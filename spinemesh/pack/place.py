"""Placing footprints (binary masks of any shape) on pages: raster first fit, largest first.

Rectangle packers cannot use the space a mesh leaves free inside its rectangle; this one
works on the texels themselves. A footprint may also have *soft* texels: texels that only have
to stay all zero for it (see :func:`spinemesh.pack.outlines.hard_texels`); the rest are *hard*.
Each page keeps two occupancy bitmaps: every placed footprint grown by the padding, and their
hard texels grown by the padding. A new footprint goes where its hard texels meet neither
bitmap and its soft texels meet no hard one: footprints may overlap where both are soft (the
page holds zeros there), hard texels keep the padding from anything of another footprint, and
rectangles may overlap wherever footprints may.

Finding the first free place is one correlation of the occupancy with the footprint
(``cv2.matchTemplate``) on a coarse grid of cells (a cell is taken when any texel in it is,
which keeps the search conservative), two where both the page and the footprint have soft
texels; then the footprint slides up and left texel by texel into the gaps the coarse grid
could not see. Every place is checked at texel level before it is taken.

Throughout, a footprint's hard mask is passed as ``hard``; ``None`` or the mask itself means
every texel is hard (the common case, which costs one bitmap and one correlation).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Longest side of the coarse grid the first-fit search runs on, in cells.
COARSE_SIDE = 512

#: Texel steps a placed footprint may slide up or left into a gap, per pass.
SLIDE_STEPS = 16

#: How the tightest fit ranks the pages a place would leave, without powers of two (see
#: :meth:`Page.tightest_fit`): by the longer side (pages near the square), by half the perimeter
#: (width + height), or by the area alone. Each packs some atlases best: a fill tries each.
PAGE_SHAPES = ("square", "perimeter", "area")

#: Side of the cells of the full-cell grid (:meth:`Page._surely_taken`), in cells of the coarse grid.
FULL_CELLS = 2

#: Places whose soft cells are checked cell by cell at once, and the most cells so checked per
#: search before one correlation checks the rest (about what one correlation costs).
KEEP_CLEAR_BATCH = 256
KEEP_CLEAR_CELLS = 40_000


@dataclass
class Placement:
    """Where one footprint went: page index, orientation index (into its candidate masks), top-left texel."""

    page: int
    orientation: int
    x: int
    y: int


def _grow(mask: np.ndarray, padding: int) -> np.ndarray:
    """``mask`` grown by ``padding`` texels on every side (square neighbourhood), shape + 2*padding."""
    import cv2

    if padding <= 0:
        return mask.copy()
    padded = np.pad(mask, padding).astype(np.uint8)
    return cv2.dilate(padded, np.ones((2 * padding + 1, 2 * padding + 1), np.uint8)).astype(bool)


def block_any(mask: np.ndarray, cell: int, grow: int = 0) -> np.ndarray:
    """Cells of ``cell x cell`` texels that hold a set texel (of ``mask`` grown by ``grow`` texels), bool.

    The mask's top-left texel starts the first cell; a partial last row or column of cells
    counts. One ``cv2.dilate`` (a max filter) sampled every ``cell`` texels: far faster than a
    reduction over reshaped axes.
    """
    import cv2

    h, w = mask.shape
    hc, wc = -(-h // cell), -(-w // cell)
    src = np.zeros((hc * cell, wc * cell), np.uint8)
    src[:h, :w] = mask
    if cell == 1 and grow == 0:
        return src.astype(bool)
    size = cell + 2 * grow
    # window of texel rows [i*cell - grow, i*cell + cell + grow) for cell i
    out = cv2.dilate(src, np.ones((size, size), np.uint8), anchor=(grow, grow),
                     borderType=cv2.BORDER_CONSTANT, borderValue=0)
    return out[::cell, ::cell].astype(bool)


def _pot(n: np.ndarray) -> np.ndarray:
    """The least power of two at or above each of ``n`` (>= 1), int64."""
    n = np.maximum(1, np.asarray(n, np.int64))
    return np.left_shift(1, np.ceil(np.log2(n)).astype(np.int64))


def _coarse(mask: np.ndarray, cell: int) -> np.ndarray:
    """Cells of side ``cell`` that hold any set texel (the mask's top-left texel starts a cell)."""
    return block_any(mask, cell)


def _shape_cost(w, h, shape: str):
    """What the tightest fit ranks a used area of ``w x h`` texels by, without powers of two (:data:`PAGE_SHAPES`)."""
    if shape == "square":
        return np.maximum(w, h)
    if shape == "perimeter":
        return w + h
    if shape == "area":
        return w * h
    raise ValueError(f"page shape {shape!r}: one of {', '.join(PAGE_SHAPES)}")


class Page:
    """One page being filled: occupancy at texel level and on the coarse grid.

    ``taken``: every placed footprint grown by the padding; ``taken_hard``: their hard texels
    grown by the padding, None while every placed texel is hard (then it equals ``taken``).
    """

    def __init__(self, width: int, height: int, padding: int):
        self.width, self.height, self.padding = width, height, padding
        self.cell = max(1, -(-max(width, height) // COARSE_SIDE))
        self.taken = np.zeros((height, width), bool)
        self.coarse = np.zeros((-(-height // self.cell), -(-width // self.cell)), np.float32)
        self.taken_hard: np.ndarray | None = None
        self.coarse_hard: np.ndarray | None = None
        self.used_w = self.used_h = 0
        self.free = width * height  # texels under no placed hard texel
        # cells of FULL_CELLS coarse cells whose every texel is taken (texels off the page count as taken)
        self.full_side = self.cell * FULL_CELLS
        self.full = np.zeros((-(-height // self.full_side), -(-width // self.full_side)), np.float32)
        self.found_none = False  # whether the last search found no place

    def _both(self, mask: np.ndarray, hard: np.ndarray | None) -> bool:
        """Whether ``mask`` (hard part ``hard``) must be checked against both bitmaps.

        Not when every texel of the footprint is hard (its texels must miss ``taken``, which
        holds ``taken_hard``), nor while every texel of the page is (the two bitmaps are one).
        """
        return hard is not None and hard is not mask and self.taken_hard is not None

    def fits(self, mask: np.ndarray, x: int, y: int, hard: np.ndarray | None = None) -> bool:
        """Whether ``mask`` at ``(x, y)`` stays on the page, its hard texels (``hard``, default all)
        meet no taken texel and the rest no taken hard texel."""
        h, w = mask.shape
        if x < 0 or y < 0 or x + w > self.width or y + h > self.height:
            return False
        if not self._both(mask, hard):
            return not (self.taken[y:y + h, x:x + w] & mask).any()
        return not ((self.taken[y:y + h, x:x + w] & hard).any()
                    or (self.taken_hard[y:y + h, x:x + w] & mask).any())

    def _search_limit(self, w: int, h: int) -> tuple[int, int]:
        """The last top-left texel ``(x, y)`` worth a search for a ``w x h`` mask.

        Nothing lies right of the used width or below the used height (but padding), so a place
        further right or down is free whenever the place at that edge is, and only grows the
        page: the search stops one cell past the edge, which keeps the correlation small.
        """
        reach = self.padding + self.cell
        return min(self.width - w, self.used_w + reach), min(self.height - h, self.used_h + reach)

    def free_places(self, mask: np.ndarray, first: int | None = None, hard: np.ndarray | None = None
                    ) -> tuple[np.ndarray, np.ndarray]:
        """Top-left texels ``(xs, ys)`` where ``mask`` (hard part ``hard``) may go, row by row (top first, then left).

        Places are cell-aligned and conservative (every one fits at texel level), within
        :meth:`_search_limit`; empty when the mask cannot go on this page. ``first``: only
        the first so many places (found without listing them all).
        """
        xs, ys, soft = self._places(mask, hard, first)
        if soft is None:
            return xs, ys
        keep = self._keep_clear(xs, ys, soft)
        return xs[keep], ys[keep]

    def _places(self, mask: np.ndarray, hard: np.ndarray | None, first: int | None = None
                ) -> tuple[np.ndarray, np.ndarray, tuple | None]:
        """Places where the footprint's hard cells meet no taken cell: ``(xs, ys, soft)``.

        ``soft`` is None when these places are all free (see :meth:`free_places`); else its
        soft cells (those without a hard texel) must still miss taken hard cells
        (:meth:`_keep_clear`): ``(rows, columns, template)``, the cells' offsets and the
        footprint's coarse template. Finding hard cells first and checking the soft ones only
        at the places a fill looks at costs one correlation where two would list them all.
        ``first``: only the first so many places (found without listing them all), all free
        (``soft`` None).
        """
        none = np.zeros(0, np.int64), np.zeros(0, np.int64), None
        h, w = mask.shape
        if w > self.width or h > self.height or self.free < int((mask if hard is None else hard).sum()):
            return none
        # once a footprint found no place, the page is often full: most that follow find none either,
        # and proving it costs little; while footprints find places, the proof is seldom made
        if self.found_none and self._surely_taken(mask if hard is None else hard, *self._search_limit(w, h)):
            return none
        xs, ys, soft = self._search(mask, hard, first)
        self.found_none = xs.size == 0
        return xs, ys, soft

    def _search(self, mask: np.ndarray, hard: np.ndarray | None, first: int | None = None
                ) -> tuple[np.ndarray, np.ndarray, tuple | None]:
        """The search of :meth:`_places` on the coarse grid (or texel by texel on a small page)."""
        import cv2

        none = np.zeros(0, np.int64), np.zeros(0, np.int64), None
        h, w = mask.shape
        cell = self.cell
        template = _coarse(mask, cell).astype(np.float32)
        hc, wc = template.shape
        last_x, last_y = self._search_limit(w, h)
        # a cell-aligned place of the template must also keep the texels on the page
        max_cx, max_cy = last_x // cell, last_y // cell
        region = self.coarse[:max_cy + hc, :max_cx + wc]
        if region.shape[0] < hc or region.shape[1] < wc:
            return (*self._texel_scan(mask, hard), None)
        soft = None
        if self.used_w == 0 and self.used_h == 0:
            scores = np.zeros((region.shape[0] - hc + 1, region.shape[1] - wc + 1), np.float32)
        else:
            hard_template = _coarse(hard, cell).astype(np.float32) if self._both(mask, hard) else template
            scores = cv2.matchTemplate(region, hard_template, cv2.TM_CCORR)
            if hard_template is not template:
                rows, cols = np.nonzero(template > hard_template)
                soft = (rows, cols, template) if rows.size else None
        free = scores[:max_cy + 1, :max_cx + 1] < 0.5
        if first is None:
            cy, cx = np.nonzero(free)
            return cx.astype(np.int64) * cell, cy.astype(np.int64) * cell, soft
        start = int(np.argmax(free))  # the first free place, found without a full listing
        flat = free.ravel()
        if not flat[start]:
            return none
        # soft cells may rule out many places: then look further, and at every place if need be
        spans = [(start, start + 4 * first)] if soft is None else [(start, start + 64 * first),
                                                                   (start + 64 * first, flat.size)]
        for lo, hi in spans:
            index = lo + np.flatnonzero(flat[lo:hi])
            cy, cx = np.divmod(index, free.shape[1])
            xs, ys = cx.astype(np.int64) * cell, cy.astype(np.int64) * cell
            keep = np.arange(min(first, xs.size)) if soft is None else self._keep_clear(xs, ys, soft, first)
            if keep.size:
                break
        return xs[keep], ys[keep], None

    def _surely_taken(self, hard: np.ndarray, last_x: int, last_y: int) -> bool:
        """Whether every place of a footprint whose hard texels are ``hard``, top-left texel up to
        ``(last_x, last_y)``, puts a hard texel on a taken one: proved on the full-cell grid.

        A full cell (:attr:`full`, side ``F`` texels) is taken in every texel. The places whose
        top-left texel lies in one cell ``(X, Y)`` of that grid put the footprint over full cell
        ``(X + i, Y + j)`` whole, wherever in the cell they start, when ``hard`` holds the
        ``(2F - 1)``-texel box at ``(iF - F + 1, jF - F + 1)``: so one correlation of the full cells
        with those boxes on a grid ``F`` times coarser than the page's texels proves, for most
        footprints that find no place on a full page, that none exists, at a small part of the
        cost of the search. False where it proves nothing (some place may be free).
        """
        import cv2

        side = self.full_side
        h, w = hard.shape
        rows, cols = (h - side) // side, (w - side) // side  # the last i, j whose box lies within the mask
        last_cx, last_cy = last_x // side, last_y // side
        if rows < 1 or cols < 1:
            return False
        box = 2 * side - 1
        inner = cv2.erode(hard.astype(np.uint8), np.ones((box, box), np.uint8), anchor=(0, 0),
                          borderType=cv2.BORDER_CONSTANT, borderValue=0)
        template = np.zeros((rows + 1, cols + 1), np.float32)
        template[1:, 1:] = inner[1::side, 1::side][:rows, :cols]  # box i at (i - 1) * F + 1
        if not template.any():
            return False
        need_h, need_w = last_cy + rows + 1, last_cx + cols + 1
        full = self.full[:need_h, :need_w]
        if full.shape != (need_h, need_w):  # past the page's last cell: nothing taken (proves nothing there)
            full = np.pad(full, ((0, need_h - full.shape[0]), (0, need_w - full.shape[1])))
        scores = cv2.matchTemplate(full, template, cv2.TM_CCORR)
        return bool((scores[:last_cy + 1, :last_cx + 1] >= 0.5).all())

    def _keep_clear(self, xs: np.ndarray, ys: np.ndarray, soft: tuple, first: int | None = None) -> np.ndarray:
        """Indices of the places ``(xs, ys)`` (from :meth:`_places`) whose soft cells miss every taken hard
        cell, in order; ``first``: only the first so many.

        Checked cell by cell in batches while that is cheap, then by one correlation for the rest.
        """
        import cv2

        rows, cols, template = soft
        cy, cx = ys // self.cell, xs // self.cell
        kept, done = [], 0
        most = max(1, min(KEEP_CLEAR_BATCH, KEEP_CLEAR_CELLS // (2 * rows.size)))
        size = min(most, 16)  # the first places often pass: a small batch first, then larger ones
        while done < cy.size and (first is None or sum(k.size for k in kept) < first):
            if (done + size) * rows.size > KEEP_CLEAR_CELLS:
                hc, wc = template.shape
                scores = cv2.matchTemplate(self.coarse_hard[:cy.max() + hc, :cx.max() + wc], template, cv2.TM_CCORR)
                rest = np.arange(done, cy.size)
                kept.append(rest[scores[cy[rest], cx[rest]] < 0.5])
                break
            batch = np.arange(done, min(cy.size, done + size))
            hit = self.coarse_hard[cy[batch, None] + rows, cx[batch, None] + cols].any(axis=1)
            kept.append(batch[~hit])
            done = batch[-1] + 1
            size = min(most, 4 * size)
        kept = np.concatenate(kept) if kept else np.zeros(0, np.int64)
        return kept if first is None else kept[:first]

    def first_fit(self, mask: np.ndarray, hard: np.ndarray | None = None) -> tuple[int, int] | None:
        """The first free place of ``mask`` (top rows first, then left), or None."""
        xs, ys = self.free_places(mask, first=64, hard=hard)
        for x, y in zip(xs.tolist(), ys.tolist()):  # conservative: the first fits; checked all the same
            if self.fits(mask, x, y, hard):
                return self._slide(mask, x, y, hard)
        return None

    def tightest_fit(self, mask: np.ndarray, max_area: int, pot: bool, hard: np.ndarray | None = None,
                     shape: str = "square") -> tuple[tuple, int, int] | None:
        """The free place that grows the used area least: ``(cost, x, y)``, or None.

        The cost is the used area's page rounded to powers of two when ``pot``, else by
        ``shape`` (:data:`PAGE_SHAPES`): its longer side (``square``, the default: a strip of
        least area now leaves no room for what comes later), its width + height
        (``perimeter``) or its area (``area``); then the used area itself, then top rows
        first, then left. Places whose rounded page would exceed ``max_area`` texels are
        passed over.
        """
        xs, ys, soft = self._places(mask, hard)
        if xs.size == 0:
            return None
        h, w = mask.shape
        new_w = np.maximum(self.used_w, xs + w)
        new_h = np.maximum(self.used_h, ys + h)
        page = (_pot(new_w) * _pot(new_h)) if pot else new_w * new_h
        area = new_w * new_h
        side = _shape_cost(new_w, new_h, shape)
        ok = np.flatnonzero(page <= max_area)
        if ok.size == 0:
            return None
        first = page if pot else side  # without powers of two the page is the used area itself
        ranked = ok[np.lexsort((xs[ok], ys[ok], area[ok], first[ok]))]
        if soft is not None:  # the best places first: most are passed over unchecked
            ranked = ranked[self._keep_clear(xs[ranked], ys[ranked], soft, 64)]
        for i in ranked[:64].tolist():
            x, y = int(xs[i]), int(ys[i])
            if self.fits(mask, x, y, hard):
                x, y = self._slide(mask, x, y, hard)
                nw, nh = max(self.used_w, x + w), max(self.used_h, y + h)
                first = int(_pot(nw)) * int(_pot(nh)) if pot else int(_shape_cost(nw, nh, shape))
                return (first, nw * nh, y, x), x, y
        return None

    def _texel_scan(self, mask: np.ndarray, hard: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Exact search at texel level (pages too small for the coarse grid to help): ``(xs, ys)``."""
        import cv2

        taken = self.taken.astype(np.float32)
        if not self._both(mask, hard):
            scores = cv2.matchTemplate(taken, mask.astype(np.float32), cv2.TM_CCORR)
        else:
            scores = (cv2.matchTemplate(taken, hard.astype(np.float32), cv2.TM_CCORR)
                      + cv2.matchTemplate(self.taken_hard.astype(np.float32), mask.astype(np.float32),
                                          cv2.TM_CCORR))
        ys, xs = np.nonzero(scores < 0.5)
        return xs.astype(np.int64), ys.astype(np.int64)

    def _slide(self, mask: np.ndarray, x: int, y: int, hard: np.ndarray | None = None) -> tuple[int, int]:
        """Move a fitting place up, then left, while it still fits (the coarse grid rounds places down)."""
        for _ in range(2):
            moved = False
            for _ in range(SLIDE_STEPS):
                if y > 0 and self.fits(mask, x, y - 1, hard):
                    y -= 1
                    moved = True
                else:
                    break
            for _ in range(SLIDE_STEPS):
                if x > 0 and self.fits(mask, x - 1, y, hard):
                    x -= 1
                    moved = True
                else:
                    break
            if not moved:
                break
        return x, y

    def take(self, mask: np.ndarray, x: int, y: int, extent: tuple[int, int], hard: np.ndarray | None = None
             ) -> None:
        """Mark ``mask`` (hard part ``hard``) at ``(x, y)``, grown by the padding, as taken; ``extent`` (w, h)
        counts as used."""
        hard = mask if hard is None else hard
        if hard is not mask and self.taken_hard is None:  # the first soft texel: the bitmaps part
            self.taken_hard, self.coarse_hard = self.taken.copy(), self.coarse.copy()
        grown = _grow(mask, self.padding)
        self._mark(self.taken, self.coarse, grown, x, y)
        if self.taken_hard is not None:
            self._mark(self.taken_hard, self.coarse_hard, grown if hard is mask else _grow(hard, self.padding), x, y)
        self.free -= int(hard.sum())
        self.used_w = max(self.used_w, x + extent[0])
        self.used_h = max(self.used_h, y + extent[1])

    def _mark(self, taken: np.ndarray, coarse: np.ndarray, grown: np.ndarray, x: int, y: int) -> None:
        """Set ``grown`` (a mask at ``(x, y)`` grown by the padding) in ``taken``, and its cells in ``coarse``."""
        p = self.padding
        h, w = grown.shape
        x0, y0 = x - p, y - p
        cx0, cy0 = max(0, x0), max(0, y0)
        cx1, cy1 = min(self.width, x0 + w), min(self.height, y0 + h)
        taken[cy0:cy1, cx0:cx1] |= grown[cy0 - y0:cy1 - y0, cx0 - x0:cx1 - x0]
        c = self.cell
        gy0, gx0, gy1, gx1 = cy0 // c, cx0 // c, -(-cy1 // c), -(-cx1 // c)
        coarse[gy0:gy1, gx0:gx1] = _coarse(taken[gy0 * c:gy1 * c, gx0 * c:gx1 * c], c)[:gy1 - gy0, :gx1 - gx0]
        if taken is self.taken:
            f = self.full_side
            fy0, fx0, fy1, fx1 = cy0 // f, cx0 // f, -(-cy1 // f), -(-cx1 // f)
            block = np.ones(((fy1 - fy0) * f, (fx1 - fx0) * f), bool)  # off the page: taken
            part = taken[fy0 * f:fy1 * f, fx0 * f:fx1 * f]
            block[:part.shape[0], :part.shape[1]] = part
            self.full[fy0:fy1, fx0:fx1] = block.reshape(fy1 - fy0, f, fx1 - fx0, f).all(axis=(1, 3))


def largest_first(candidates: list[list[np.ndarray]]) -> list[int]:
    """Footprint indices by present mask area, then height, largest first (ties by index)."""
    return sorted(range(len(candidates)), key=lambda i: (-candidates[i][0].size, -candidates[i][0].shape[0], i))


def fill_pages(candidates: list[list[np.ndarray]], width: int, height: int, padding: int,
               order: list[int] | None = None, max_pages: int | None = None, tight: bool = False,
               max_area: int | None = None, pot: bool = False, budget: int | None = None,
               hard: list[list[np.ndarray]] | None = None, shape: str = "square"
               ) -> tuple[list[Placement | None], list[tuple[int, int]]]:
    """Place every footprint on as few pages of ``width x height`` as the greedy fill gives.

    Parameters
    ----------
    candidates : list of list of ndarray
        Per footprint, its masks (bool, shape (h, w)) in each orientation it may take; the
        first is its present orientation. A place keeps the whole mask's rectangle on the page.
    width, height : int
        Page size, in texels.
    padding : int
        Texels left free between the hard texels of one footprint and anything of another.
    order : list of int, optional
        The order to place them in; default largest mask area first.
    max_pages : int, optional
        Stop once this many pages are full (what is left stays None): a size that cannot
        hold everything fails fast. Also stop as soon as the footprints left cannot go on the
        pages left however placed (:func:`least_share`): such a fill would fail anyway.
    tight : bool
        Where each footprint goes. False (default): the first free place, top rows first,
        the orientation whose bottom edge is lowest (the page fills downwards, for a page of
        this width). True: the place and orientation that grow the used area (rounded to
        powers of two when ``pot``) least, so that the page takes the shape its footprints
        pack best in, within ``max_area`` texels.
    max_area : int, optional
        With ``tight``, the most texels a page's used area (rounded) may take; default the page's.
    pot : bool
        With ``tight``, pages are rounded to powers of two.
    budget : int, optional
        Give up (placements None from there on) once the pages' used areas add up to this
        many texels: a fill that cannot beat an earlier one stops early.
    hard : list of list of ndarray, optional
        Per footprint and orientation, its hard texels (bool, the mask's shape, within the
        mask); the rest of the mask is soft and may overlap other footprints' soft texels.
        Default: every texel is hard. Pass the mask itself where all of it is hard (faster).
    shape : str
        With ``tight`` and without ``pot``, how places rank the page they would leave
        (:data:`PAGE_SHAPES`; default ``square``, by its longer side).

    Returns
    -------
    placements : list of Placement or None
        Per footprint (in the order given); None for one larger than a page.
    used : list of (int, int)
        Per page, the width and height its footprints reach.
    """
    order = largest_first(candidates) if order is None else order
    limit = max_area or width * height
    placements: list[Placement | None] = [None] * len(candidates)
    pages: list[Page] = []
    left = [i for i in order if any(m.shape[1] <= width and m.shape[0] <= height for m in candidates[i])]
    boxes = {i: _solid_boxes(candidates[i], None if hard is None else hard[i]) for i in left}
    reach = padding // 2
    room = (width + 2 * reach) * (height + 2 * reach)
    shares = {} if max_pages is None else {i: least_share((candidates if hard is None else hard)[i][0], reach)
                                           for i in left}
    while left and (max_pages is None or len(pages) < max_pages):
        if shares and sum(shares[i] for i in left) > (max_pages - len(pages)) * room:
            break  # the pages left cannot take what is left, however placed (see least_share): fail now
        pages.append(Page(width, height, padding))
        still = _fill_page(pages, left, candidates, hard, boxes, placements, (tight, limit, pot, shape), budget)
        if still is None:  # over the budget
            return [None] * len(candidates), [(p.used_w, p.used_h) for p in pages]
        if len(still) == len(left):  # nothing fitted on an empty page: cannot happen (sizes checked)
            pages.pop()
            break
        left = still
    return placements, [(p.used_w, p.used_h) for p in pages]


def _fill_page(pages: list[Page], left: list[int], candidates, hard, boxes: dict, placements: list,
               how: tuple, budget: int | None) -> list[int] | None:
    """One page of :func:`fill_pages` (the last of ``pages``) filled with what it can take of
    ``left``, in order; ``placements`` set for those. Returns the footprints still left, or None
    once the pages' used areas reach ``budget``. ``how``: ``(tight, limit, pot, shape)``."""
    tight, limit, pot, shape = how
    page = pages[-1]
    still = []
    failed: list[tuple[int, int]] = []  # solid boxes (h, w) that found no place on this page
    for i in left:
        if boxes[i] is not None and all(any(fh <= h and fw <= w for fh, fw in failed) for h, w in boxes[i]):
            still.append(i)  # a solid box no larger found no place: neither does this one
            continue
        hards = candidates[i] if hard is None else hard[i]
        best = _best_place(page, candidates[i], hards, tight, limit, pot, shape)
        if best is None:
            if boxes[i] is not None:
                failed += boxes[i]
            still.append(i)
            continue
        k, x, y = best
        mask = candidates[i][k]
        page.take(mask, x, y, (mask.shape[1], mask.shape[0]), hards[k])
        placements[i] = Placement(len(pages) - 1, k, x, y)
        if budget is not None and sum(p.used_w * p.used_h for p in pages) >= budget:
            return None
    return still


def least_share(hard: np.ndarray, reach: int) -> int:
    """The fewest texels a footprint's hard texels ``hard`` (bool, (h, w)) take grown by ``reach``
    texels on every side (square neighbourhood), without growing them: a lower bound, exact for a box.

    With ``reach`` half the padding (rounded down), two footprints' hard texels so grown never
    share a texel (hard texels keep the padding from anything of another footprint), and they
    stay within the page grown by ``reach``: footprints whose shares add up to more than the
    pages' so grown texels cannot all go on them, however placed. Growing each row adds at
    least ``reach`` texels at each end of it, then growing each column of that at least
    ``reach`` at each end; the grown rows span ``2 * reach`` columns more than the mask's.
    The same for every quarter turn of the mask.
    """
    rows = int(np.count_nonzero(hard.any(axis=1)))
    if rows == 0:
        return 0
    columns = int(np.count_nonzero(hard.any(axis=0)))
    return int(np.count_nonzero(hard)) + 2 * reach * rows + 2 * reach * (columns + 2 * reach)


def _solid_boxes(masks: list[np.ndarray], hards: list[np.ndarray] | None) -> list[tuple[int, int]] | None:
    """The shapes ``(h, w)`` of a footprint's masks when every one is a solid box of hard texels, else None.

    Where a solid box finds no place on a page, no solid box at least as high and as wide does,
    then or later (a place of the larger holds the smaller at its top-left corner, on the
    coarse grid too, and growing the page as little): the fill passes such boxes over
    untried. Regions that keep their rectangles are solid boxes, most of an atlas's often.
    """
    for k, m in enumerate(masks):
        if not m.all() or (hards is not None and hards[k] is not m and not hards[k].all()):
            return None
    return [m.shape for m in masks]


def _best_place(page: Page, masks: list[np.ndarray], hards: list[np.ndarray], tight: bool, max_area: int,
                pot: bool, shape: str = "square") -> tuple[int, int, int] | None:
    """``(orientation, x, y)`` of the best place of one footprint (``masks``, hard parts ``hards``) on
    ``page`` (see :func:`fill_pages`), or None."""
    best = None
    for k, (mask, hard) in enumerate(zip(masks, hards)):
        if tight:
            found = page.tightest_fit(mask, max_area, pot, hard, shape)
            if found is None:
                continue
            score, x, y = found
        else:
            place = page.first_fit(mask, hard)
            if place is None:
                continue
            x, y = place
            # the lowest bottom edge keeps the page short, then the leftmost place
            score = (max(page.used_h, y + mask.shape[0]), y, x)
        if best is None or score < best[0]:
            best = (score, k, x, y)
    return None if best is None else best[1:]
