"""The shared typer application and consoles."""

from __future__ import annotations

import typer
from rich.console import Console

app = typer.Typer(
    name="spinemesh",
    help="Automatic triangle meshes for Spine projects.\n\n"
         "Example: spinemesh upgrade project/ --out meshed/",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode="rich",
)
console = Console()
err_console = Console(stderr=True)


@app.callback()
def _root() -> None:
    """Automatic triangle meshes for Spine projects.

    Example: spinemesh upgrade project/ --out meshed/
    """
