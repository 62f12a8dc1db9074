"""Runtime proof of ``spinemesh pack``: a packed project renders like the unpacked one.

For every project folder given (by default every example of 3.8-4.2 and every corpus project)
and every skeleton in it whose Spine version the harness ``../shared/tools/spine-runtime``
renders (3.8, 4.0, 4.1, 4.2):

1. ``spinemesh pack`` the project into a scratch folder (default options; with ``--upgrade``,
   ``spinemesh upgrade`` it first and pack a copy of the upgrade in place, as ``upgrade --pack``
   does, then compare against the upgrade);
2. render the same skeleton file with the original atlas and with the packed one, in the same
   frame: the setup pose, then two frames (0.3 s and 0.7 s) of up to three animations; with
   named skins, the first one too;
3. compare the renders premultiplied: a render passes when no pixel differs by more than
   2/255 (the upgrade proof's tolerance), apart from at most ``MAX_OFF_SHARE`` of its pixels
   (1e-5: float32 UVs over a new page size, see there).

The skeleton files are the very same bytes on both sides (packing changes atlases and pages
only), so any difference comes from the pages.

The harness draws without mipmaps. ``--mipmaps`` proves a copy of each project whose pages all
have a ``MipMap`` min filter (so packing pads for mipmaps), and checks mipmap bleeding texel by
texel: per region, the deepest level at which what it draws reads no texel of another region
(:func:`mip_clean_level`), on the original and the packed pages. Every region must be clean at
``MIP_REQUIRED``; regions clean to a lower level than before are counted, not failed. And per
level, the texels each region's drawn texels read there on the packed page against the original
page's, downscaled with the region's blocks falling as they fall on the packed page
(:func:`mip_texel_differences`): within ``TOLERANCE`` at every level up to ``MIP_REQUIRED``,
deeper levels reported. Atlases whose own pages use ``MipMap`` filters get the same checks
without ``--mipmaps``.

    .venv/bin/python scripts/prove_pack.py                                # examples + corpus (slow: nice)
    .venv/bin/python scripts/prove_pack.py ../shared/spine-examples/4.2/spineboy --json build/pack-proof.json
    .venv/bin/python scripts/prove_pack.py --upgrade --every 3 --json build/upgrade-pack-proof.json
    .venv/bin/python scripts/prove_pack.py --mipmaps --only 'jt-*'           # pages given a MipMap filter
    .venv/bin/python scripts/prove_pack.py --tables-from build/*.json        # tables of saved runs
"""

from __future__ import annotations

import argparse
import fnmatch
import json
import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests"))
sys.path.insert(0, str(REPO / "scripts"))

from prove_corpus import (CORPUS, RENDERABLE, TOLERANCE, harness_atlas, harness_copy, pose_list,  # noqa: E402
                          prove_each, renderable, skins_to_render)
from runtime_tool import dump, install, render, render_difference  # noqa: E402

from spinemesh.errors import SpineMeshError  # noqa: E402
from spinemesh.pack.report import PackResult  # noqa: E402
from spinemesh.pack.run import PackOptions, pack_project_into  # noqa: E402
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

#: Mipmap levels checked: level ``L`` averages blocks of ``2**L`` texels (2 to 16).
MIP_LEVELS = 4

#: Mipmap levels every region of a packed MipMap page must read clean of other regions: the
#: packer's mipmap padding (4 texels between what two regions draw) guarantees level 1 (blocks of
#: 2); deeper levels depend on where blocks fall, as on the exporter's own pages.
MIP_REQUIRED = 1

#: The min filter ``--mipmaps`` gives every page (the mag filter stays linear).
MIPMAP_FILTER = ["MipMapLinearLinear", "Linear"]


@dataclass
class Row:
    """The proof of one skeleton against one packed atlas."""

    project: str
    skeleton: str
    version: str = ""
    atlas: str = ""
    packed: bool = False            # its pages were written anew: packed, or cleared outside its rectangles
                                    # (else it was kept, and both sides hold the same texels)
    renders: int = 0
    worst: int = 0
    off: int = 0
    off_share: float = 0.0
    status: str = ""                # pass | FAIL | not rendered
    cause: str = ""
    details: list = field(default_factory=list)
    #: pages with MipMap filters only: the deepest level at which no region reads another's texels,
    #: before and after packing (the worst region's), and regions that packing made bleed sooner
    #: (at a level deeper than MIP_REQUIRED: reported, not a failure)
    mip_before: int | None = None
    mip_after: int | None = None
    mip_worse: list = field(default_factory=list)
    #: per mipmap level 1..MIP_LEVELS: ``[level, largest difference /255, regions over TOLERANCE,
    #: regions compared]`` of the level's texels under the regions, packed against the original
    #: with blocks falling alike (:func:`mip_texel_differences`)
    mip_texels: list = field(default_factory=list)


def pose_frame(tool: Path, atlas: Path, skeleton: Path, doc: dict, prefix: Path, skin: str | None,
               poses: str | None) -> Path | None:
    """A frame file around what the setup pose and the sampled ``poses`` draw (plus 25%), for a
    skeleton whose file has no bounds, or empty ones (the harness frames by them); None when the
    file has them or nothing is drawn."""
    bounds = doc.get("skeleton") or {}
    if all(isinstance(bounds.get(k), (int, float)) for k in ("x", "y", "width", "height")) \
            and bounds["width"] > 0 and bounds["height"] > 0:
        return None
    out = prefix.with_suffix(".dump.json")
    dump(tool, atlas, skeleton, None, "", out, poses=poses, skin=skin)
    points = [v for pose in json.loads(out.read_text())["poses"] for a in pose["attachments"] for v in a["vertices"]]
    if not points:
        return None
    xs, ys = points[0::2], points[1::2]
    w, h = max(xs) - min(xs), max(ys) - min(ys)
    frame = {"x": min(xs) - w / 8, "y": min(ys) - h / 8, "width": w * 1.25, "height": h * 1.25}
    path = prefix.with_suffix(".frame.json")
    path.write_text(json.dumps({"frame": frame}))
    return path


def prove_skeleton(tool: Path, project: Path, out: Path, skeleton: Path, work: Path, row: Row,
                   packed_atlases: set[str], animations: int = ANIMATIONS, pma: bool = False) -> Row:
    """Render ``skeleton`` with its original atlas and with the packed one in ``out``; fill in ``row``.

    ``pma``: with the premultiplied twin of its atlas (``NAME-pma.atlas`` beside ``NAME.atlas``)
    where there is one, as the examples ship both.
    """
    doc, atlas = renderable(skeleton, project, row)
    if atlas is None:
        return row
    twin = atlas.with_name(f"{atlas.stem}-pma{atlas.suffix}")
    if pma and twin.is_file():
        atlas = twin
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
        frame = pose_frame(tool, a_atlas, skel, doc, work / f"f{k}", skin, these)
        a = render(tool, a_atlas, skel, None, "", work / f"a{k}", frame_from=frame, poses=these, skin=skin)
        if frame is None:
            shown = json.loads((work / f"a{k}.frame.json").read_text())["frame"]
            if any(v is None for v in shown.values()):
                row.status, row.cause = "not rendered", "no pose draws anything and the file has no bounds"
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


def with_mipmaps(project: Path, dest: Path) -> Path:
    """A copy of ``project`` in ``dest`` whose every atlas page samples through mipmaps
    (:data:`MIPMAP_FILTER`); page images and skeletons are hard links where the file system allows.

    The atlases are rewritten in the copy only: each is unlinked first, so no input file changes.
    """
    import os

    from spinemesh.atlas import Entry, read_atlas
    from spinemesh.project import project_atlases

    def link(src, dst):
        try:
            os.link(src, dst)
        except OSError:
            shutil.copy2(src, dst)

    shutil.copytree(project, dest, copy_function=link, symlinks=False)
    for path in project_atlases(find_project(dest)):
        atlas = read_atlas(path)
        for page in atlas.pages:
            entry = next((e for e in page.entries if e.key == "filter"), None)
            if entry is None:
                like = page.entries[0] if page.entries else Entry("", [])
                page.entries.append(Entry("filter", list(MIPMAP_FILTER), like.indent, like.sep, like.colon))
            else:
                entry.values = list(MIPMAP_FILTER)
        text = atlas.dumps()
        path.unlink()
        path.write_text(text, encoding="utf-8")
    return dest


def core_on_page(g, fp) -> tuple[int, int, np.ndarray]:
    """Where a region's footprint core lies on its page: ``(row, column, mask as stored)``.

    The inverse of :func:`spinemesh.pack.outlines.window_texels`: the upright core turned as
    the region is stored; row and column of its top-left may be negative (the ring past the edge).
    """
    from spinemesh.pack.outlines import content_box, stored_index

    x0, y0, x1, y1 = content_box(g)
    k = g.degrees // 90
    wx0, wy0, wx1, wy1 = fp.window
    corners = [stored_index(i - x0, j - y0, x1 - x0, y1 - y0, k) for i in (wx0, wx1 - 1) for j in (wy0, wy1 - 1)]
    return g.y + min(r for r, _ in corners), g.x + min(c for _, c in corners), np.rot90(fp.core, k)


def blocks_read(drawn: np.ndarray, s: int) -> np.ndarray:
    """Blocks of ``s x s`` texels whose mipmap texel bilinear sampling reads while ``drawn`` is drawn, bool.

    A sample in texel ``i`` (block ``i // s``) reads the two level texels whose centres lie less
    than ``s`` from it: its own block and the one before when ``i`` lies in the first half of
    its block, the one after otherwise; that is blocks ``k - 1`` and ``k`` of the texel
    shifted by ``s / 2``, on both axes. Shape: the blocks of ``drawn`` (partial ones count).
    """
    h, w = drawn.shape
    nh, nw = -(-h // s), -(-w // s)
    shifted = np.zeros(((nh + 1) * s, (nw + 1) * s), bool)
    shifted[s // 2:s // 2 + h, s // 2:s // 2 + w] = drawn
    hit = shifted.reshape(nh + 1, s, nw + 1, s).any(axis=(1, 3))
    return hit[:nh, :nw] | hit[1:, :nw] | hit[:nh, 1:] | hit[1:, 1:]


def mip_clean_level(alpha: np.ndarray, own: np.ndarray, core: np.ndarray, levels: int = MIP_LEVELS,
                    tol: int = TOLERANCE) -> int:
    """The deepest mipmap level (0 to ``levels``) at which a region reads nothing of other regions.

    Parameters
    ----------
    alpha : ndarray, shape (H, W), uint8
        The page's alpha (a window of it whose corner is a corner of ``2**levels`` blocks).
    own : ndarray, shape (H, W), bool
        Texels that are the region's own (never foreign).
    core : ndarray, shape (H, W), bool
        Its footprint core: the texels it samples at level 0 (what it draws, grown by the one
        texel bilinear sampling reads; shrunk back by that texel here).
    levels : int
        Deepest level checked.
    tol : int
        Largest foreign alpha (/255) a read level texel may average.

    A level-``L`` texel averages a ``2**L`` block of the page (aligned to its corner, as
    mipmaps are built); the region is clean at ``L`` when no block it reads there
    (:func:`blocks_read`) averages more than ``tol``/255 of alpha from texels not its own.
    """
    import cv2

    drawn = cv2.erode(core.astype(np.uint8), np.ones((3, 3), np.uint8), borderValue=0).astype(bool)
    foreign = np.where(own, 0, alpha).astype(np.float64)
    clean = 0
    for level in range(1, levels + 1):
        s = 1 << level
        h, w = -(-alpha.shape[0] // s) * s, -(-alpha.shape[1] // s) * s
        f = np.zeros((h, w))
        f[:alpha.shape[0], :alpha.shape[1]] = foreign
        mean = f.reshape(h // s, s, w // s, s).mean(axis=(1, 3))
        if mean[blocks_read(drawn, s)].max(initial=0) > tol:
            break
        clean = level
    return clean


def mip_levels(atlas, region_uses: dict, pinned: str, own_rectangles: bool) -> dict:
    """Per region ``(name, index)``: its clean mipmap level (:func:`mip_clean_level`) on ``atlas``'s pages.

    ``own_rectangles``: a region's whole stored rectangle is its own (true of exported atlases,
    whose rectangles never overlap; packed rectangles may overlap where outlines do not).
    """
    import cv2

    from spinemesh.images.decode import load_rgba
    from spinemesh.pack.atlas_pack import uses_mipmaps
    from spinemesh.pack.outlines import footprint
    from spinemesh.pack.uses import RegionUses

    margin = 2 << MIP_LEVELS
    out = {}
    pages = [load_rgba(atlas.path.parent / p.name)[..., 3] for p in atlas.pages]
    for region in atlas.regions:
        g = region.geometry(str(atlas.path))
        uses = RegionUses(pinned=pinned) if pinned else region_uses.get(region.name)
        r0, c0, core = core_on_page(g, footprint(g, uses))
        alpha = pages[region.page]
        H, W = alpha.shape
        # a window of whole top-level blocks around the core, clipped to the page
        step = 1 << MIP_LEVELS
        wr0, wc0 = max(0, (r0 - margin) // step * step), max(0, (c0 - margin) // step * step)
        wr1, wc1 = min(H, r0 + core.shape[0] + margin), min(W, c0 + core.shape[1] + margin)
        sampled = np.zeros((wr1 - wr0, wc1 - wc0), bool)
        rr0, cc0 = max(r0, wr0), max(c0, wc0)
        rr1, cc1 = min(r0 + core.shape[0], wr1), min(c0 + core.shape[1], wc1)
        sampled[rr0 - wr0:rr1 - wr0, cc0 - wc0:cc1 - wc0] = core[rr0 - r0:rr1 - r0, cc0 - c0:cc1 - c0]
        own = sampled.copy()
        if not own_rectangles and uses_mipmaps(atlas.pages[region.page]):
            # packing copies, on a MipMap page, the region's own art within a texel of its core
            # (spinemesh.pack.outlines.grown_for_mipmaps); the padding keeps others further away
            own = cv2.dilate(own.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)
        if own_rectangles:
            h, w = (g.width, g.height) if g.degrees in (90, 270) else (g.height, g.width)
            own[max(0, g.y - wr0):max(0, g.y + h - wr0), max(0, g.x - wc0):max(0, g.x + w - wc0)] = True
        key = (region.name, region.get("index")[0] if region.get("index") else "-1")
        out[key] = mip_clean_level(alpha[wr0:wr1, wc0:wc1], own, sampled)
    return out


def _page_window(rgba: np.ndarray, r0: int, r1: int, c0: int, c1: int, own=None) -> np.ndarray:
    """Rows ``r0:r1`` and columns ``c0:c1`` of a page, as float; past its edges, its edge texels
    (a sample there reads them: clamp to edge, the pages' wrap, which packing copies into the
    ring it gives a region that lay on the edge). ``own``: ``((row0, col0, row1, col1), core,
    (row, col))``, a region's stored rectangle and its footprint core at ``(row, col)``: the
    texels kept (every other one of the page reads as zero)."""
    h, w = rgba.shape[:2]
    rows, cols = np.arange(r0, r1), np.arange(c0, c1)
    out = rgba[np.clip(rows, 0, h - 1)[:, None], np.clip(cols, 0, w - 1)[None, :]].astype(np.float64)
    if own is not None:
        (y0, x0, y1, x1), core, (cr, cc) = own
        keep = ((rows >= y0) & (rows < y1))[:, None] & ((cols >= x0) & (cols < x1))[None, :]
        a0, a1 = max(cr, r0), min(cr + core.shape[0], r1)
        b0, b1 = max(cc, c0), min(cc + core.shape[1], c1)
        if a0 < a1 and b0 < b1:
            keep[a0 - r0:a1 - r0, b0 - c0:b1 - c0] |= core[a0 - cr:a1 - cr, b0 - cc:b1 - cc]
        out[~keep] = 0
    return out


def _bilinear(level: np.ndarray, y: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``level`` (H, W, C) sampled bilinearly at level texel coordinates (centres at integers)."""
    h, w = level.shape[:2]
    y0, x0 = np.floor(y).astype(int), np.floor(x).astype(int)
    fy, fx = (y - y0)[:, None], (x - x0)[:, None]
    def at(r, c):
        return level[np.clip(r, 0, h - 1), np.clip(c, 0, w - 1)]
    return (at(y0, x0) * (1 - fy) * (1 - fx) + at(y0, x0 + 1) * (1 - fy) * fx
            + at(y0 + 1, x0) * fy * (1 - fx) + at(y0 + 1, x0 + 1) * fy * fx)


def mip_texel_difference(original: np.ndarray, packed: np.ndarray, at_original: tuple[int, int],
                         at_packed: tuple[int, int], drawn: np.ndarray, level: int, pma: bool,
                         own: tuple[int, int, int, int] | None = None, core: np.ndarray | None = None) -> float:
    """How far (/255, premultiplied) the packed page's mipmap level ``level`` reads from the
    original's under a region, with its blocks falling as they fall on the packed page.

    A level-``L`` texel averages a block of ``2**L`` page texels (blocks aligned to the page's
    corner, as GPUs build mipmaps); the region's drawn texels (``drawn``, as stored, its top-left
    at ``at_original`` and ``at_packed``, row and column) sample it bilinearly at their centres.
    Packing moves a region by any number of texels, so its blocks fall otherwise than on the
    original page (any repacking does: a level texel then averages other texels of the art); the
    original is therefore downscaled as if its blocks fell as the packed page's do, and what is
    left is what the packed page holds otherwise within a level texel's reach: what lies beyond
    the footprint (zero when packed; on the original another region's texels, or art the meshes
    do not draw). ``pma``: the pages hold premultiplied colour (else straight, premultiplied
    after sampling, as blending does). ``own``: the region's stored rectangle on the original
    page, ``(row0, col0, row1, col1)``, and ``core`` its footprint core there (at
    ``at_original``, what packing copies); texels outside both are other regions' (or the
    exporter's padding), which the original's levels read where its padding is too narrow and a
    packed page is not to copy: they count as zero. Both pages RGBA uint8."""
    s = 1 << level
    margin = 2 * s
    h, w = drawn.shape
    (ro, co), (rp, cp) = at_original, at_packed
    a, b = (rp - margin) // s, -(-(rp + h + margin) // s)
    c, d = (cp - margin) // s, -(-(cp + w + margin) // s)
    dr, dc = rp - ro, cp - co
    levels = []
    kept_original = None if own is None else (own, core if core is not None else np.zeros((0, 0), bool), at_original)
    for page, r, cc, kept in ((packed, a * s, c * s, None), (original, a * s - dr, c * s - dc, kept_original)):
        window = _page_window(page, r, r + (b - a) * s, cc, cc + (d - c) * s, kept)
        levels.append(window.reshape(b - a, s, d - c, s, 4).mean(axis=(1, 3)))
    rows, cols = np.nonzero(drawn)
    y = (rows + rp - a * s + 0.5) / s - 0.5
    x = (cols + cp - c * s + 0.5) / s - 0.5
    samples = [_bilinear(lv, y, x) for lv in levels]
    if not pma:
        samples = [np.concatenate([v[:, :3] * v[:, 3:] / 255, v[:, 3:]], axis=1) for v in samples]
    return float(np.abs(samples[0] - samples[1]).max(initial=0))


def mip_texel_differences(original_atlas, packed_atlas, region_uses: dict, pinned: str,
                          levels: int = MIP_LEVELS) -> dict:
    """Per level ``1..levels``: ``(largest difference /255, regions over TOLERANCE, regions
    compared)`` of :func:`mip_texel_difference` over the regions of two atlases of one project,
    each region's original neighbourhood turned as packing stored it (:func:`_turned_like`)."""
    import cv2

    from spinemesh.images.decode import load_rgba
    from spinemesh.pack.outlines import footprint
    from spinemesh.pack.uses import RegionUses

    def pages(atlas):
        return [load_rgba(atlas.path.parent / p.name) for p in atlas.pages]

    def placed(atlas):
        out = {}
        for region in atlas.regions:
            g = region.geometry(str(atlas.path))
            uses = RegionUses(pinned=pinned) if pinned else region_uses.get(region.name)
            r0, c0, core = core_on_page(g, footprint(g, uses))
            key = (region.name, region.get("index")[0] if region.get("index") else "-1")
            pma = (atlas.pages[region.page].get("pma") or ["false"])[0].lower() == "true"
            h, w = (g.width, g.height) if g.degrees in (90, 270) else (g.height, g.width)
            out[key] = (region.page, r0, c0, core, g.degrees, pma, (g.y, g.x, g.y + h, g.x + w))
        return out

    before, after = placed(original_atlas), placed(packed_atlas)
    orig_pages, packed_pages = pages(original_atlas), pages(packed_atlas)
    # each region's original neighbourhood turned as it is stored on the packed page
    turned = {key: _turned_like(orig_pages[before[key][0]], before[key], core, packed_pages[page], (r0, c0))
              for key, (page, r0, c0, core, *_) in after.items() if key in before}
    result = {}
    for level in range(1, levels + 1):
        worst, over, compared = 0.0, 0, 0
        for key, (page, r0, c0, core, degrees, pma, _) in after.items():
            if turned.get(key) is None:
                continue
            drawn = cv2.erode(core.astype(np.uint8), np.ones((3, 3), np.uint8), borderValue=0).astype(bool)
            window, at = turned[key]
            e = mip_texel_difference(window, packed_pages[page], at, (r0, c0), drawn, level, pma)
            worst, over, compared = max(worst, e), over + (e > TOLERANCE), compared + 1
        result[level] = (worst, over, compared)
    return result


def _turned_like(page: np.ndarray, placed: tuple, core: np.ndarray, packed: np.ndarray, at_packed: tuple[int, int]):
    """A region's neighbourhood on its original page (its own texels only: its stored rectangle
    and footprint core, the rest zero; the page's edge repeated past it) turned as the region is
    stored on the packed page, and where its core lies in it: ``(window, (row, column))``. The
    turn is the one that brings the original's texels under the core onto the packed page's
    (packing copies them unchanged); None when no turn does (not compared)."""
    _, r0, c0, core0, _, _, own = placed
    m = 2 << MIP_LEVELS
    h, w = core0.shape
    window = _page_window(page, r0 - m, r0 + h + m, c0 - m, c0 + w + m, (own, core0, (r0, c0)))
    mine = packed[at_packed[0]:at_packed[0] + core.shape[0], at_packed[1]:at_packed[1] + core.shape[1]]
    for k in range(4):
        turned = np.rot90(window, k)
        turned_core = np.rot90(core0, k)
        if turned_core.shape != core.shape or not np.array_equal(turned_core, core):
            continue
        there = turned[m:m + core.shape[0], m:m + core.shape[1]]
        if mine.shape == there.shape and np.array_equal(mine[core], there[core]):
            return turned, (m, m)
    return None


def prove_mipmaps(source: Path, out: Path, atlas_rel: str, uses) -> tuple[int, int, list[str], list]:
    """Mipmap bleeding before and after packing one atlas whose pages use MipMap filters.

    Returns the worst region's clean level before and after, the regions whose clean level
    packing lowered below what they had (at most :data:`MIP_LEVELS`), and per level the texels
    read under the regions against the original's (:func:`mip_texel_differences`, as
    :attr:`Row.mip_texels` lists them).
    """
    from spinemesh.atlas import read_atlas

    original = read_atlas(source / atlas_rel)
    packed = read_atlas(out / atlas_rel)
    table_uses = next((v for k, v in uses.regions.items() if k.resolve() == (source / atlas_rel).resolve()), {})
    before = mip_levels(original, table_uses, uses.everything_pinned, True)
    after = mip_levels(packed, table_uses, uses.everything_pinned, False)
    worse = [f"{name}: level {before[(name, i)]} -> {level}" for (name, i), level in after.items()
             if (name, i) in before and level < before[(name, i)]]
    texels = mip_texel_differences(original, packed, table_uses, uses.everything_pinned)
    return (min(before.values(), default=MIP_LEVELS), min(after.values(), default=MIP_LEVELS), worse,
            [[level, round(worst, 2), over, compared] for level, (worst, over, compared) in texels.items()])


def mipmap_results(source: Path, out: Path, packed: set[str]) -> dict:
    """:func:`prove_mipmaps` of every packed atlas of ``source`` (written to ``out``) whose pages use MipMap filters."""
    from spinemesh.atlas import read_atlas
    from spinemesh.pack.atlas_pack import uses_mipmaps
    from spinemesh.pack.uses import collect_uses

    mip = [rel for rel in sorted(packed) if any(uses_mipmaps(p) for p in read_atlas(source / rel).pages)]
    if not mip:
        return {}
    uses = collect_uses(find_project(source))
    return {rel: prove_mipmaps(source, out, rel, uses) for rel in mip}


def pack_as_the_cli_does(source: Path, out: Path, upgraded: bool) -> list:
    """Pack ``source`` into ``out`` as ``spinemesh pack`` does, or, for an upgrade (``upgraded``),
    as ``upgrade --pack`` does: in place, on a copy of the upgrade. Returns the atlas rows."""
    if upgraded:
        from spinemesh.upgrade.pack import pack_written
        from spinemesh.upgrade.report import Result

        shutil.copytree(source, out)
        done = Result()
        pack_written(out, done)
        return done.atlases
    out.mkdir(parents=True, exist_ok=True)
    result = PackResult()
    pack_project_into(find_project(source), out, PackOptions(), result)
    return result.atlases


def prove_project(tool: Path, project: Path, work: Path, animations: int = ANIMATIONS,
                  upgrade: bool = False, mipmaps: bool = False, skeletons: str = "*", pma: bool = False) -> list[Row]:
    """Pack ``project`` (optionally its upgrade; with ``mipmaps``, a copy whose pages use
    mipmaps) into ``work`` and prove each skeleton whose path in it matches the glob ``skeletons``."""
    name = project_label(project)
    source = with_mipmaps(project, work / "mipmapped") if mipmaps else project
    if upgrade:
        from spinemesh.upgrade import Options, upgrade_project

        upgraded = work / "upgraded"
        try:
            upgrade_project(source, upgraded, Options())
        except SpineMeshError as e:
            return [Row(name, "-", status="FAIL", cause=f"upgrade refused the project: {e}")]
        source = upgraded
    out = work / "out"
    try:
        atlases = pack_as_the_cli_does(source, out, upgrade)
    except SpineMeshError as e:
        return [Row(name, "-", status="FAIL", cause=f"pack refused the project: {e}")]
    # pages written with other texels: packed anew, or cleared outside the regions' rectangles
    packed = {a.atlas for a in atlases if a.status in ("packed", "cleared")}
    mips = mipmap_results(source, out, packed)
    rows = []
    for skeleton in find_project(source).skeletons:
        rel = skeleton.relative_to(source).as_posix()
        if not fnmatch.fnmatchcase(rel, skeletons):
            continue
        row = Row(name, rel)
        scratch = work / "render" / rel.replace("/", "~")
        scratch.mkdir(parents=True, exist_ok=True)
        try:
            prove_skeleton(tool, source, out, skeleton, scratch, row, packed, animations, pma)
        except (AssertionError, SpineMeshError) as e:  # the harness failed to load or render
            row.status, row.cause = "FAIL", f"harness: {str(e).strip().splitlines()[-1][:300]}"
        except subprocess.TimeoutExpired as e:  # a slow render (a busy machine): prove it again alone
            row.status, row.cause = "FAIL", f"harness timed out after {e.timeout:g} s"
        if row.atlas in mips:
            row.mip_before, row.mip_after, row.mip_worse, row.mip_texels = mips[row.atlas]
            if row.mip_after < MIP_REQUIRED:
                row.status = "FAIL"
                row.details.append(f"a region reads another's texels at mipmap level {row.mip_after + 1}")
            for level, worst, over, _ in row.mip_texels:
                if level <= MIP_REQUIRED and over:
                    row.status = "FAIL"
                    row.details.append(f"{over} regions read mipmap level {level} {worst:g}/255 off the original's")
        rows.append(row)
    return rows


def project_label(project: Path) -> str:
    """``examples/4.2/spineboy`` or ``corpus/jt-mia`` for the development data, else the folder's name
    (example projects of different versions share names)."""
    for root, label in ((EXAMPLES, "examples"), (CORPUS, "corpus")):
        if project.is_relative_to(root.resolve()):
            return f"{label}/{project.relative_to(root.resolve()).as_posix()}"
    return project.name


def table(rows: list[Row]) -> str:
    mip = any(r.mip_after is not None for r in rows)
    head = ("| project | skeleton | version | atlas | packed | renders | worst /255 | px > 2/255 |"
            + (" mipmap levels clean before -> after |" if mip else "") + " status | cause |\n"
            "|---|---|---|---|---|---:|---:|---:|" + ("---:|" if mip else "") + "---|---|")

    def levels(r: Row) -> str:
        if r.mip_after is None:
            return " - |"
        return f" {r.mip_before} -> {r.mip_after}" + (f" ({len(r.mip_worse)} lower)" if r.mip_worse else "") + " |"

    return "\n".join([head] + [f"| {r.project} | {r.skeleton} | {r.version} | {r.atlas} | {'yes' if r.packed else 'no'} | "
                               f"{r.renders} | {r.worst} | {r.off} |" + (levels(r) if mip else "")
                               + f" {r.status} | {r.cause} |" for r in rows])


def summary(rows: list[Row]) -> str:
    rendered = [r for r in rows if r.status != "not rendered" and r.packed]
    passed = [r for r in rendered if r.status == "pass"]
    projects = {r.project for r in rendered}
    text = (f"{len(passed)}/{len(rendered)} skeletons on packed atlases pass ({len(projects)} projects), "
            f"{sum(r.renders for r in rendered)} renders "
            f"({sum(1 for r in rows if r.status == 'not rendered')} not renderable, "
            f"{sum(1 for r in rows if not r.packed and r.status == 'pass')} on atlases kept as they were)")
    mip = {(r.project, r.atlas): r for r in rows if r.mip_after is not None}
    if mip:
        text += (f"; mipmaps: {len(mip)} packed atlases, every region clean to level >= "
                 f"{min(r.mip_after for r in mip.values())} after packing (worst before: "
                 f"{min(r.mip_before for r in mip.values())}), {sum(len(r.mip_worse) for r in mip.values())} "
                 "regions clean to a lower level than before")
    return text


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
    ap.add_argument("--pma", action="store_true",
                    help="render each skeleton with the premultiplied twin of its atlas (NAME-pma.atlas) where there is one")
    ap.add_argument("--mipmaps", action="store_true",
                    help="give every page a MipMap filter first (in a copy), and check mipmap bleeding too")
    ap.add_argument("--json", type=Path, help="write the rows here as JSON")
    ap.add_argument("--animations", type=int, default=ANIMATIONS, help="animations sampled per skeleton")
    ap.add_argument("--every", type=int, default=1, metavar="N",
                    help="prove every N-th project (in the order given; default: all)")
    ap.add_argument("--resume", action="store_true", help="keep the rows already in --json, prove the rest")
    ap.add_argument("--keep", type=Path, help="keep packs and renders here (default: a temporary folder)")
    ap.add_argument("--tables-from", type=Path, nargs="+", metavar="JSON",
                    help="print the table and summary of rows saved by --json (runs merged, one row per skeleton)")
    args = ap.parse_args(argv)
    if args.tables_from:
        merged = {(r["project"], r["skeleton"]): Row(**r) for f in args.tables_from for r in json.loads(f.read_text())}
        rows = list(merged.values())
        print(table(rows))
        print()
        print(summary(rows))
        return 0 if all(r.status != "FAIL" for r in rows) else 1
    projects = [p.resolve() for p in args.projects] or default_projects()
    if args.only:
        projects = [p for p in projects if any(fnmatch.fnmatchcase(p.name, g) for g in args.only)]
    projects = projects[::max(1, args.every)]
    rows = []
    if args.resume and args.json and args.json.is_file():
        rows = [Row(**r) for r in json.loads(args.json.read_text())]
        done = {r.project for r in rows}
        projects = [p for p in projects if project_label(p) not in done]
    base = Path(tempfile.mkdtemp(prefix="prove-pack-")) if args.keep is None else args.keep
    tool = install(base / "tool")
    rows = prove_each(projects, base, lambda project, work: prove_project(tool, project, work, args.animations,
                                                                          args.upgrade, args.mipmaps, pma=args.pma),
                      args.json, args.keep is None, rows)
    print(table(rows))
    print()
    print(summary(rows))
    if args.keep is None:
        shutil.rmtree(base, ignore_errors=True)
    return 0 if all(r.status != "FAIL" for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
