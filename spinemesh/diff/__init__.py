"""``spinemesh diff``: generated meshes against the artists' own (paper sec. 5: the comparison with artists).

>>> import tempfile
>>> from spinemesh.demo import make_demo_project
>>> from spinemesh.diff import run_diff, write_report
>>> from spinemesh.upgrade import upgrade_project
>>> tmp = tempfile.mkdtemp()
>>> _ = upgrade_project(make_demo_project(f"{tmp}/demo"), f"{tmp}/meshed")  # meshes standing for an artist's
>>> result = run_diff([f"{tmp}/meshed"])
>>> sorted(write_report(result, f"{tmp}/meshed-diff"))  # report.md, report.json, index.html, assets/
['html', 'json', 'markdown']

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
