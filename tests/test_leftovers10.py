"""Small leftovers of the fourth stop, each proven here: a project named ``.`` from inside it
reported as from elsewhere, ..."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path


def run(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    env = dict(os.environ, COLUMNS="200", PYTHONPATH=os.pathsep.join(
        filter(None, [str(Path(__file__).resolve().parents[1]), os.environ.get("PYTHONPATH")])))
    return subprocess.run([sys.executable, "-m", "spinemesh", *args], capture_output=True, text=True, env=env,
                          cwd=cwd)


# --- a project named from inside it ----------------------------------------------------------------

def _demo_without_page(folder: Path, bad_skeleton: bool = False) -> Path:
    """The demo project with its atlas page gone (the atlas's error names the project's file), or
    with a skeleton that cannot be read beside its own."""
    from spinemesh.demo import make_demo_project

    project = folder / "proj"
    make_demo_project(project)
    if bad_skeleton:
        (project / "broken.json").write_text('{"skeleton": {"spine": "4.2.0"}, "bones": [')
    else:
        (project / "demo.png").unlink()
    return project


def _without_seconds(value):
    if isinstance(value, dict):
        return {k: _without_seconds(v) for k, v in value.items() if "seconds" not in k}
    if isinstance(value, list):
        return [_without_seconds(v) for v in value]
    return value


def test_project_named_dot_reports_as_from_elsewhere(tmp_path):
    import json

    outside = _demo_without_page(tmp_path / "a")
    inside = _demo_without_page(tmp_path / "b")
    first = run("upgrade", "proj", "--out", "out", "--report", "r.json", "--preview", "p", cwd=outside.parent)
    second = run("upgrade", ".", "--out", "../out", "--report", "../r.json", "--preview", "../p", cwd=inside)
    assert first.returncode == second.returncode == 3, (first.stderr, second.stderr)
    one = json.loads((outside.parent / "r.json").read_text())
    two = json.loads((inside.parent / "r.json").read_text())
    assert any("proj/demo.atlas" in e for e in one["errors"]), one["errors"]
    assert _without_seconds(one) == _without_seconds(two)
    assert (outside.parent / "p/index.html").read_bytes() == (inside.parent / "p/index.html").read_bytes()
    # a skeleton named from inside too, and the console still names a file to open
    third = run("upgrade", "demo.json", "--out", "../out3", "--report", "../r3.json", cwd=inside)
    three = json.loads((inside.parent / "r3.json").read_text())
    assert any("proj/demo.atlas" in e for e in three["errors"]), three["errors"]
    assert str(inside.resolve() / "demo.atlas") in third.stderr + third.stdout


def test_pack_project_named_dot_reports_as_from_elsewhere(tmp_path):
    import json

    outside = _demo_without_page(tmp_path / "a", bad_skeleton=True)
    inside = _demo_without_page(tmp_path / "b", bad_skeleton=True)
    first = run("pack", "proj", "--out", "out", "--report", "r.json", cwd=outside.parent)
    second = run("pack", ".", "--out", "../out", "--report", "../r.json", cwd=inside)
    assert first.returncode == second.returncode, (first.stderr, second.stderr)
    one = json.loads((outside.parent / "r.json").read_text())
    two = json.loads((inside.parent / "r.json").read_text())
    assert "proj/broken.json" in json.dumps(one), one
    assert _without_seconds(one) == _without_seconds(two)


# --- folders spinemesh marks as its own, written again ---------------------------------------------

def _plant_temporaries(folder: Path) -> tuple[list[str], list[str]]:
    """A killed run's temporary files (named as the atomic writer names them) at the top and one
    folder down, and a user's files that look like them but are not ours. Returns (ours, theirs)."""
    from spinemesh.files.atomic import _temporary_name

    ours = [_temporary_name("report.json", "0123abcd"), f"assets/{_temporary_name('0.png', 'deadbeef')}"]
    theirs = ["notes.tmp", ".draft.tmp", ".report.json.0123ABCD.tmp"]
    for rel in ours + theirs:
        (folder / rel).parent.mkdir(parents=True, exist_ok=True)
        (folder / rel).write_bytes(b"half a file")
    return ours, theirs


def _sprite(radius: int):
    import numpy as np

    yy, xx = np.mgrid[:48, :48]
    rgba = np.zeros((48, 48, 4), np.uint8)
    rgba[(yy - 24) ** 2 + (xx - 24) ** 2 < radius ** 2] = (200, 80, 40, 255)
    return rgba


def test_diff_report_written_again_loses_the_earlier_reports_files_and_a_killed_runs(tmp_path):
    """``diff --out`` written again kept the earlier report's pictures (``assets/``) that the new one
    did not write, and a killed run's temporary files; both go, a user's look-alikes stay."""
    _demo_without_page(tmp_path, bad_skeleton=True)
    assert run("upgrade", "proj", "--out", "meshed", cwd=tmp_path).returncode in (0, 3)
    first = run("diff", "meshed", "--out", "report", "--methods", "hull", "--limit", "3", cwd=tmp_path)
    assert first.returncode == 0, first.stderr
    out = tmp_path / "report"
    assert (out / "assets" / "2.png").is_file() and (out / "assets" / "2-hull.svg").is_file()
    ours, theirs = _plant_temporaries(out)
    second = run("diff", "meshed", "--out", "report", "--methods", "hull", "--limit", "1", cwd=tmp_path)
    assert second.returncode == 0, second.stderr
    assert (out / "assets" / "0.png").is_file() and (out / "report.json").is_file()
    assert not (out / "assets" / "2.png").exists() and not (out / "assets" / "1-hull.svg").exists()
    assert not any((out / rel).exists() for rel in ours), sorted(p.name for p in out.rglob("*"))
    assert all((out / rel).read_bytes() == b"half a file" for rel in theirs)


def _need(module: str, extra: str):
    """``module``, imported; a proof without it fails in CI and skips elsewhere (``unavailable``)."""
    import importlib

    from conftest import unavailable

    try:
        return importlib.import_module(module)
    except ImportError as e:
        unavailable(f"{module} is not installed ({e}): pip install 'spinemesh[{extra}]'")


def test_dataset_stats_plots_written_again_lose_a_killed_runs_temporary_files(tmp_path):
    _need("matplotlib", "stats")
    from spinemesh.dataset import build_dataset
    from spinemesh.demo import make_demo_project

    make_demo_project(tmp_path / "corpus" / "demo", with_images_folder=False)
    build_dataset([tmp_path / "corpus"], tmp_path / "ds")
    assert run("dataset-stats", "ds", "--plots", "plots", cwd=tmp_path).returncode == 0
    ours, theirs = _plant_temporaries(tmp_path / "plots")
    r = run("dataset-stats", "ds", "--plots", "plots", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "plots" / "image_sizes.png").is_file()
    assert not any((tmp_path / "plots" / rel).exists() for rel in ours)
    assert all((tmp_path / "plots" / rel).read_bytes() == b"half a file" for rel in theirs)


def test_training_folder_written_again_loses_a_killed_runs_temporary_files(tmp_path):
    _need("torch", "train")
    import torch

    from spinemesh.train.loop import TrainConfig, train

    out = tmp_path / "run"
    sprites = {"train": [_sprite(r) for r in (10, 14, 18)], "val": [_sprite(12)], "train_games": ["a"],
               "val_games": ["b"]}
    cfg = TrainConfig(out=str(out), pretrained=False, image_size=64, epochs=1, epoch_samples=2, batch_size=2,
                      warmup_steps=1, threads=1)
    threads = torch.get_num_threads()
    try:
        train(cfg, sprites)
        ours, theirs = _plant_temporaries(out)
        (out / "sprites.npz").write_bytes(b"a pack read from here")  # a file not the writer's: kept
        train(cfg, sprites)
    finally:
        torch.set_num_threads(threads)
    assert (out / "best.pt").is_file() and (out / "log.jsonl").is_file()
    assert not any((out / rel).exists() for rel in ours), sorted(p.name for p in out.rglob("*"))
    assert all((out / rel).read_bytes() == b"half a file" for rel in theirs)
    assert (out / "sprites.npz").read_bytes() == b"a pack read from here"


# --- an animation's key written twice beside another case of it --------------------------------------

def test_an_animation_key_written_twice_beside_another_case_of_it_is_said():
    """``x``, ``X``, ``x`` in an animation's object: ``x`` is written twice (spine-c, spine-cpp and
    libGDX read each, spine-ts the last), as the attachment check flags it; ``x`` and ``X`` alone,
    two names both kept, are not said."""
    from spinemesh.skeleton import parse_skeleton_json
    from spinemesh.skeleton_check import animations_keyed_twice

    slots = '{"spark": {"attachment": [], "Attachment": [], "attachment": []}}'
    lines = animations_keyed_twice(parse_skeleton_json('{"animations": {"wave": {"slots": ' + slots + "}}}"))
    assert len(lines) == 1 and lines[0].startswith("animation 'wave': slots.spark.attachment written twice;"), lines
    named = animations_keyed_twice(parse_skeleton_json('{"animations": {"wave": {}, "Wave": {}, "wave": {}}}'))
    assert named and named[0].startswith("animation 'wave': named twice;"), named
    assert not animations_keyed_twice(parse_skeleton_json('{"animations": {"wave": {"slots": {"s": {"rgba": [], '
                                                          '"RGBA": []}}}, "Wave": {}}}'))
