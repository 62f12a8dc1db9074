"""``spinemesh upgrade``: region attachments become mesh attachments, whole projects at a time.

:mod:`.geometry` holds the one rule that places a mesh where the region's quad was;
:mod:`.run` walks projects, meshes each unique image once, and writes the result.
"""

from .geometry import mesh_attachment, region_quad_transform, uvs_of
from .run import EXIT_PARTIAL, Options, Result, upgrade_project, write_report

__all__ = ["mesh_attachment", "region_quad_transform", "uvs_of", "EXIT_PARTIAL", "Options",
           "Result", "upgrade_project", "write_report"]
