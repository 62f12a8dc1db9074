"""The documentation site: it builds with ``mkdocs build --strict``, and its examples run.

Which examples run, where, and on what is the convention of :mod:`doc_examples` (every page
under ``docs/``, pages added later included): command lines starting with ``spinemesh `` in
fenced blocks are checked against the application and run on copies of the demo project
(``project/``, ``examples/demo/``, ``library/``, ``sprite.png``, ``sprites/``,
``flat-sprite.jpg``, ``hero.skel``), ```` ```python ```` blocks are executed, page by page in document order.
The README's examples are run by ``tests/test_readme.py`` with the same rules.
"""

from __future__ import annotations

import importlib.util
import re
import subprocess
import sys
from pathlib import Path

import pytest

from conftest import unavailable
from doc_examples import REPO, Example, examples_of, make_workspace, option_errors, run_page, why_not_run

PAGES = sorted((REPO / "docs").rglob("*.md"))
#: User-facing text names no commit or issue (the changelog may cite issue numbers).
COMMIT = re.compile(r"\b(?=[0-9a-f]*[a-f])(?=[0-9a-f]*[0-9])[0-9a-f]{7,40}\b")
ISSUE = re.compile(r"(#\d+\b|\bissues? \d+|goal (?:is |was )?not met|\.\./shared)", re.I)


@pytest.fixture(scope="module")
def workspace_template(tmp_path_factory) -> Path:
    return make_workspace(tmp_path_factory.mktemp("docs") / "template")


def test_site_builds_strict(tmp_path):
    """``mkdocs build --strict``: every page in the nav, every link and anchor resolves, the CLI
    and API references generate (a missing package fails in CI, skips elsewhere)."""
    missing = [m for m in ("mkdocs", "material", "mkdocstrings_handlers")
               if importlib.util.find_spec(m) is None]
    if missing:
        unavailable(f"the docs extra is not installed ({', '.join(missing)}): pip install '.[docs]'")
    done = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir",
                           str(tmp_path / "site")], cwd=REPO, capture_output=True, text=True,
                          env={**__import__("os").environ, "NO_MKDOCS_2_WARNING": "1"}, timeout=600)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-5000:]
    cli = (tmp_path / "site" / "reference" / "cli" / "index.html").read_text(encoding="utf-8")
    for command in ("upgrade", "weights", "mesh", "diff", "dataset", "segment-eval", "convert"):
        assert f'id="spinemesh-{command}"' in cli, f"the CLI reference lacks {command}"
    assert "--min-saving" in cli and "--weights" in cli
    api = (tmp_path / "site" / "reference" / "api" / "index.html").read_text(encoding="utf-8")
    assert "upgrade_project" in api and "mesh_image" in api


def test_cli_reference_has_every_command_and_option():
    """The generated reference holds every command and every option name the application has."""
    import typer

    from spinemesh.cli import app
    from spinemesh.cli.reference import cli_markdown

    text = cli_markdown()
    for name, command in typer.main.get_command(app).commands.items():
        assert f"## spinemesh {name}\n" in text
        for param in command.params:
            for opt in param.opts + param.secondary_opts:
                if opt.startswith("-"):
                    assert opt in text, f"{name}: {opt} missing from the reference"
    assert "```sh\nspinemesh upgrade project/ --out meshed/" in text  # --help examples as code


def test_pages_name_no_commit_or_issue():
    for page in [REPO / "README.md", *PAGES]:
        if page.name == "changelog.md":
            continue
        text = page.read_text(encoding="utf-8")
        for pattern in (COMMIT, ISSUE):
            found = pattern.search(text)
            assert not found, f"{page.relative_to(REPO)} names {found.group(0)!r}"


@pytest.mark.parametrize("page", PAGES, ids=[p.relative_to(REPO / "docs").as_posix() for p in PAGES])
def test_page_examples_run(page, workspace_template, tmp_path):
    """Every example of the page is checked, and run on the demo unless it cannot be."""
    import shutil

    workspace = tmp_path / "ws"
    shutil.copytree(workspace_template, workspace)
    run_page(page, workspace)


def test_convention_catches_what_it_should():
    """The checker itself: unknown options and commands fail, continuations join, NOT_RUN applies."""
    text = "```sh\nspinemesh upgrade project/ \\\n  --out x/ --no-such-option  # note\n```\n" \
           "```python\nprint(1)\n```\n```console\n$ spinemesh nope\n```\n"
    commands = [e for e in examples_of(text) if e.kind == "command"]
    assert [e.args for e in commands] == [["upgrade", "project/", "--out", "x/", "--no-such-option"],
                                          ["nope"]]
    assert option_errors(commands[0]) == ["upgrade: unknown option --no-such-option"]
    assert option_errors(commands[1]) == ["unknown command ['nope']"]
    assert [e.kind for e in examples_of(text)] == ["command", "python", "command"]
    assert Example("command", "spinemesh weights hero.skel --out w/", 1).args == ["weights", "heroes/hero.skel",
                                                                                  "--out", "w/"]
    assert why_not_run("docs/guide/x.md", Example("command", "spinemesh train --data DS", 1))
    assert why_not_run("docs/guide/x.md", Example("command", "spinemesh upgrade p --out o --dask local", 1)) is None
    assert why_not_run("docs/benchmarks/speed.md", Example("command", "spinemesh upgrade p --out o", 1))
