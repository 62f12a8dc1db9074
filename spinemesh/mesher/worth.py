"""When a region should stay a region: a mesh that saves little costs more than it gives.

Game teams mesh to draw fewer pixels (fill rate) and to deform. A mesh adds vertices that
the runtime transforms every frame and uploads; a quad has four. So a region stays a region
(``upgrade`` reports it as *kept*, a deliberate skip, not a failure) when any of these holds,
tested in this order, each as soon as what it needs is known:

1. **The art fills the region.** Every mesh contains all art pixels (the default preset
   never clips), so it draws at least the art's area: when the art covers more than
   ``1 - min_saving`` of the region, no mesh can save ``min_saving``. Decided from the mask
   alone, before any geometry. (``upgrade``'s mask carries a whole texel of sampling margin,
   of which the hull keeps half, ``MesherParams.hull_inset``: the bound is then high by at
   most half a texel along the outline.)
2. **Scattered islands.** One Spine mesh is one hull loop, so separate pieces of art (rain,
   snow, sparkles) are bridged into one outline that needs at least
   :data:`VERTICES_PER_ISLAND` vertices per piece. When that many vertices pass
   :data:`MAX_HULL_VERTICES` and even the best mesh (drawing only the art) would save fewer
   than :data:`MIN_PIXELS_PER_VERTEX` pixels per vertex, the region is kept: the rule 3
   below, bounded from the mask's connected pieces before the costly bridging. Nobody
   deforms a rain sheet.
3. **The hull saves too little.** Once the covering hull is known (before the interior
   edges and the triangulation, the expensive steps), the mesh is kept a region when the
   hull draws less than ``min_saving`` fewer pixels than the quad, or when its outline needs
   more than :data:`MAX_HULL_VERTICES` vertices while saving fewer than
   :data:`MIN_PIXELS_PER_VERTEX` pixels per vertex (a big mesh that saves a lot still pays).

``min_saving`` (``spinemesh upgrade --min-saving``, :data:`DEFAULT_MIN_SAVING`) and the two
limits were chosen from an upgrade of a corpus of real game projects
(``benchmarks/bench_corpus_upgrade.py``; figures in the README).
"""

from __future__ import annotations

import numpy as np

from ..errors import ImageError
from .exterior import pieces
from .geometry import signed_area

#: ``upgrade``'s default: keep the region when a mesh would draw less than this share fewer pixels.
DEFAULT_MIN_SAVING = 0.05
#: A hull with more vertices than this must save at least MIN_PIXELS_PER_VERTEX pixels per vertex.
MAX_HULL_VERTICES = 200
MIN_PIXELS_PER_VERTEX = 500
#: Fewest hull vertices one bridged island adds (its bridge's two sides and its far side).
VERTICES_PER_ISLAND = 3
#: ``upgrade``'s cap (px) on the hull tolerance (``MesherParams.max_hull_tolerance``): the
#: tolerance grows with the art's size, and on large art (glows, rays, light) a cap of 16 px
#: still saves more than MIN_PIXELS_PER_VERTEX pixels per vertex it adds (on the corpus's
#: VFX-heavy projects: 2.1 Mpx for 3,426 vertices; the next step, 8 px, saves 300-430 each).
MAX_HULL_TOLERANCE = 16.0


class NotWorthMeshing(ImageError):
    """The image is better drawn as a region; the message says why (it starts "not worth meshing")."""


def percent(share: float) -> str:
    """``share`` (0..1) as a percentage with the digits it needs, at most two: 0.05 -> "5%"."""
    return f"{round(100 * share, 2):g}%"


def percents_below(share: float, limit: float) -> tuple[str, str]:
    """``share`` and ``1 - share`` as percentages, ``share`` reading as below ``limit``.

    Rounding to whole percents would print a saving of 4.8% against a limit of 5% as "5%", which
    reads as a contradiction; this uses the fewest decimals (0 to 2) that keep the printed share
    below the printed limit, or "under" the limit when even two decimals do not. A share above 0
    never prints as "0%" (art filling 99.6% of a region read "fills 100% ... at most 0% fewer").

    Returns
    -------
    tuple of str
        ``share`` (for example ``"4.8%"``) and its complement with the same decimals (``"95.2%"``).
    """
    share = min(max(share, 0.0), 1.0)
    for digits in (0, 1, 2):
        shown = round(100 * share, digits)
        if shown < round(100 * limit, 2) and (shown > 0 or share == 0):
            return f"{100 * share:.{digits}f}%", f"{100 * (1 - share):.{digits}f}%"
    if 0 < share < 0.0001 < limit:
        return "under 0.01%", "over 99.99%"
    return f"under {percent(limit)}", f"over {percent(1 - limit)}"


def art_share_reason(mask: np.ndarray, min_saving: float) -> str:
    """Rule 1: ``""``, or why no mesh of ``mask`` can save ``min_saving`` of the region."""
    share = float(np.count_nonzero(mask)) / max(mask.size, 1)
    if min_saving > 0 and 1.0 - share < min_saving:
        free, filled = percents_below(1.0 - share, min_saving)
        return (f"not worth meshing: the art fills {filled} of the region, so a mesh would draw "
                f"at most {free} fewer pixels (--min-saving {percent(min_saving)})")
    return ""


def islands_reason(mask: np.ndarray, pixel_area: float = 1.0, max_vertices: int = MAX_HULL_VERTICES,
                   min_per_vertex: float = MIN_PIXELS_PER_VERTEX, labels: tuple[int, np.ndarray] | None = None) -> str:
    """Rule 2: ``""``, or why the separate pieces of ``mask`` cost more vertices than they save.

    ``mask`` may be a block-maximum downscale of the art (what the hull is built on); then
    its pieces are counted at that scale and each of its pixels stands for ``pixel_area``
    full-size pixels. ``labels``: ``mask``'s 8-connected pieces as
    :func:`~.exterior.pieces` gives them, when the caller has them already (the hull
    bridges the same pieces).
    """
    if labels is None:
        labels = pieces(mask)
    need = VERTICES_PER_ISLAND * (labels[0] - 1)
    if need <= max_vertices:
        return ""
    best = pixel_area * float(mask.size - np.count_nonzero(mask)) / need  # pixels saved per vertex, at best
    if best < min_per_vertex:
        return (f"not worth meshing: {need // VERTICES_PER_ISLAND} separate islands of art need {need}+ "
                f"outline vertices to save at most {best:.0f} pixels each (fewer than {min_per_vertex:g})")
    return ""


def hull_reason(hull: np.ndarray, width: float, height: float, min_saving: float,
                max_vertices: int = MAX_HULL_VERTICES, min_per_vertex: float = MIN_PIXELS_PER_VERTEX) -> str:
    """Rule 3: ``""``, or why a mesh with this covering ``hull`` (n, 2) px would not pay."""
    area = abs(signed_area(hull))
    saving = 1.0 - area / max(float(width) * float(height), 1e-12)
    if min_saving > 0 and saving < min_saving:
        return (f"not worth meshing: a mesh would draw only {percents_below(saving, min_saving)[0]} fewer "
                f"pixels than the region (--min-saving {percent(min_saving)})")
    saved = saving * float(width) * float(height)
    if len(hull) > max_vertices and saved < min_per_vertex * len(hull):
        return (f"not worth meshing: its outline needs {len(hull)} vertices (more than {max_vertices}) to save "
                f"{saved / len(hull):.0f} pixels per vertex (fewer than {min_per_vertex:g})")
    return ""


def worth_meshing(mask: np.ndarray, min_saving: float = DEFAULT_MIN_SAVING) -> str:
    """Rules 1 and 2, from the mask alone: ``""`` when a mesh may pay, else the reason.

    Parameters
    ----------
    mask : ndarray, shape (H, W), bool
        What the mesh must cover (the art, with any sampling margin), over the whole region.
    min_saving : float
        Share of the region's pixels a mesh must save (0..1); 0 turns rule 1 off.

    Returns
    -------
    str
        ``""`` or a reason starting with "not worth meshing".
    """
    return art_share_reason(mask, min_saving) or islands_reason(mask)
