"""``spinemesh convert``: a skeleton from binary ``.skel`` to ``.json`` and back, same version.

The options live here; the work in :mod:`.convert_files`, which the console script also runs
without typer for a plain call.
"""

from __future__ import annotations

from pathlib import Path

import typer

from ._app import Annotated, app
from .convert_files import KEEP_BINARY_INFO, convert_files, say_converted


@app.command()
def convert(
    source: Annotated[Path, typer.Argument(metavar="SOURCE", help="Skeleton to read: .skel (binary) or .json.")],
    target: Annotated[Path, typer.Argument(metavar="TARGET", help="Skeleton to write; its extension picks the format: .skel "
                                                "or .skel.bytes (binary), .json, .json.txt (Unity) or .spine-json "
                                                "(Godot).")],
    keep_binary_info: Annotated[bool, typer.Option(
        KEEP_BINARY_INFO,
        help="Keep the binary-only data (string table order) in the JSON, so that converting it back "
             "gives the original .skel byte for byte.")] = False,
) -> None:
    """Convert a skeleton between binary .skel and .json, keeping its Spine version (3.5 to 4.3).

    The JSON has the layout of the Spine editor's own export of that version.

    \b
    Example: spinemesh convert hero.skel hero.json
    """
    # Plain print: a rich console would cost more start-up than the conversion of a small skeleton.
    say_converted(convert_files(source, target, keep_binary_info))
