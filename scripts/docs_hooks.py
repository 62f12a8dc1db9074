"""MkDocs hooks (``hooks:`` in mkdocs.yml): generated pages' content put in at build time.

A page holding the line ``<!-- spinemesh-cli-reference -->`` gets, in its place, the reference
of every command generated from the application (:func:`spinemesh.cli.reference.cli_markdown`).
"""

from __future__ import annotations

MARKER = "<!-- spinemesh-cli-reference -->"


def on_page_markdown(markdown: str, **kwargs) -> str:
    """Replace the CLI reference marker by the generated reference."""
    if MARKER not in markdown:
        return markdown
    from spinemesh.cli.reference import cli_markdown

    return markdown.replace(MARKER, cli_markdown())
