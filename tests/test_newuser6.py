"""A new user walks the guides a sixth time, from an installed wheel and a folder outside the
checkout, on corpus and example projects: what they met that the program said badly, each test
failing on the code before its fix.

Everything runs on the demo project drawn by our own code (no outside data needed).
"""

from __future__ import annotations

from pathlib import Path

from test_pipeline import spinemesh

REPO = Path(__file__).resolve().parents[1]
DEMO = REPO / "examples" / "demo"


def _run(*args, cwd: Path):
    """``spinemesh ARGS`` as a user runs it, from ``cwd``: never a traceback."""
    r = spinemesh(*args, cwd=cwd)
    assert "Traceback" not in r.stdout + r.stderr, r.stderr[-3000:]
    return r


def test_the_paper_preset_refuses_the_options_it_does_not_read(tmp_path):
    """``mesh sprites/ --preset paper --density 2 --max-vertices 60`` (the mesh guide's example)
    wrote meshes of up to 94 vertices on spine-examples' raptor images, the same as without the
    options, and ``upgrade --preset paper --min-saving 0.5`` meshed every region: the paper's
    preset reads none of them. Each is refused in one line, before anything is written."""
    res = _run("mesh", DEMO / "images", "--out", "m", "--preset", "paper", "--density", "2", "--max-vertices", "60",
               cwd=tmp_path)
    assert res.returncode == 2, res.stdout + res.stderr
    assert "--density and --max-vertices tune the default preset only" in res.stderr, res.stderr
    res = _run("upgrade", DEMO, "--out", "u", "-p", "paper", "--min-saving", "0.5", cwd=tmp_path)
    assert res.returncode == 2, res.stdout + res.stderr
    assert "--min-saving tunes the default preset only" in res.stderr, res.stderr
    assert not (tmp_path / "m").exists() and not (tmp_path / "u").exists()
    # the default preset takes them; the paper preset alone runs as before
    assert _run("mesh", DEMO / "images", "--out", "d", "--max-vertices", "12", cwd=tmp_path).returncode == 0
    assert _run("mesh", DEMO / "images", "--out", "p", "--preset", "paper", cwd=tmp_path).returncode == 0
