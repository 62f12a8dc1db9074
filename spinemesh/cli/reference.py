"""The command-line reference, generated from the application itself.

The documentation site's *Command line* page is this module's :func:`cli_markdown`: every
command with its help, usage, arguments and options exactly as ``--help`` prints them
(``scripts/docs_hooks.py`` puts it into the page when the site is built), so the reference
cannot drift from the code.
"""

from __future__ import annotations

import html
import re

_EXAMPLE = re.compile(r"^Example(?: \([^)]*\))?: ")


def _help_markdown(text: str) -> list[str]:
    """A command's help as Markdown: paragraphs kept, its ``Example:`` lines as a code block."""
    out: list[str] = []
    for paragraph in re.split(r"\n\s*\n", text.strip()):
        lines = [line.strip() for line in paragraph.splitlines() if line.strip()]
        examples = [line for line in lines if _EXAMPLE.match(line)]
        prose = [line for line in lines if not _EXAMPLE.match(line)]
        if prose:
            out += [html.escape(" ".join(prose), quote=False), ""]
        if examples:
            out += ["```sh", *(_EXAMPLE.sub("", line) for line in examples), "```", ""]
    return out


def _params_markdown(title: str, records: list[tuple[str, str]]) -> list[str]:
    """A definition list of ``(name, help)`` records under a bold title (none: nothing)."""
    if not records:
        return []
    out = [f"**{title}**", ""]
    for name, help_text in records:
        out += [f"`{name}`", f":   {html.escape(help_text, quote=False) or '-'}", ""]
    return out


def cli_markdown(heading_level: int = 2) -> str:
    """Markdown for every command of ``spinemesh``, in the order of ``spinemesh --help``.

    Parameters
    ----------
    heading_level : int, optional
        Markdown heading level of each command's title (default 2: ``## spinemesh upgrade``).

    Returns
    -------
    str
        Per command: its help (examples as code blocks), its usage line, and its arguments and
        options with the help, choices, ranges and defaults that ``--help`` prints.
    """
    import typer

    from . import app

    group = typer.main.get_command(app)
    out: list[str] = []
    for name, command in group.commands.items():
        ctx = command.make_context(f"spinemesh {name}", ["--help"], resilient_parsing=True)
        records = [(param, param.get_help_record(ctx)) for param in command.get_params(ctx)]
        records = [(param, record) for param, record in records if record is not None]
        arguments = [record for param, record in records if param.param_type_name == "argument"]
        options = [record for param, record in records if param.param_type_name == "option"]
        out += [f"{'#' * heading_level} spinemesh {name}", ""]
        out += _help_markdown(command.help or "")
        out += ["```text", command.get_usage(ctx), "```", ""]
        out += _params_markdown("Arguments", arguments)
        out += _params_markdown("Options", options)
    return "\n".join(out)
