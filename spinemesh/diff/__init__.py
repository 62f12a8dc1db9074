"""``spinemesh diff``: generated meshes against the artists' own (paper sec. 5: the comparison with artists).

>>> from spinemesh.diff import run_diff, write_report
>>> result = run_diff(["projects/sack"])
>>> write_report(result, "sack-diff/")      # report.md, report.json, index.html, assets/

Modules: :mod:`.baselines` (the paper's hull / grid / Shi-Tomasi baselines, sec. 5),
:mod:`.compare` (hull IoU, Chamfer distance, artist mesh from a skeleton attachment),
:mod:`.run` (walk projects), :mod:`.report` (Markdown, JSON, HTML).
"""

from .baselines import BASELINES, baseline_mesh
from .compare import artist_mesh, chamfer_distance, coverage_iou, hull_iou
from .report import write_report
from .run import METHODS, DiffResult, DiffRow, run_diff

__all__ = ["BASELINES", "baseline_mesh", "artist_mesh", "chamfer_distance", "coverage_iou", "hull_iou",
           "METHODS", "DiffResult", "DiffRow", "run_diff", "write_report"]
