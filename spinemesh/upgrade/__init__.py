"""``spinemesh upgrade``: region attachments become mesh attachments, whole projects at a time.

The stages, each a module: :mod:`.plan` (read and plan), :mod:`.meshing` (mesh on the
workers asked for), :mod:`.apply` (meshes into documents, weighted with ``--weights auto``),
:mod:`.write` (documents and files written), :mod:`.pack` (``--pack``), :mod:`.report` (what
became of every region); :mod:`.run` runs them for one project and :mod:`.library` for a
folder of projects on one set of workers. :mod:`.options` holds what the user asked for,
:mod:`spinemesh.output` the output-folder rules, :mod:`spinemesh.attachment_geometry` the one
rule that places a mesh where the region's quad was, :mod:`.repack` the atlases of
sequences stored whole, :mod:`.preview` the HTML page.
"""

from ..attachment_geometry import mesh_attachment, region_quad_transform, uvs_of
from ..runs import EXIT_PARTIAL
from .library import is_library, library_projects, upgrade_library
from .options import Options
from .report import Result, write_report
from .run import upgrade_project

__all__ = ["mesh_attachment", "region_quad_transform", "uvs_of", "EXIT_PARTIAL", "Options",
           "Result", "is_library", "library_projects", "upgrade_library", "upgrade_project", "write_report"]
