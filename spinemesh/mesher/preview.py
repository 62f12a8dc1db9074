"""Pictures of a mesh: the wireframe preview and the paper's six-panel pipeline figure.

Colours follow the paper's figures: exterior vertices blue, interior vertices yellow.
Constrained interior edges (the chains along colour boundaries) are drawn in orange so that
users can see which parts will deform independently.
"""

from __future__ import annotations

import cv2
import numpy as np

from .mesh import Mesh

BLUE = (40, 110, 255)
YELLOW = (255, 215, 0)
ORANGE = (255, 130, 30)
WIRE = (255, 255, 255)
SHADOW = (20, 20, 20)
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


def draw_wireframe(canvas: np.ndarray, mesh: Mesh, scale: float, vertices: bool = True,
                   edges_only: bool = False) -> np.ndarray:
    """Draw triangles, constrained chains and vertices on an RGB canvas (in place)."""
    p = _pts(mesh.vertices, scale)
    lw = 1
    if not edges_only and len(mesh.triangles):
        tri = p[mesh.triangles].reshape(-1, 3, 1, 2)
        cv2.polylines(canvas, list(tri), True, SHADOW, lw + 2, cv2.LINE_AA, _SHIFT)
        cv2.polylines(canvas, list(tri), True, WIRE, lw, cv2.LINE_AA, _SHIFT)
    inner = [e for e in mesh.edges.tolist() if mesh.is_interior[e[0]] and mesh.is_interior[e[1]]]
    for a, b in inner:
        cv2.line(canvas, tuple(p[a]), tuple(p[b]), ORANGE, lw + 1, cv2.LINE_AA, _SHIFT)
    if vertices:
        r = max(2, int(round(min(6, 2 + scale))))
        for i, q in enumerate(p):
            colour = YELLOW if mesh.is_interior[i] else BLUE
            cv2.circle(canvas, tuple(q), r << _SHIFT, SHADOW, -1, cv2.LINE_AA, _SHIFT)
            cv2.circle(canvas, tuple(q), (r - 1) << _SHIFT, colour, -1, cv2.LINE_AA, _SHIFT)
    return canvas


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
    ndarray, shape (h, w, 3), uint8 RGB
    """
    scale = _fit_scale(*image.shape[:2], size)
    canvas = _composite(image, scale)
    return draw_wireframe(canvas, mesh, scale)


def steps_figure(image: np.ndarray, mask: np.ndarray, mesh: Mesh, panel: int = 384) -> np.ndarray:
    """The paper's six-panel pipeline figure (Fig. 1), for tuning parameters on one image.

    Panels: (1) input, (2) mask, (3) exterior vertices (blue), (4) interior vertices (yellow)
    with the exterior ones, (5) triangulation wireframe, (6) final mesh over the sprite.

    Returns
    -------
    ndarray, shape (2 * (panel + 24), 3 * panel, 3), uint8 RGB
    """
    h, w = image.shape[:2]
    scale = _fit_scale(h, w, panel - 16)
    base = _composite(image, scale)
    m = cv2.resize(mask.astype(np.uint8) * 255, (base.shape[1], base.shape[0]), interpolation=cv2.INTER_NEAREST)
    mask_rgb = np.repeat(m[:, :, None], 3, axis=2)
    p = _pts(mesh.vertices, scale)
    r = max(2, int(round(min(5, 2 + scale))))

    def dots(canvas, which):
        for i in np.flatnonzero(which):
            colour = YELLOW if mesh.is_interior[i] else BLUE
            cv2.circle(canvas, tuple(p[i]), r << _SHIFT, SHADOW, -1, cv2.LINE_AA, _SHIFT)
            cv2.circle(canvas, tuple(p[i]), (r - 1) << _SHIFT, colour, -1, cv2.LINE_AA, _SHIFT)
        return canvas

    ext = dots((mask_rgb // 2 + 40).astype(np.uint8), ~mesh.is_interior)
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
    return np.vstack([np.hstack(tiles[:3]), np.hstack(tiles[3:])])
