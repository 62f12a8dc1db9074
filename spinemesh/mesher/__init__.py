"""The auto-mesher: one sprite image in, one triangle mesh out (paper sec. 3).

>>> import numpy as np
>>> from spinemesh.mesher import mesh_image
>>> rgba = np.zeros((64, 64, 4), np.uint8)
>>> y, x = np.mgrid[:64, :64]
>>> rgba[(y - 32) ** 2 + (x - 32) ** 2 < 400] = 255   # an opaque disc
>>> mesh = mesh_image(rgba)                      # default preset: never clips, sparse
>>> mesh = mesh_image(rgba, preset="paper")      # the paper's parameters exactly
>>> mesh = mesh_image(rgba, density=2.0, max_vertices=60)
>>> mesh.vertex_count <= 60
True

Modules follow the pipeline: :mod:`.mask` (sec. 3.1), :mod:`.exterior` (sec. 3.2),
:mod:`.interior` (sec. 3.3), :mod:`.triangulate` (sec. 3.4), :mod:`.params` (presets),
:mod:`.mesh` (the result and ``mesh.json``), :mod:`.preview` (figures), :mod:`.worth` (when a
region should stay a region).
"""

from .mask import compute_mask
from .mesh import Mesh
from .params import PRESETS, MesherParams
from .pipeline import mesh_image, resolve_params
from .worth import DEFAULT_MIN_SAVING, NotWorthMeshing, worth_meshing

__all__ = ["mesh_image", "Mesh", "PRESETS", "MesherParams", "compute_mask", "resolve_params",
           "worth_meshing", "NotWorthMeshing", "DEFAULT_MIN_SAVING"]
