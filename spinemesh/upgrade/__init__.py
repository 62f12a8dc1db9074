"""``spinemesh upgrade``: region attachments become mesh attachments, whole projects at a time.

:mod:`.geometry` holds the one rule that places a mesh where the region's quad was;
:mod:`.run` plans projects, meshes each unique image once on the workers asked for, and
writes the result; a folder of many projects is upgraded with one set of workers.
"""

from ..runs import EXIT_PARTIAL
from .geometry import mesh_attachment, region_quad_transform, uvs_of
from .run import (Options, Result, is_library, upgrade_library, upgrade_project,
                  write_report)

__all__ = ["mesh_attachment", "region_quad_transform", "uvs_of", "EXIT_PARTIAL", "Options",
           "Result", "is_library", "upgrade_library", "upgrade_project", "write_report"]
