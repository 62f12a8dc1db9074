"""``spinemesh convert``: a skeleton from binary ``.skel`` to ``.json`` and back, same version."""

from __future__ import annotations

from pathlib import Path

import typer

from ._app import Annotated, app

_BINARY_SUFFIXES = (".skel", ".skel.bytes")


def _is_binary_name(path: Path) -> bool:
    return path.name.lower().endswith(_BINARY_SUFFIXES)


@app.command()
def convert(
    source: Annotated[Path, typer.Argument(metavar="SOURCE", help="Skeleton to read: .skel (binary) or .json.", exists=True,
                                           dir_okay=False)],
    target: Annotated[Path, typer.Argument(metavar="TARGET", help="Skeleton to write; its extension (.skel or .json) picks "
                                                "the format.")],
    keep_binary_info: Annotated[bool, typer.Option(
        "--keep-binary-info",
        help="Keep the binary-only data (string table order) in the JSON, so that converting it back "
             "gives the original .skel byte for byte.")] = False,
) -> None:
    """Convert a skeleton between binary .skel and .json, keeping its Spine version (3.6 to 4.3).

    The JSON has the layout of the Spine editor's own export of that version.

    \b
    Example: spinemesh convert hero.skel hero.json
    """
    # Imported here, not at the top: `spinemesh --help` and the other commands do not need them.
    from ..errors import SpineMeshError
    from ..fsutil import atomic_write_bytes, atomic_write_text, check_outputs
    from ..skeleton import dumps_skeleton, load_skeleton, spine_version
    from ..skeleton_binary import tidy_floats, write_skel
    from ..skeleton_binary.enums import EXTRA

    check_outputs([source], files=[target])  # never onto the source, never through a symlink
    doc = load_skeleton(source)
    if _is_binary_name(target):
        atomic_write_bytes(target, write_skel(doc, target))
        kind = "binary"
    elif target.suffix.lower() == ".json":
        if not keep_binary_info:
            doc = {k: v for k, v in doc.items() if k != EXTRA}
        if _is_binary_name(source):
            # float32 values as their shortest decimals, not as float64 expansions.
            doc = tidy_floats(doc)
        atomic_write_text(target, dumps_skeleton(doc, target))
        kind = "JSON"
    else:
        raise SpineMeshError("target must end in .skel, .skel.bytes or .json", target)
    # Plain echo: a rich console would cost more start-up than the conversion of a small skeleton.
    typer.echo(f"wrote {target} ({kind}, Spine {spine_version(doc) or '?'})")
