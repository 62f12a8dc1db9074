"""``upgrade --pack``: the written project's atlas pages packed anew by the upgraded meshes' outlines.

It runs after the project is written (:func:`.run.finish_project`), on the output folder in
place: it packs by the skeleton files a game will load (the meshes just written, ``--repack``'s
untrimmed pages included) and changes no skeleton, only atlases and page images, with the
rules of ``spinemesh pack`` (:mod:`spinemesh.pack`). An atlas that cannot be packed stays as
the upgrade wrote it, with the reason in the report.
"""

from __future__ import annotations

import time
from pathlib import Path

from ..errors import SpineMeshError
from ..project import find_project
from .report import Result


def pack_written(out: Path, result: Result) -> None:
    """Pack every atlas of the project just written to ``out``; rows go to ``result.atlases``."""
    from ..pack.run import PackOptions, PackResult, pack_project_into

    t0 = time.perf_counter()
    packed = PackResult()
    try:
        pack_project_into(find_project(out), out, PackOptions(), packed)
    except SpineMeshError as e:
        result.errors.append(f"not packed: {e}")
    result.atlases += packed.atlases
    result.errors += [f"{a.atlas}: not packed: {a.reason}" for a in packed.atlases if a.status == "failed"]
    result.errors += [f"packing: {e}" for e in packed.errors]
    result.seconds["pack"] = result.seconds.get("pack", 0.0) + time.perf_counter() - t0
