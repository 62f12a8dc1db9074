"""The paper's three baselines (sec. 5, "Comparison with Baselines"), as :class:`Mesh` objects.

The paper compares interior vertex placements, so every baseline shares the rest of the
paper's pipeline with the ``paper`` preset: the mask ``alpha > 128`` (sec. 3.1), the exterior
contour with Douglas-Peucker 0.003 P and 50 target vertices (sec. 3.2), the 2 px merge and the
Delaunay triangulation whose triangles are kept when their centroid lies on the mask (sec. 3.4).
Only the interior points differ:

``hull``
    "Alpha-only hull": the exterior contour vertices and nothing else.
``grid``
    "Uniform grid": a square grid whose spacing is proportional to the mask size, kept where
    it falls on the mask. The paper gives no spacing; we choose ``sqrt(mask area) / 20``, so a
    compact sprite gets about 20^2 = 400 grid points, in line with the paper's 520 vertices
    (64 exterior + ~456 interior) for this baseline.
``shi-tomasi``
    "Shi-Tomasi corners": ``cv2.goodFeaturesToTrack`` on the gray image. The paper gives no
    parameters; we use OpenCV's customary quality level 0.01 and block size 3, the paper's own
    interior merge radius (18 px, sec. 3.3 step 5) as the minimum corner distance and at most
    600 corners (its table reports 667 vertices, i.e. ~600 interior).

Both grid and corner points obey the paper's interior rule of sec. 3.3 step 4: at least 6 px
from the mask border (a point on the border would only make slivers).
"""

from __future__ import annotations

import cv2
import numpy as np

from ..errors import ImageError
from ..foreground import foreground
from ..mesher import Mesh, exterior, triangulate
from ..mesher.params import PAPER

# The pipeline's own merge and finishing steps, so that a baseline differs from the paper
# preset only in where its interior points come from.
from ..mesher.pipeline import finish_mesh, merge_close_points

#: Baseline names, in the order of the paper's comparison table.
BASELINES = ("hull", "grid", "shi-tomasi")

#: Grid spacing = sqrt(mask area) / GRID_CELLS (our choice; the paper gives none).
GRID_CELLS = 20.0
#: Shi-Tomasi parameters (our choice; the paper gives none, see the module docstring).
SHI_TOMASI_MAX_CORNERS = 600
SHI_TOMASI_QUALITY = 0.01
SHI_TOMASI_BLOCK_SIZE = 3


def paper_mask(image: np.ndarray) -> np.ndarray:
    """The paper's foreground mask, ``alpha > 128`` (sec. 3.1), shape (H, W) bool."""
    mask = foreground(image, PAPER.alpha_threshold)
    if not mask.any():
        raise ImageError("the image has no pixel with alpha > 128: nothing to mesh")
    return mask


def exterior_points(mask: np.ndarray) -> np.ndarray:
    """Exterior contour vertices of all components (paper sec. 3.2), shape (n, 2) px."""
    loops = exterior.paper_loops(mask, PAPER.mask_blur_sigma, PAPER.min_component_area,
                                 PAPER.dp_epsilon_ratio, PAPER.n_target)
    if not loops:
        raise ImageError("no foreground component to mesh")
    return np.concatenate(loops)


def interior_allowed(mask: np.ndarray, border: float = PAPER.border_distance) -> np.ndarray:
    """Pixels at least ``border`` px (6, paper sec. 3.3 step 4) from the mask border."""
    dist = cv2.distanceTransform(np.pad(mask, 1).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    return dist[1:-1, 1:-1] >= border


def grid_points(mask: np.ndarray, cells: float = GRID_CELLS) -> np.ndarray:
    """Grid baseline's interior points: spacing ``sqrt(mask area) / cells`` px.

    The grid starts half a spacing inside the mask's bounding box, so it is centred on the
    sprite rather than on the image corner. Points are pixel centres ``(x + 0.5, y + 0.5)``.

    Returns
    -------
    ndarray, shape (K, 2), float64
    """
    spacing = max(1.0, float(np.sqrt(mask.sum())) / cells)
    rows, cols = np.nonzero(mask)
    xs = np.arange(cols.min() + spacing / 2, cols.max() + 1, spacing)
    ys = np.arange(rows.min() + spacing / 2, rows.max() + 1, spacing)
    gx, gy = np.meshgrid(xs, ys)
    pts = np.stack([gx.ravel(), gy.ravel()], axis=1)
    allowed = interior_allowed(mask)
    c = np.floor(pts[:, 0]).astype(int)
    r = np.floor(pts[:, 1]).astype(int)
    keep = allowed[r, c]
    return np.floor(pts[keep]) + 0.5


def shi_tomasi_points(image: np.ndarray, mask: np.ndarray, max_corners: int = SHI_TOMASI_MAX_CORNERS,
                      quality: float = SHI_TOMASI_QUALITY, min_distance: float = PAPER.dedup_radius,
                      block_size: int = SHI_TOMASI_BLOCK_SIZE) -> np.ndarray:
    """Shi-Tomasi baseline's interior points: strongest corners of the gray image.

    Transparent pixels are composited over black first, so that whatever colour hides under
    alpha 0 makes no corner; corners are searched only where :func:`interior_allowed`.

    Returns
    -------
    ndarray, shape (K, 2), float64, pixel coordinates
    """
    rgb = np.asarray(image)[:, :, :3].astype(np.float32)
    if image.shape[2] == 4:
        rgb *= image[:, :, 3:4].astype(np.float32) / 255.0
    gray = cv2.cvtColor(rgb.astype(np.uint8), cv2.COLOR_RGB2GRAY)
    allowed = interior_allowed(mask).astype(np.uint8)
    if not allowed.any():
        return np.zeros((0, 2))
    corners = cv2.goodFeaturesToTrack(gray, maxCorners=int(max_corners), qualityLevel=float(quality),
                                      minDistance=float(min_distance), mask=allowed, blockSize=int(block_size))
    if corners is None:
        return np.zeros((0, 2))
    # OpenCV reports integer pixel indices; their centres are +0.5 in mesh coordinates
    return corners.reshape(-1, 2).astype(np.float64) + 0.5


def mesh_with_interior(mask: np.ndarray, inner: np.ndarray, name: str) -> Mesh:
    """Paper exterior + the given interior points, merged (2 px) and Delaunay-triangulated.

    Parameters
    ----------
    mask : ndarray, shape (H, W), bool
        Foreground (the paper's ``alpha > 128``).
    inner : ndarray, shape (K, 2)
        Interior points in pixel coordinates.
    name : str
        Stored as ``mesh.info["preset"]``.
    """
    h, w = mask.shape
    ext = exterior_points(mask)
    inner = np.asarray(inner, dtype=np.float64).reshape(-1, 2)
    flags = np.r_[np.zeros(len(ext), bool), np.ones(len(inner), bool)]
    pts, is_int = merge_close_points(np.vstack([ext, inner]), flags, PAPER.triangulation_dedup)
    verts, tris = triangulate.delaunay_centroid_filter(pts, mask)
    if len(tris) == 0:
        raise ImageError("the baseline mesh has no triangle (the sprite is too thin)")
    mesh = finish_mesh(verts, tris, is_int, np.zeros((0, 2), np.int64), w, h, preset=name)
    return mesh


def baseline_mesh(image: np.ndarray, method: str, mask: np.ndarray | None = None) -> Mesh:
    """One of :data:`BASELINES` for an RGBA image.

    Parameters
    ----------
    image : ndarray, shape (H, W, 4), uint8
        Straight RGBA at the original size.
    method : {"hull", "grid", "shi-tomasi"}
    mask : ndarray, shape (H, W), bool, optional
        Foreground to use instead of the paper's ``alpha > 128``.

    Returns
    -------
    Mesh
        ``is_interior`` marks the grid or corner points (yellow in the report).
    """
    image = np.asarray(image)
    if image.ndim != 3 or image.shape[2] not in (3, 4) or image.dtype != np.uint8:
        raise ImageError(f"expected an (H, W, 3|4) uint8 image, got shape {image.shape} {image.dtype}")
    mask = paper_mask(image) if mask is None else np.asarray(mask, dtype=bool)
    if method == "hull":
        inner = np.zeros((0, 2))
    elif method == "grid":
        inner = grid_points(mask)
    elif method == "shi-tomasi":
        inner = shi_tomasi_points(image, mask)
    else:
        raise ValueError(f"unknown baseline {method!r}; choose from {', '.join(BASELINES)}")
    return mesh_with_interior(mask, inner, method)
