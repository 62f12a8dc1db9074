"""Small leftovers of the fifth stop, each proven here: a usage error of any command in one
line, ..."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest


def run(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    env = dict(os.environ, COLUMNS="200", PYTHONPATH=os.pathsep.join(
        filter(None, [str(Path(__file__).resolve().parents[1]), os.environ.get("PYTHONPATH")])))
    return subprocess.run([sys.executable, "-m", "spinemesh", *args], capture_output=True, text=True, env=env,
                          cwd=cwd)


# --- a usage error in one line ---------------------------------------------------------------------

def _commands() -> dict:
    """Every command the app registers (a new one is checked too), by name."""
    import typer

    from spinemesh.cli import app

    return typer.main.get_command(app).commands


COMMANDS = _commands()
NEEDING_AN_ARGUMENT = sorted(name for name, command in COMMANDS.items()
                             if any(p.required and p.param_type_name == "argument" for p in command.params))


def _one_usage_line(r: subprocess.CompletedProcess, command: str, words: str) -> None:
    """Exit 2, nothing on stdout, one line on stderr: the command, click's words, the help's place."""
    assert r.returncode == 2, (r.returncode, r.stdout, r.stderr)
    assert r.stdout == "" and r.stderr.count("\n") == 1, r.stderr
    line = r.stderr.rstrip("\n")
    prefix = f"error: {command}: " if command else "error: "
    assert line.startswith(prefix + words), line
    assert line.endswith(f" {command} --help')" if command else " spinemesh --help')"), line
    assert "Usage:" not in line and "Traceback" not in line


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_an_unknown_option_is_one_line_in_every_command(command):
    _one_usage_line(run(command, "x", "--bogus", "y"), command, "No such option: --bogus")


@pytest.mark.parametrize("command", NEEDING_AN_ARGUMENT)
def test_a_missing_argument_is_one_line_in_every_command(command):
    _one_usage_line(run(command), command, "Missing argument '")


@pytest.mark.parametrize("args, words", [
    (["mesh", "x.png", "--preset", "nope"], "Invalid value for '--preset' / '-p': 'nope' is not one of"),
    (["upgrade", "p", "--out", "o", "--jobs", "many"], "Invalid value for '--jobs' / '-j': 'many' is not a valid"),
    (["upgrade", "p", "--out", "o", "--density", "nan"], "Invalid value for '--density'"),
    (["pose", "s.json", "--times=abc"], "Invalid value for --times: 'abc' is not a number of seconds"),
    (["segment", "x.png"], "Missing option '--out'"),
    # a traceback from deep in the export, once the sprites were read
    (["segment-export", "best.pt", "--data", "ds", "--out", "m.onnx", "--size", "100"],
     "Invalid value for '--size': 100 is not a multiple of 32"),
])
def test_a_bad_value_is_one_line(tmp_path, args, words):
    _one_usage_line(run(*args, cwd=tmp_path), args[0], words)
    assert list(tmp_path.iterdir()) == []


def test_an_unknown_command_or_root_option_is_one_line():
    _one_usage_line(run("upgrayed"), "", "No such command 'upgrayed'")
    _one_usage_line(run("--bogus"), "", "No such option: --bogus")


def test_help_and_version_are_as_before():
    r = run()
    assert r.returncode == 2 and r.stderr.startswith("Usage: ") and "Commands:" in r.stderr, r.stderr
    r = run("upgrade", "--help")
    assert r.returncode == 0 and r.stdout.startswith("Usage: ") and r.stderr == ""
    r = run("--version")
    assert r.returncode == 0 and r.stdout.startswith("spinemesh "), r.stdout
