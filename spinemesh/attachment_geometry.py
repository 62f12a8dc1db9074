"""Where a region attachment's image lies in its bone's space, and the mesh that replaces it.

A region attachment draws its original image as a quad. The image point ``(u, v)``
(u right, v down, 0..1 over the original image) sits at::

    ((u - 0.5) * width * scaleX, (0.5 - v) * height * scaleY)

rotated by ``rotation`` degrees and moved by ``(x, y)``. A mesh attachment that replaces
the region puts each vertex at exactly that position, with the same ``(u, v)`` as its UV,
so it renders in the same place. The runtimes map mesh UVs through the atlas region's
offsets and rotation themselves, so UVs stay relative to the original image.
"""

from __future__ import annotations

import math

import numpy as np

from .skeleton import number

#: JSON key order of a mesh attachment in the editor's export.
MESH_KEY_ORDER = ("name", "type", "path", "color", "uvs", "triangles", "vertices", "hull",
                  "sequence", "edges", "width", "height")


def region_quad_transform(region: dict, source=None) -> np.ndarray:
    """The affine map from UV to attachment space for a region attachment.

    Parameters
    ----------
    region : dict
        The region attachment (``x``, ``y``, ``rotation``, ``scaleX``, ``scaleY``,
        ``width``, ``height``; defaults 0, 0, 0, 1, 1, 32, 32 as in the runtimes).

    Returns
    -------
    ndarray, shape (2, 3)
        ``A`` such that ``A @ [u, v, 1]`` is the position in the slot's bone space.
    """
    x = number(region, "x", 0, source)
    y = number(region, "y", 0, source)
    rot = math.radians(number(region, "rotation", 0, source))
    sx = number(region, "scaleX", 1, source) * number(region, "width", 32, source)
    sy = number(region, "scaleY", 1, source) * number(region, "height", 32, source)
    c, s = math.cos(rot), math.sin(rot)
    # local = (sx*(u - 0.5), sy*(0.5 - v)); world = R @ local + (x, y)
    scale_uv = np.array([[sx, 0.0, -0.5 * sx], [0.0, -sy, 0.5 * sy]])
    rotate = np.array([[c, -s], [s, c]])
    out = rotate @ scale_uv
    out[:, 2] += (x, y)
    return out


def region_positions(region: dict, vertices_px: np.ndarray, image_width: int, image_height: int,
                     box: tuple[int, int, int, int] | None = None, source=None) -> np.ndarray:
    """Attachment-space positions of image pixels, computed as the runtimes compute a region's corners.

    Mathematically the same map as :func:`region_quad_transform`, but evaluated in the
    runtimes' order of operations from the stored rectangle's corner: a vertex on an edge of
    the stored rectangle then gets, once rounded to float32 as the runtimes store both, the
    very coordinate of the region quad's edge. Along an edge the quad and the mesh share
    (wherever art reaches the border of a trimmed region), the rasteriser then sees one line,
    and pixels whose centres lie on it (axis-aligned poses put many there) are decided alike.

    Parameters
    ----------
    region : dict
        The region attachment (``x``, ``y``, ``rotation``, ``scaleX``, ``scaleY``, ``width``,
        ``height``).
    vertices_px : ndarray, shape (N, 2)
        Pixels of the original image (x right, y down).
    image_width, image_height : int
        The original image's size (the atlas region's original size).
    box : (x0, y0, x1, y1), optional
        The stored rectangle in the same pixels (default: the whole image).

    Returns
    -------
    ndarray, shape (N, 2)
        Positions in the slot's bone space, float64 (store them as float32).
    """
    x = number(region, "x", 0, source)
    y = number(region, "y", 0, source)
    rotation = number(region, "rotation", 0, source)
    scale_x, scale_y = number(region, "scaleX", 1, source), number(region, "scaleY", 1, source)
    width, height = number(region, "width", 32, source), number(region, "height", 32, source)
    x0, _, _, y1 = box if box is not None else (0, 0, image_width, image_height)
    region_scale_x = width / image_width * scale_x
    region_scale_y = height / image_height * scale_y
    offset_x, offset_y = x0, image_height - y1  # the stored rectangle's corner, y up from the bottom
    local_x = -width / 2 * scale_x + offset_x * region_scale_x
    local_y = -height / 2 * scale_y + offset_y * region_scale_y
    px = np.asarray(vertices_px, np.float64)
    lx = local_x + (px[:, 0] - offset_x) * region_scale_x
    ly = local_y + ((image_height - px[:, 1]) - offset_y) * region_scale_y
    radians = rotation * math.pi / 180
    cos, sin = math.cos(radians), math.sin(radians)
    return np.stack([(lx * cos + x) - ly * sin, (ly * cos + y) + lx * sin], axis=1)


def float32_exact(value: float) -> float:
    """``value`` rounded to float32, as the shortest decimal that reads back as that float32.

    Runtimes store vertices as float32: written this way, a JSON number loads as exactly the
    float32 a binary skeleton would hold, and no digit is spent beyond that.
    """
    return float32_exact_all(np.float64(value))[0]


def float32_exact_all(values: np.ndarray) -> list[float]:
    """:func:`float32_exact` of every value of ``values`` (any shape), flattened in order.

    A float32's ``str`` is its shortest round-tripping digits (Dragon4, as
    ``np.format_float_positional(..., unique=True)`` gives them, in scientific form for
    very small or large values, which reads back as the same number); one conversion of
    the array instead of one per value.
    """
    return [float(str(v)) for v in np.asarray(values, np.float64).astype(np.float32).ravel()]


def uvs_of(vertices: np.ndarray, width: int, height: int) -> np.ndarray:
    """UVs, shape (N, 2), of pixel positions (N, 2) in an image of ``width x height`` pixels."""
    uv = np.asarray(vertices, dtype=np.float64) / (float(width), float(height))
    return np.clip(uv, 0.0, 1.0)


def mesh_attachment(region: dict, vertices_px: np.ndarray, triangles: np.ndarray, hull: int,
                    edges: np.ndarray, image_width: int, image_height: int, source=None,
                    box: tuple[int, int, int, int] | None = None) -> dict:
    """The mesh attachment that replaces ``region``.

    Parameters
    ----------
    region : dict
        The region attachment; its ``name``, ``path``, ``color`` and ``sequence`` are kept.
    vertices_px : ndarray, shape (N, 2)
        Mesh vertices in pixels of the original image (x right, y down); the first
        ``hull`` form the outer loop.
    triangles : ndarray, shape (M, 3)
    edges : ndarray, shape (K, 2)
        Constrained edges as vertex index pairs (written doubled, as Spine's JSON wants).
    image_width, image_height : int
        Size in pixels of the image the vertices refer to.
    box : (x0, y0, x1, y1), optional
        The part of that image the atlas stores (see :func:`region_positions`).

    Returns
    -------
    dict
        A JSON mesh attachment with ``uvs``, ``triangles``, ``vertices`` (unweighted),
        ``hull``, ``edges``, ``width`` and ``height``, keys in the editor's order.
    """
    uv = uvs_of(vertices_px, image_width, image_height)
    pos = region_positions(region, vertices_px, image_width, image_height, box, source)
    fields = {
        "name": region.get("name"),
        "type": "mesh",
        "path": region.get("path"),
        "color": region.get("color"),
        # Python numbers through tolist (one conversion of the array, not one per value)
        "uvs": [round(c, 6) for c in uv.ravel().tolist()],
        "triangles": np.asarray(triangles, np.int64).ravel().tolist(),
        "vertices": float32_exact_all(pos),
        "hull": int(hull),
        "sequence": region.get("sequence"),
        "edges": [i * 2 for i in np.asarray(edges, np.int64).ravel().tolist()],
        "width": region.get("width", 32),
        "height": region.get("height", 32),
    }
    out = {k: fields[k] for k in MESH_KEY_ORDER if fields[k] is not None}
    # Unknown fields of the region (tool-specific extras) are kept, after the known ones.
    known = {"name", "type", "path", "color", "sequence", "width", "height", "x", "y", "rotation", "scaleX", "scaleY"}
    for k, v in region.items():
        if k not in known and k not in out:
            out[k] = v
    return out


def spine_triangles(vertices: np.ndarray, hull: int, edges: np.ndarray) -> np.ndarray | None:
    """A full constrained triangulation of the hull polygon, as Spine's mesh model wants it.

    Spine meshes are one hull polygon whose inside is entirely triangulated: the 4.2 binary
    format does not even store the triangle count, which must be ``2 * N - hull - 2``.
    The mesher may leave holes open (a ring's middle); here holes are triangulated too,
    while their outlines stay constrained edges, so the parts still deform independently.

    Parameters
    ----------
    vertices : ndarray, shape (N, 2)
    hull : int
        The first ``hull`` vertices, in order, form the outer loop.
    edges : ndarray, shape (K, 2)
        Constrained edges (the hull loop is added if missing).

    Returns
    -------
    ndarray, shape (2N - hull - 2, 3), or None
        None when no such triangulation exists (a vertex outside the hull, crossing edges).
    """
    import pythoncdt as cdt

    v = np.ascontiguousarray(vertices, dtype=np.float64)
    loop = np.stack([np.arange(hull), (np.arange(hull) + 1) % hull], axis=1)
    all_edges = np.unique(np.sort(np.concatenate([loop, np.asarray(edges, int).reshape(-1, 2)]), axis=1), axis=0)
    t = cdt.Triangulation(cdt.VertexInsertionOrder.AS_PROVIDED,
                          cdt.IntersectingConstraintEdges.NOT_ALLOWED, 0.0)
    try:
        t.insert_vertices(v)
        t.insert_edges(np.ascontiguousarray(all_edges, dtype=np.uint32))
        t.erase_outer_triangles()
    except RuntimeError:  # pythoncdt's refusal: crossing constraint edges, duplicate vertices
        return None
    if len(t.vertices_array()) != len(v):
        return None
    tris = t.triangles_array()["vertices"].astype(np.int64)
    if len(tris) != 2 * len(v) - hull - 2:
        return None
    return tris


def cover_resample(mask: np.ndarray, width: int, height: int) -> np.ndarray:
    """Resample a bool mask to ``height x width`` so that every cell any set texel overlaps is set.

    Cell ``(i, j)`` of the result covers ``[j/width, (j+1)/width] x [i/height, (i+1)/height]``
    of the image, as texel ``(y, x)`` of ``mask`` covers ``[x/w, (x+1)/w] x [y/h, (y+1)/h]``:
    a conservative resampling in normalised image coordinates (a mesh covering the result
    covers every set texel).

    Parameters
    ----------
    mask : ndarray, shape (h, w), bool
    width, height : int

    Returns
    -------
    ndarray, shape (height, width), bool
    """
    mask = np.asarray(mask, bool)
    h, w = mask.shape
    if (h, w) == (height, width):  # each cell is one texel: the mask itself (a copy)
        return mask.copy()

    def spans(n_out: int, n_in: int) -> tuple[np.ndarray, np.ndarray]:
        i = np.arange(n_out)
        return (i * n_in) // n_out, -((-(i + 1) * n_in) // n_out)  # [first, end) overlapping each cell

    x0, x1 = spans(width, w)
    y0, y1 = spans(height, h)
    # running counts of set texels; int32 holds any count of a row or column the limits allow
    along_x = np.zeros((h, w + 1), np.int32)
    np.cumsum(mask, axis=1, dtype=np.int32, out=along_x[:, 1:])
    cols = (along_x[:, x1] - along_x[:, x0]) > 0
    along_y = np.zeros((h + 1, width), np.int32)
    np.cumsum(cols, axis=0, dtype=np.int32, out=along_y[1:])
    return (along_y[y1] - along_y[y0]) > 0


def frames_on_one_grid(frames: list) -> list:
    """Sequence frames of different original sizes brought to the largest one's pixel grid.

    A sequence draws every frame over the attachment's one rectangle, whatever each frame's
    original size: runtimes place a frame's texel by its position relative to that frame's
    original size (its UV). One mesh serves every frame in those relative coordinates, so
    frames are compared on one grid: the largest frame's size. Colours are resampled
    bilinearly (they only guide interior edges), the drawn texels conservatively
    (:func:`cover_resample`), and the stored rectangle inwards, so that a mesh inside it
    samples every frame inside that frame's own stored rectangle.

    Parameters
    ----------
    frames : list of RegionImage

    Returns
    -------
    list of RegionImage
        ``frames`` itself when all have one size, else new images on the common grid.
    """
    import cv2

    from .images.sources import RegionImage

    if len({f.shape[:2] for f in frames}) <= 1:
        return frames
    height = max(f.shape[0] for f in frames)
    width = max(f.shape[1] for f in frames)
    out = []
    for f in frames:
        h, w = f.rgba.shape[:2]
        x0, y0, x1, y1 = f.content
        content = (-(-x0 * width // w), -(-y0 * height // h), x1 * width // w, y1 * height // h)
        rgba = cv2.resize(f.rgba, (width, height), interpolation=cv2.INTER_LINEAR)
        out.append(RegionImage(rgba, f.scale, f.name, f.source, content, cover_resample(f.drawn, width, height),
                               cover_resample(f.shown, width, height)))
    return out
