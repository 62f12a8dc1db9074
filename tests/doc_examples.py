"""The examples shown in README.md and the documentation pages, found and run on the demo.

The convention every page follows (README.md and every Markdown file under ``docs/``, pages
added later included):

* **Commands.** Every line of a fenced code block that starts with ``spinemesh `` (after an
  optional ``$ ``) is a command example; a trailing ``\\`` continues it on the next line and
  ``#`` starts a comment. Each one is checked against the application itself: the command
  exists and every option it names is one of that command's options. Then it is run
  (``python -m spinemesh ARGS`` must exit 0 without a traceback), unless it matches one of
  :data:`NOT_RUN`, which says why it cannot run on the demo (training, a running cluster, data
  outside the repository).
* **Python.** Every ```` ```python ```` block runs, in one namespace per page.
* **Where.** A page's commands and Python blocks run in document order in a fresh folder that
  holds the placeholder inputs of :func:`make_workspace`: ``project/`` and ``examples/demo/``
  (copies of the demo project), ``library/`` (two copies of it), ``sprite.png`` and
  ``sprites/`` (demo images), ``flat-sprite.jpg`` (a demo image flattened on a blue background,
  no alpha). An argument named in :data:`ALIASES` (``hero.skel``) stands for a file there (the
  demo's binary skeleton, already upgraded to meshes, in ``heroes/``). Outputs land in that
  folder, so a later example on a page reads what an earlier one wrote. So a page's examples
  use these names, or outputs its own earlier examples made.
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
import subprocess
import sys
from dataclasses import dataclass
from fnmatch import fnmatch
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
DEMO = REPO / "examples" / "demo"

#: Examples that cannot run on the demo: (page glob, pattern searched in the command line,
#: why). They are still checked against the application's commands and options.
NOT_RUN: tuple[tuple[str, str, str], ...] = (
    ("docs/benchmarks/*", r"", "measured on data outside the repository, minutes to hours"),
    ("*", r"^spinemesh train\b", "needs the train extra (PyTorch) and minutes to hours"),
    ("*", r"^spinemesh segment-export\b", "needs a checkpoint written by spinemesh train"),
    ("*", r"--dask (?!local\b)", "needs a running Dask scheduler"),
)

#: Arguments that stand for a file of the workspace (a skeleton on its own cannot lie at the
#: workspace's root: its folder would be the project, and every output inside it refused).
ALIASES = {"hero.skel": "heroes/hero.skel"}

_FENCE = re.compile(r"^(?P<indent> *)(?P<fence>```+|~~~+)\s*(?P<info>[^\n`]*)$")


@dataclass(frozen=True)
class Example:
    """One example of a page: a command line (``kind == "command"``) or a Python block."""

    kind: str
    text: str
    line: int  # 1-based line of the page where it starts

    @property
    def args(self) -> list[str]:
        """The command's arguments after ``spinemesh`` (commands only), :data:`ALIASES` resolved."""
        return [ALIASES.get(arg, arg) for arg in shlex.split(self.text, comments=True)[1:]]


def examples_of(markdown: str) -> list[Example]:
    """Command lines and Python blocks of a Markdown text, in document order.

    Parameters
    ----------
    markdown : str
        The page's text.

    Returns
    -------
    list of Example
        Commands (lines starting with ``spinemesh `` in any fenced block, continuations
        joined) and Python blocks (fences whose info string starts with ``python``).
    """
    found: list[Example] = []
    lines = markdown.split("\n")
    i = 0
    while i < len(lines):
        opening = _FENCE.match(lines[i])
        if not opening:
            i += 1
            continue
        fence, indent = opening["fence"], len(opening["indent"])
        language = opening["info"].strip().split(" ")[0].lower()
        start = i + 1
        i += 1
        body: list[str] = []
        while i < len(lines) and not lines[i].strip().startswith(fence):
            body.append(lines[i][indent:] if lines[i][:indent].strip() == "" else lines[i])
            i += 1
        i += 1  # the closing fence
        if language == "python":
            found.append(Example("python", "\n".join(body) + "\n", start + 1))
            continue
        j = 0
        while j < len(body):
            text = body[j].strip()
            if text.startswith("$ "):
                text = text[2:]
            if not text.startswith("spinemesh "):
                j += 1
                continue
            first = j
            while text.endswith("\\") and j + 1 < len(body):
                j += 1
                text = text[:-1] + " " + body[j].strip()
            found.append(Example("command", text, start + 1 + first))
            j += 1
    return found


def why_not_run(page: str, example: Example) -> str | None:
    """The reason an example cannot run on the demo (:data:`NOT_RUN`), or None when it runs."""
    for glob, pattern, reason in NOT_RUN:
        if fnmatch(page, glob) and re.search(pattern, example.text):
            return reason
    return None


def option_errors(example: Example) -> list[str]:
    """What in a command line the application does not know: the command, or an option.

    Returns
    -------
    list of str
        One message per unknown command or option; empty when the line fits the application.
    """
    import typer

    from spinemesh.cli import app

    group = typer.main.get_command(app)
    args = example.args
    if not args or args[0] not in group.commands:
        return [f"unknown command {args[:1]}"]
    command = group.commands[args[0]]
    known = {"--help", "-h"}
    for param in command.params:
        known.update(param.opts)
        known.update(param.secondary_opts)
    return [f"{args[0]}: unknown option {token}" for token in args[1:]
            if token.startswith("-") and token.split("=", 1)[0] not in known]


def make_workspace(folder: Path) -> Path:
    """Lay out the placeholder inputs the pages' examples use (see the module docstring)."""
    import numpy as np
    from PIL import Image

    folder.mkdir(parents=True, exist_ok=True)
    shutil.copytree(DEMO, folder / "project")
    shutil.copytree(DEMO, folder / "examples" / "demo")
    shutil.copytree(DEMO, folder / "library" / "studio-a" / "hero")
    shutil.copytree(DEMO, folder / "library" / "studio-b" / "villain")
    shutil.copy(DEMO / "images" / "demo-body.png", folder / "sprite.png")
    (folder / "sprites").mkdir()
    for name in ("demo-body.png", "demo-head.png", "demo-ring.png"):
        shutil.copy(DEMO / "images" / name, folder / "sprites" / name)
    rgba = np.asarray(Image.open(DEMO / "images" / "demo-body.png").convert("RGBA"), np.float64)
    alpha = rgba[..., 3:] / 255.0
    flat = rgba[..., :3] * alpha + np.array([40.0, 90.0, 200.0]) * (1 - alpha)
    Image.fromarray(flat.round().astype(np.uint8)).save(folder / "flat-sprite.jpg", quality=92)
    from spinemesh.upgrade import Options, upgrade_project

    upgrade_project(DEMO / "demo-binary.skel", folder / "heroes", Options(jobs=1))
    (folder / "heroes" / "demo-binary.skel").rename(folder / "heroes" / "hero.skel")
    return folder


def run_command(example: Example, cwd: Path, where: str) -> None:
    """Run one command example as a user would (``python -m spinemesh``); it must exit 0."""
    env = {**os.environ, "PYTHONPATH": str(REPO), "COLUMNS": "100"}
    done = subprocess.run([sys.executable, "-m", "spinemesh", *example.args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=600)
    output = (done.stdout + done.stderr)[-3000:]
    assert done.returncode == 0, f"{where}: `{example.text}` exited {done.returncode}:\n{output}"
    assert "Traceback" not in output, f"{where}: `{example.text}` printed a traceback:\n{output}"


def run_page(page: Path, workspace: Path) -> tuple[int, int, str]:
    """Check and run every example of one page in ``workspace`` (a fresh folder).

    Returns
    -------
    tuple of (int, int, str)
        Commands run, commands only checked (:data:`NOT_RUN`), and what the Python blocks printed.
    """
    import contextlib
    import io

    name = page.relative_to(REPO).as_posix()
    ran = checked = 0
    printed = io.StringIO()
    namespace: dict = {"__name__": "__docs__"}
    previous = Path.cwd()
    os.chdir(workspace)
    try:
        for example in examples_of(page.read_text(encoding="utf-8")):
            where = f"{name}:{example.line}"
            if example.kind == "python":
                with contextlib.redirect_stdout(printed):
                    exec(compile(example.text, where, "exec"), namespace)
                continue
            errors = option_errors(example)
            assert not errors, f"{where}: `{example.text}`: {'; '.join(errors)}"
            if why_not_run(name, example):
                checked += 1
                continue
            run_command(example, workspace, where)
            ran += 1
    finally:
        os.chdir(previous)
    return ran, checked, printed.getvalue()
