"""``spinemesh info``: what a project holds."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import typer
from rich.table import Table

from ..atlas import read_atlas
from ..errors import SpineMeshError
from ..project import find_project, image_source_for
from ..skeleton import image_paths, iter_attachments, load_skeleton, spine_version
from ._app import app, console, err_console


@app.command()
def info(project: Path = typer.Argument(..., help="Project folder or skeleton file (.json/.skel).")) -> None:
    """Show the Spine version, attachments by type, atlas pages and regions, and missing images.

    Example: spinemesh info ../shared/spine-examples/4.2/spineboy
    """
    proj = find_project(project)
    atlases = {}
    for p in proj.atlases:
        try:
            atlases[p] = read_atlas(p)
        except SpineMeshError as e:
            err_console.print(f"[yellow]skipped atlas:[/] {e}")
    table = Table(title=f"Atlases in {proj.root}")
    for col in ("atlas", "syntax", "pages", "regions", "scale", "pma"):
        table.add_column(col)
    for p, a in atlases.items():
        table.add_row(str(p.relative_to(proj.root)), a.syntax, str(len(a.pages)), str(len(a.regions)),
                      ",".join(sorted({f"{pg.scale:g}" for pg in a.pages})), "yes" if any(pg.pma for pg in a.pages) else "no")
    console.print(table)
    for path in proj.skeletons:
        try:
            doc = load_skeleton(path)
        except SpineMeshError as e:
            err_console.print(f"[red]unreadable skeleton:[/] {e}")
            continue
        refs = list(iter_attachments(doc))
        counts = Counter(r.type for r in refs)
        source = image_source_for(doc, path, proj, atlases=atlases)
        missing = sorted({(r.skin, r.slot, r.name, p) for r in refs for p in image_paths(r)
                          if source is None or p not in source})
        console.print(f"\n[bold]{path.relative_to(proj.root)}[/]  Spine {spine_version(doc) or '?'}  "
                      f"images from: {_describe(source)}")
        t = Table()
        t.add_column("attachment type")
        t.add_column("count", justify="right")
        for kind, n in sorted(counts.items()):
            t.add_row(kind, str(n))
        t.add_row("[bold]total[/]", str(len(refs)))
        console.print(t)
        if missing:
            console.print(f"[yellow]{len(missing)} attachment image(s) not found:[/]")
            for skin, slot, name, p in missing[:50]:
                console.print(f"  skin {skin!r} slot {slot!r} attachment {name!r}: image {p!r}")
            if len(missing) > 50:
                console.print(f"  ... and {len(missing) - 50} more")
        else:
            console.print("every attachment image was found")


def _describe(source) -> str:
    if source is None:
        return "[red]none[/]"
    if hasattr(source, "atlases"):
        return ", ".join(a.path.name for a in source.atlases)
    return str(source.folder)
