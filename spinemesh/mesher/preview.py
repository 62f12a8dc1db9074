"""Pictures of a mesh: the wireframe preview and the paper's six-panel pipeline figure.

Colours follow the paper's figures: exterior vertices blue, interior vertices yellow.
Constrained interior edges (the chains along colour boundaries) are drawn in orange so that
users can see which parts will deform independently; hole loops (transparent holes cut out of
the mesh) in magenta; the hull outline in blue. Every picture carries a legend.
"""

from __future__ import annotations

import cv2
import numpy as np

from .mesh import Mesh

BLUE = (40, 110, 255)
YELLOW = (255, 215, 0)
ORANGE = (255, 130, 30)
MAGENTA = (235, 50, 200)
WIRE = (255, 255, 255)
SHADOW = (20, 20, 20)
HALO = (255, 255, 255)
_SHIFT = 4  # sub-pixel drawing: coordinates in 1/16 px


def _checker(h: int, w: int, cell: int = 8) -> np.ndarray:
    y, x = np.mgrid[0:h, 0:w]
    light = ((y // cell + x // cell) % 2 == 0)
    out = np.where(light[:, :, None], 205, 160).astype(np.uint8)
    return np.repeat(out, 3, axis=2)


def _composite(image: np.ndarray, scale: float) -> np.ndarray:
    """Sprite over a checkerboard, resized by ``scale``, as RGB uint8."""
    h, w = image.shape[:2]
    size = (max(1, round(w * scale)), max(1, round(h * scale)))
    interp = cv2.INTER_NEAREST if scale >= 2 else cv2.INTER_AREA
    img = cv2.resize(image, size, interpolation=interp)
    bg = _checker(size[1], size[0])
    if img.ndim == 3 and img.shape[2] == 4:
        a = img[:, :, 3:4].astype(np.float32) / 255
        return (img[:, :, :3] * a + bg * (1 - a)).astype(np.uint8)
    return img[:, :, :3].copy()


def _fit_scale(h: int, w: int, target: int) -> float:
    """Scale so the longer side is about ``target`` px (small sprites are enlarged)."""
    return target / max(h, w)


def _pts(v: np.ndarray, scale: float) -> np.ndarray:
    return np.round(v * scale * (1 << _SHIFT)).astype(np.int32)


def edge_kinds(mesh: Mesh) -> dict[str, list[tuple[int, int]]]:
    """The constrained edges by kind: ``hull`` loop, ``hole`` loops and interior ``chain`` edges.

    Hull edges join consecutive vertices of the first ``mesh.hull``; hole-loop edges join two
    boundary (not interior) vertices off the hull loop; chain edges join interior vertices.
    """
    n = mesh.hull
    hull = {tuple(sorted((i, (i + 1) % n))) for i in range(n)} if n >= 3 else set()
    out: dict[str, list[tuple[int, int]]] = {"hull": [], "hole": [], "chain": []}
    for a, b in mesh.edges.tolist():
        if tuple(sorted((a, b))) in hull:
            out["hull"].append((a, b))
        elif not mesh.is_interior[a] and not mesh.is_interior[b]:
            out["hole"].append((a, b))
        else:
            out["chain"].append((a, b))
    return out


def _dot(canvas: np.ndarray, q, r: int, colour) -> None:
    """A vertex: coloured disc in a white ring and a dark rim, readable on dark and light."""
    cv2.circle(canvas, tuple(q), (r + 1) << _SHIFT, SHADOW, -1, cv2.LINE_AA, _SHIFT)
    cv2.circle(canvas, tuple(q), r << _SHIFT, HALO, -1, cv2.LINE_AA, _SHIFT)
    cv2.circle(canvas, tuple(q), max(r - 1, 1) << _SHIFT, colour, -1, cv2.LINE_AA, _SHIFT)


def draw_wireframe(canvas: np.ndarray, mesh: Mesh, scale: float, vertices: bool = True,
                   edges_only: bool = False) -> np.ndarray:
    """Draw triangles, hull, hole loops, constrained chains and vertices on an RGB canvas (in place)."""
    p = _pts(mesh.vertices, scale)
    lw = 1
    if not edges_only and len(mesh.triangles):
        tri = p[mesh.triangles].reshape(-1, 3, 1, 2)
        cv2.polylines(canvas, list(tri), True, SHADOW, lw + 2, cv2.LINE_AA, _SHIFT)
        cv2.polylines(canvas, list(tri), True, WIRE, lw, cv2.LINE_AA, _SHIFT)
    kinds = edge_kinds(mesh)
    for kind, colour in (("hull", BLUE), ("hole", MAGENTA), ("chain", ORANGE)):
        for a, b in kinds[kind]:
            cv2.line(canvas, tuple(p[a]), tuple(p[b]), SHADOW, lw + 3, cv2.LINE_AA, _SHIFT)
            cv2.line(canvas, tuple(p[a]), tuple(p[b]), colour, lw + 1, cv2.LINE_AA, _SHIFT)
    if vertices:
        r = max(2, int(round(min(6, 2 + scale))))
        for i, q in enumerate(p):
            _dot(canvas, q, r, YELLOW if mesh.is_interior[i] else BLUE)
    return canvas


#: Legend entries: (label, colour, "dot" or "line").
LEGEND = (("hull or hole vertex", BLUE, "dot"), ("interior vertex", YELLOW, "dot"), ("triangle edge", WIRE, "line"),
          ("hull outline", BLUE, "line"), ("hole loop", MAGENTA, "line"), ("constrained edge", ORANGE, "line"))


def legend(width: int, entries=LEGEND) -> np.ndarray:
    """A band (RGB uint8) explaining the colours, wrapped onto as many rows as ``width`` needs."""
    font, fs = cv2.FONT_HERSHEY_SIMPLEX, 0.42
    items = []
    for label, colour, kind in entries:
        (tw, _), _ = cv2.getTextSize(label, font, fs, 1)
        items.append((label, colour, kind, 28 + tw + 16))
    rows, row, used = [], [], 8
    for it in items:
        if row and used + it[3] > width:
            rows.append(row)
            row, used = [], 8
        row.append(it)
        used += it[3]
    rows.append(row)
    band = np.full((22 * len(rows) + 6, width, 3), 48, np.uint8)
    for k, row in enumerate(rows):
        x, y = 8, 16 + 22 * k
        for label, colour, kind, step in row:
            if kind == "dot":
                _dot(band, (np.array([x + 10, y - 4]) << _SHIFT).astype(np.int32), 5, colour)
            else:
                cv2.line(band, (x, y - 4), (x + 20, y - 4), SHADOW, 4, cv2.LINE_AA)
                cv2.line(band, (x, y - 4), (x + 20, y - 4), colour, 2, cv2.LINE_AA)
            cv2.putText(band, label, (x + 28, y), font, fs, (235, 235, 235), 1, cv2.LINE_AA)
            x += step
    return band


def preview(image: np.ndarray, mesh: Mesh, size: int = 768) -> np.ndarray:
    """The wireframe over the sprite.

    Parameters
    ----------
    image : ndarray, shape (H, W, 4|3), uint8
    mesh : Mesh
    size : int
        Longer side of the picture (px); small sprites are enlarged, large ones reduced.

    Returns
    -------
    ndarray, shape (h + legend, w, 3), uint8 RGB
        The picture with a legend band below it.
    """
    scale = _fit_scale(*image.shape[:2], size)
    canvas = draw_wireframe(_composite(image, scale), mesh, scale)
    return np.vstack([canvas, legend(canvas.shape[1])])


def steps_figure(image: np.ndarray, mask: np.ndarray, mesh: Mesh, panel: int = 384) -> np.ndarray:
    """The paper's six-panel pipeline figure (Fig. 1), for tuning parameters on one image.

    Panels: (1) input, (2) mask, (3) exterior vertices (blue), (4) interior vertices (yellow)
    with the exterior ones, (5) triangulation wireframe, (6) final mesh over the sprite; a
    legend below.

    Returns
    -------
    ndarray, shape (2 * (panel + 24) + legend, 3 * panel, 3), uint8 RGB
    """
    h, w = image.shape[:2]
    scale = _fit_scale(h, w, panel - 16)
    base = _composite(image, scale)
    m = cv2.resize(mask.astype(np.uint8) * 255, (base.shape[1], base.shape[0]), interpolation=cv2.INTER_NEAREST)
    mask_rgb = np.repeat(m[:, :, None], 3, axis=2)
    p = _pts(mesh.vertices, scale)
    r = max(3, int(round(min(5, 2 + scale))))

    def dots(canvas, which):
        for i in np.flatnonzero(which):
            _dot(canvas, p[i], r, YELLOW if mesh.is_interior[i] else BLUE)
        return canvas

    # the mask in light greys, so that the blue dots stand out
    ext = dots(np.where(mask_rgb > 0, 235, 175).astype(np.uint8), ~mesh.is_interior)
    allv = dots(base.copy(), np.ones(len(p), bool))
    wire = np.full_like(base, 32)
    draw_wireframe(wire, mesh, scale, vertices=False)
    final = draw_wireframe(base.copy(), mesh, scale)
    titles = ["1 input", "2 mask", f"3 exterior ({int((~mesh.is_interior).sum())})",
              f"4 interior ({int(mesh.is_interior.sum())})", f"5 triangles ({len(mesh.triangles)})", "6 final mesh"]
    tiles = []
    for img, title in zip([base, mask_rgb, ext, allv, wire, final], titles):
        tile = np.full((panel + 24, panel, 3), 255, np.uint8)
        y0 = 24 + (panel - img.shape[0]) // 2
        x0 = (panel - img.shape[1]) // 2
        tile[y0:y0 + img.shape[0], x0:x0 + img.shape[1]] = img
        cv2.putText(tile, title, (6, 17), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (0, 0, 0), 1, cv2.LINE_AA)
        tiles.append(tile)
    grid = np.vstack([np.hstack(tiles[:3]), np.hstack(tiles[3:])])
    return np.vstack([grid, legend(grid.shape[1])])
