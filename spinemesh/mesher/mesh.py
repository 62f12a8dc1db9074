"""The :class:`Mesh` result and its ``mesh.json`` file format.

``mesh.json`` (stable; other tools read it)::

    {
      "width": W, "height": H,            # size of the image the mesh was made for (px)
      "vertices": [[x, y], ...],          # pixel coordinates, origin top-left, x right, y down
      "triangles": [[i, j, k], ...],      # vertex indices, see winding below
      "hull": N,                          # the first N vertices form the outer loop, in order
      "edges": [[i, j], ...],             # constrained edges: hull loop + interior chains + holes
      "interior": [false, ..., true, ...] # optional: vertex was placed inside (not on the hull/holes)
    }

Extra keys are allowed and ignored by readers. Winding: every triangle ``(i, j, k)`` has a
*positive* signed area ``(xj-xi)(yk-yi) - (xk-xi)(yj-yi) > 0`` in the stored coordinates,
i.e. it is clockwise as seen on screen (y down) and counter-clockwise in a y-up frame such
as Spine's UV-to-world mapping after the y flip. The hull loop has the same orientation.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass
class Mesh:
    """A triangle mesh over one image.

    Attributes
    ----------
    vertices : ndarray, shape (N, 2), float64
        Pixel coordinates of the original image (x right, y down, origin top-left corner of the
        top-left pixel). The first ``hull`` vertices form the outer loop in order.
    triangles : ndarray, shape (M, 3), int32
        Vertex indices, positive signed area in image coordinates (see module docstring).
    hull : int
        Number of leading vertices that form the outer loop.
    edges : ndarray, shape (K, 2), int32
        Constrained edges: the hull loop, hole loops and interior boundary chains.
    width, height : int
        Size of the image (px).
    is_interior : ndarray, shape (N,), bool
        True for vertices placed inside the art (yellow in previews), False for vertices on the
        hull or on a hole loop (blue).
    info : dict
        Free-form diagnostics (timings, preset name); written to JSON under ``"info"``.
    hole_triangles : ndarray, shape (H, 3), int32
        Triangles filling the holes the mesh leaves open (same winding), so that
        ``triangles`` and ``hole_triangles`` together triangulate the whole hull polygon,
        as a Spine mesh attachment must. Not written to ``mesh.json``.
    """

    vertices: np.ndarray
    triangles: np.ndarray
    hull: int
    edges: np.ndarray
    width: int
    height: int
    is_interior: np.ndarray
    info: dict = field(default_factory=dict)
    hole_triangles: np.ndarray = field(default_factory=lambda: np.zeros((0, 3), np.int32))

    def __post_init__(self):
        self.vertices = np.asarray(self.vertices, dtype=np.float64).reshape(-1, 2)
        self.triangles = np.asarray(self.triangles, dtype=np.int32).reshape(-1, 3)
        self.edges = np.asarray(self.edges, dtype=np.int32).reshape(-1, 2)
        self.is_interior = np.asarray(self.is_interior, dtype=bool).reshape(-1)
        self.hole_triangles = np.asarray(self.hole_triangles, dtype=np.int32).reshape(-1, 3)
        self.hull = int(self.hull)
        self.width = int(self.width)
        self.height = int(self.height)

    @property
    def vertex_count(self) -> int:
        return len(self.vertices)

    @property
    def triangle_count(self) -> int:
        return len(self.triangles)

    def hull_triangles(self) -> np.ndarray | None:
        """Every triangle of the hull polygon, holes filled: Spine's mesh model.

        A Spine mesh is one hull polygon triangulated entirely (the 4.2 binary format does not
        even store the triangle count, which must be ``2 * N - hull - 2``), so the mesher's
        own triangulation is returned with its holes filled, hole outlines kept as edges.

        Returns
        -------
        ndarray, shape (2N - hull - 2, 3), or None
            None when the triangles do not make such a triangulation (e.g. a mesh read from
            ``mesh.json``, which has no hole triangles, or a paper-preset mesh of several loops).
        """
        tris = np.concatenate([self.triangles, self.hole_triangles]).astype(np.int64)
        if len(tris) != 2 * len(self.vertices) - self.hull - 2 or len(np.unique(tris)) != len(self.vertices):
            return None
        return tris

    def to_json(self) -> dict:
        """The ``mesh.json`` dict.

        Coordinates are written at full precision (shortest round-trip repr): hull vertices can
        sit exactly on pixel corners, and rounding them inward would clip art by a sliver.
        A consumer that must round should round hull vertices away from the mesh.
        """
        verts = self.vertices
        out = {
            "width": self.width,
            "height": self.height,
            "vertices": [[_num(x), _num(y)] for x, y in verts],
            "triangles": self.triangles.tolist(),
            "hull": self.hull,
            "edges": self.edges.tolist(),
            "interior": self.is_interior.tolist(),
        }
        if self.info:
            out["info"] = self.info
        return out

    @classmethod
    def from_json(cls, doc: dict) -> "Mesh":
        """Read a ``mesh.json`` dict; ``interior`` defaults to "not on the hull"."""
        verts = np.asarray(doc["vertices"], dtype=np.float64).reshape(-1, 2)
        hull = int(doc["hull"])
        interior = doc.get("interior")
        if interior is None:
            interior = np.arange(len(verts)) >= hull
        return cls(vertices=verts, triangles=doc["triangles"], hull=hull, edges=doc.get("edges", []),
                   width=doc["width"], height=doc["height"], is_interior=interior,
                   info=dict(doc.get("info", {})))


def _num(v: float):
    """Integers print as integers so that JSON stays short and byte-stable."""
    f = float(v)
    return int(f) if f.is_integer() else f
