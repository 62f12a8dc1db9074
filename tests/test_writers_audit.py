"""Every writer audited: each file a command or library call writes is written atomically,
never over a user's files in a folder spinemesh did not write, never with NaN or Infinity.

Each test here failed on the code before its fix.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from PIL import Image


def run(*args: str, cwd: Path | None = None) -> subprocess.CompletedProcess:
    env = dict(os.environ, COLUMNS="200")
    return subprocess.run([sys.executable, "-m", "spinemesh", *args], capture_output=True, text=True, env=env,
                          cwd=cwd)


def _user_folder(path: Path, *names: str) -> dict[str, bytes]:
    """A folder of a user's files, some named as spinemesh would name its own; returns its contents."""
    path.mkdir(parents=True)
    for name in names:
        (path / name).parent.mkdir(parents=True, exist_ok=True)
        (path / name).write_bytes(b"mine: " + name.encode())
    return _contents(path)


def _contents(path: Path) -> dict[str, bytes]:
    return {p.relative_to(path).as_posix(): p.read_bytes() for p in sorted(path.rglob("*")) if p.is_file()}


def _one_error(r: subprocess.CompletedProcess) -> str:
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    (line,) = [x for x in r.stderr.splitlines() if x.startswith("error:")]
    return line


def _need(module: str, extra: str = "train"):
    """``module``, imported; a proof without it fails in CI and skips elsewhere (``unavailable``)."""
    import importlib

    from conftest import unavailable

    try:
        return importlib.import_module(module)
    except ImportError as e:
        unavailable(f"{module} is not installed ({e}): pip install 'spinemesh[{extra}]'")


def _sprite(path: Path, radius: int = 20) -> Path:
    yy, xx = np.mgrid[:64, :64]
    rgba = np.zeros((64, 64, 4), np.uint8)
    rgba[(yy - 32) ** 2 + (xx - 32) ** 2 < radius ** 2] = (200, 80, 40, 255)
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(rgba).save(path)
    return path


# --- mesh DIR: its --out, --preview and --steps folders -------------------------------------------

@pytest.mark.parametrize("option,name", [("--out", "hero.json"), ("--preview", "hero.png"), ("--steps", "hero.png")])
def test_mesh_of_a_folder_never_writes_over_a_users_folder(tmp_path, option, name):
    """``mesh DIR --out/--preview/--steps FOLDER`` wrote ``hero.json``/``hero.png`` into any folder,
    replacing a user's files of those names (exit 0). A folder of someone else's files is refused
    in one line before any work; the folders it writes are its own, written into again."""
    art = tmp_path / "art"
    _sprite(art / "hero.png")
    mine = tmp_path / "mine"
    before = _user_folder(mine, name, "notes.txt")
    line = _one_error(run("mesh", str(art), option, str(mine), cwd=tmp_path))
    assert f"{mine}: {option} folder is not empty and holds no spinemesh" in line, line
    assert _contents(mine) == before
    for _ in range(2):  # its own folders, written into again
        r = run("mesh", str(art), "--out", "meshes", "--preview", "previews", "--steps", "steps", cwd=tmp_path)
        assert r.returncode == 0, r.stderr
    assert (tmp_path / "meshes" / "hero.json").is_file() and (tmp_path / "steps" / "hero.png").is_file()


# --- dataset --out ----------------------------------------------------------------------------------

def test_a_data_set_is_never_built_in_a_folder_of_a_users_files(tmp_path):
    """``dataset --out FOLDER`` (and ``build_dataset``) appended its rows to a user's
    ``index.jsonl`` (cutting its last line when it had no newline), emptied their ``.lock`` and
    wrote ``meta.json`` and ``shards/`` beside them (exit 0). A folder of someone else's files is
    refused in one line before anything is written; a data set is resumed as before, also one an
    earlier spinemesh wrote without marking its folder."""
    from spinemesh.dataset import build_dataset
    from spinemesh.demo import make_demo_project
    from spinemesh.errors import OutputError

    make_demo_project(tmp_path / "corpus" / "demo", with_images_folder=False)
    mine = tmp_path / "mine"
    before = _user_folder(mine, "index.jsonl", "projects.jsonl", ".lock")
    line = _one_error(run("dataset", "corpus", "--out", "mine", cwd=tmp_path))
    assert "mine: data set folder is not empty and holds no spinemesh data set" in line, line
    assert _contents(mine) == before
    with pytest.raises(OutputError, match="data set folder is not empty"):
        build_dataset([tmp_path / "corpus"], mine)
    assert _contents(mine) == before
    ds = tmp_path / "ds"
    first = build_dataset([tmp_path / "corpus"], ds)
    assert first.samples > 0
    (ds / ".spinemesh-written").unlink()  # a data set built before folders were marked
    again = build_dataset([tmp_path / "corpus"], ds)
    assert again.samples == 0 and again.projects_done_before == 1


# --- dataset-stats --plots ----------------------------------------------------------------------------

def test_dataset_stats_never_draws_over_a_users_folder(tmp_path):
    """``dataset-stats DS --plots FOLDER`` wrote its four PNGs into any folder, replacing a user's
    ``image_sizes.png`` (exit 0), and through a symlink. Such a folder is refused in one line before
    any work; the folder it drew into is its own, drawn into again, and so is the default DS/stats."""
    _need("matplotlib", "stats")
    from spinemesh.dataset import build_dataset
    from spinemesh.demo import make_demo_project

    make_demo_project(tmp_path / "corpus" / "demo", with_images_folder=False)
    build_dataset([tmp_path / "corpus"], tmp_path / "ds")
    mine = tmp_path / "mine"
    before = _user_folder(mine, "image_sizes.png", "notes.txt")
    line = _one_error(run("dataset-stats", "ds", "--plots", "mine", cwd=tmp_path))
    assert "mine: --plots folder is not empty and holds no spinemesh plots" in line, line
    assert _contents(mine) == before
    (tmp_path / "link").symlink_to(mine)
    assert "symlink" in _one_error(run("dataset-stats", "ds", "--plots", "link", cwd=tmp_path))
    assert _contents(mine) == before
    for _ in range(2):
        for plots in (["--plots", "plots"], []):
            r = run("dataset-stats", "ds", *plots, cwd=tmp_path)
            assert r.returncode == 0, r.stderr
    assert (tmp_path / "plots" / "image_sizes.png").is_file() and (tmp_path / "ds" / "stats" / "type_share.png").is_file()


# --- segment-export: the model and its card ----------------------------------------------------------

@pytest.fixture
def checkpoint(tmp_path):
    """A small untrained checkpoint as the training loop writes one, and inputs to export it with."""
    torch = _need("torch")
    _need("onnxruntime")
    _need("efficientnet_lite_pytorch")
    from spinemesh.train.loop import half_state
    from spinemesh.train.model import SegmentationModel

    before = torch.get_num_threads()
    torch.set_num_threads(1)  # a shared machine: more threads spin
    torch.manual_seed(0)
    model = SegmentationModel("efficientnet-lite0", 64, pretrained=False).eval()
    path = tmp_path / "best.pt"
    torch.save({"config": model.config, "model": half_state(model), "metrics": {"epoch": 1}, "meta": {}}, path)
    inputs = [np.random.default_rng(i).normal(size=(3, 64, 64)).astype(np.float32) for i in range(4)]
    yield path, inputs
    torch.set_num_threads(before)


def test_an_exported_model_and_its_card_are_written_whole_or_not_at_all(tmp_path, checkpoint, monkeypatch):
    """``segment-export`` wrote ``OUT.fp32.onnx`` beside OUT (a user's file of that name replaced,
    then deleted), the model straight onto OUT, and the card with ``json.dumps``: a run that failed
    after the fp32 export left that file behind, and a checkpoint whose outputs are NaN shipped a
    card saying ``NaN``. Now both are made apart and written together, strict JSON or nothing."""
    import spinemesh.train.export as export
    from spinemesh.errors import SpineMeshError
    from spinemesh.segment import model_card

    ckpt, inputs = checkpoint
    out = tmp_path / "models" / "segment.onnx"
    before = _user_folder(out.parent, "segment.fp32.onnx", "segment.prep.onnx")

    def cut_short(*args):
        raise KeyboardInterrupt

    real_parity = export.parity
    with monkeypatch.context() as m:
        m.setattr(export, "quantize_int8", cut_short)
        with pytest.raises(KeyboardInterrupt):
            export.release(ckpt, out, inputs, inputs, int8=True)
    assert _contents(out.parent) == before
    with monkeypatch.context() as m:
        m.setattr(export, "parity", lambda *a: {"max_abs_logit_diff": float("nan"), "mask_pixels_differing": 0.0})
        with pytest.raises(SpineMeshError, match="non-finite"):
            export.release(ckpt, out, inputs, inputs, int8=False)
    assert _contents(out.parent) == before
    assert export.parity is real_parity
    card = export.release(ckpt, out, inputs, inputs, int8=True)
    assert card == model_card(out) and card["precision"] == "int8" and card["size_bytes"] == out.stat().st_size
    after = _contents(out.parent)
    assert sorted(after) == sorted([*before, "segment.json", "segment.onnx"])
    assert all(after[name] == data for name, data in before.items())


def test_segment_export_never_writes_its_card_through_a_symlink_or_onto_an_input(tmp_path):
    """The card beside ``--out`` was not checked: a symlink there was written through, onto any
    file it named, and ``--out ds/meta.onnx`` would write the card over ``ds/meta.json``, given
    as ``--data``. Both are refused in one line before any work, as ``--out`` itself is."""
    (tmp_path / "best.pt").write_bytes(b"not read: refused before")
    (tmp_path / "ds").mkdir()
    theirs = tmp_path / "theirs.json"
    theirs.write_text("{}")
    (tmp_path / "m.json").symlink_to(theirs)
    line = _one_error(run("segment-export", "best.pt", "--data", "ds", "--out", "m.onnx", cwd=tmp_path))
    assert "m.json: output file is a symlink" in line, line
    line = _one_error(run("segment-export", "best.pt", "--data", "ds/meta.json", "--out", "ds/meta.onnx",
                          cwd=tmp_path))
    assert "lies inside the input" in line or "is the input" in line, line
    assert theirs.read_text() == "{}"


# --- train --out: the training folder, its checkpoints and log ----------------------------------------

def test_training_never_writes_into_a_folder_of_a_users_files(tmp_path):
    """``train --out FOLDER`` (and ``train.loop.train``) wrote ``config.json``, ``split.json``,
    ``log.jsonl``, ``curves.png`` and the checkpoints into any folder, over a user's files of
    those names. Such a folder is refused in one line before the data are even read."""
    _need("torch")
    from spinemesh.errors import OutputError
    from spinemesh.train.loop import TrainConfig, train

    mine = tmp_path / "mine"
    before = _user_folder(mine, "config.json", "best.pt")
    (tmp_path / "ds").mkdir()
    line = _one_error(run("train", "--data", "ds", "--out", "mine", cwd=tmp_path))
    assert "mine: training folder is not empty and holds no spinemesh training run" in line, line
    with pytest.raises(OutputError, match="training folder is not empty"):
        train(TrainConfig(data=[str(tmp_path / "ds")], out=str(mine)))
    assert _contents(mine) == before


def test_an_epoch_is_saved_whole_its_log_strict_and_this_runs_own(tmp_path, monkeypatch):
    """Each epoch's ``best.pt`` and ``last.pt`` were written in place by ``torch.save``: a run
    stopped while saving (Ctrl-C, the time limit of a cluster job) left half a ``best.pt``, the
    earlier best lost. ``log.jsonl`` was appended to, as ``json.dumps`` writes (a diverged loss as
    ``NaN``, which strict readers refuse), after the lines of an earlier run into the folder."""
    torch = _need("torch")
    _need("matplotlib")
    _need("efficientnet_lite_pytorch")
    import json

    import spinemesh.train.loop as loop
    from spinemesh.train.model import SegmentationModel

    out = tmp_path / "run"
    out.mkdir()
    (out / "log.jsonl").write_text('{"epoch": 1, "from": "an earlier run"}\n')
    model = SegmentationModel("efficientnet-lite0", 64, pretrained=False)
    val = {"loss": 0.5, "iou": 0.5, "dice": 0.6, "acc": 0.9}
    best = loop._save_epoch(out, model, {"epoch": 1, "train_loss": 0.7, "val": val}, {}, log := [], {})
    saved = (out / "best.pt").read_bytes()

    real_save, calls = torch.save, []

    def cut_short(obj, f, *args, **kwargs):  # last.pt saved, best.pt stopped half-way (a path or an open file)
        calls.append(f)
        if len(calls) == 1:
            return real_save(obj, f, *args, **kwargs)
        if isinstance(f, (str, os.PathLike)):
            with open(f, "wb") as file:
                file.write(b"half a checkpoint")
        else:
            f.write(b"half a checkpoint")
        raise KeyboardInterrupt

    monkeypatch.setattr(torch, "save", cut_short)
    with pytest.raises(KeyboardInterrupt):
        loop._save_epoch(out, model, {"epoch": 2, "train_loss": float("nan"), "val": {**val, "iou": 0.7}}, {},
                         log, best)
    assert len(calls) == 2 and (out / "best.pt").read_bytes() == saved
    assert not [p.name for p in out.iterdir() if p.name.endswith(".tmp")]
    lines = (out / "log.jsonl").read_text().splitlines()
    records = [json.loads(line, parse_constant=lambda c: pytest.fail(f"{c} in log.jsonl")) for line in lines]
    assert [r["epoch"] for r in records] == [1, 2] and records[1]["train_loss"] is None
    assert "from" not in records[0]


def test_a_sprite_pack_cut_short_leaves_nothing_behind(tmp_path, monkeypatch):
    """``train --write-pack PACK`` wrote ``.PACK.tmp.npz`` beside it under one fixed name and left
    it there when the write failed (a full disk, Ctrl-C); two runs shared that name; a folder not
    made yet was a traceback. Now a uniquely named temporary file is removed whatever ends the run,
    PACK keeps what it held, and its folder is made as every output's is."""
    from spinemesh.dataset import build_dataset
    from spinemesh.demo import make_demo_project
    from spinemesh.train.data import read_pack, write_pack

    make_demo_project(tmp_path / "corpus" / "demo", with_images_folder=False)
    build_dataset([tmp_path / "corpus"], tmp_path / "ds")
    pack = tmp_path / "packs" / "sprites.npz"
    counts = write_pack([tmp_path / "ds"], pack)
    assert counts["train"] + counts["val"] > 0
    held = pack.read_bytes()
    real_savez = np.savez

    def cut_short(file, **arrays):
        real_savez(file, blob=arrays["blob"][:10])
        raise KeyboardInterrupt

    monkeypatch.setattr(np, "savez", cut_short)
    with pytest.raises(KeyboardInterrupt):
        write_pack([tmp_path / "ds"], pack)
    monkeypatch.undo()
    assert [p.name for p in pack.parent.iterdir()] == ["sprites.npz"] and pack.read_bytes() == held
    assert sum(len(v) for k, v in read_pack(pack).items() if k in ("train", "val")) == counts["train"] + counts["val"]


# --- the bone choice models the training script writes ------------------------------------------------

def test_bone_choice_models_are_written_strict_and_whole(tmp_path):
    """``save_fold_models`` (and the script writing the shipped model) wrote ``json.dumps`` text in
    place: a fit gone wrong wrote ``NaN``, which strict readers refuse. It is refused in one line
    naming the file, nothing written; a good model is written to the same bytes as the shipped one."""
    import json

    from spinemesh.errors import SpineMeshError
    from spinemesh.rig.learned import TreeEnsemble
    from spinemesh.train.bone_choice import load_fold_models, save_fold_models

    shipped = Path(__file__).resolve().parents[1] / "spinemesh" / "models" / "bone_choice.json"
    broken = TreeEnsemble.from_json(json.loads(shipped.read_text("utf-8")))
    broken.threshold = float("nan")
    with pytest.raises(SpineMeshError, match="fold-0.json: not written: it would hold a non-finite number"):
        save_fold_models({0: broken}, tmp_path / "broken")
    assert not (tmp_path / "broken").exists() or not list((tmp_path / "broken").iterdir())
    from spinemesh.train.bone_choice import write_model

    model = TreeEnsemble.from_json(json.loads(shipped.read_text("utf-8")))
    write_model(tmp_path / "again.json", model)
    assert (tmp_path / "again.json").read_bytes() == shipped.read_bytes()
    save_fold_models({0: model, 1: model}, tmp_path / "folds")
    assert set(load_fold_models(tmp_path / "folds", folds=2)) == {0, 1}


# --- what segment-export reads ----------------------------------------------------------------------

def test_segment_export_reads_a_checkpoint_as_data_only(tmp_path):
    """A checkpoint was read with ``torch.load(weights_only=False)``: a file that is not one was a
    traceback, and one holding a pickle that runs code ran it (here, making a folder). Both are
    now one line naming the file, exit 2, and nothing runs."""
    torch = _need("torch")

    class Runs:
        def __reduce__(self):
            return os.mkdir, (str(tmp_path / "ran"),)

    torch.save({"config": Runs(), "model": {}}, tmp_path / "runs.pt")
    (tmp_path / "junk.pt").write_bytes(b"not a checkpoint")
    for name in ("runs.pt", "junk.pt"):
        line = _one_error(run("segment-export", name, "--data", "ds", "--out", "m.onnx", cwd=tmp_path))
        assert line.startswith(f"error: {name}: not a checkpoint"), line
    assert not (tmp_path / "ran").exists() and not (tmp_path / "m.onnx").exists()


def test_a_shard_cut_short_leaves_no_temporary_file(tmp_path, monkeypatch):
    """A data set shard was written to ``.NAME.tmp``, one fixed name, left behind when the write
    failed (only the next run into the folder removed it). Now it is a uniquely named temporary
    file removed whatever stops the write; the offsets are those a tar reader finds."""
    import tarfile

    from spinemesh.dataset.format import write_shard

    members = [("a.png", b"x" * 700), ("b.png", b"y" * 3)]
    offsets = write_shard(tmp_path / "s.0000.tar", members)
    with tarfile.open(tmp_path / "s.0000.tar") as tar:
        for name, data in members:
            info = tar.getmember(name)
            assert (info.offset_data, info.size) == offsets[name]
    real_addfile = tarfile.TarFile.addfile

    def cut_short(self, info, fileobj=None):
        if info.name == "b.png":
            raise KeyboardInterrupt
        return real_addfile(self, info, fileobj)

    monkeypatch.setattr(tarfile.TarFile, "addfile", cut_short)
    with pytest.raises(KeyboardInterrupt):
        write_shard(tmp_path / "s.0001.tar", members)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.0000.tar"]


# --- a folder spinemesh writes again, holding a symlink to a folder elsewhere ---------------------------

def test_a_folder_written_again_never_writes_through_a_linked_folder(tmp_path):
    """An output folder spinemesh wrote before is written into again (``--overwrite``, a preview
    rerun). A symlink to a folder planted in it (``OUT/images -> elsewhere``) was followed: the
    project's images, the preview's pictures were written into ``elsewhere``, over its files of
    the same names (exit 0). Such a folder is refused in one line naming the link, nothing written."""
    from spinemesh.demo import make_demo_project

    make_demo_project(tmp_path / "p")
    r = run("upgrade", "p", "--out", "out", "--preview", "pv", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    elsewhere = tmp_path / "elsewhere"
    before = _user_folder(elsewhere, "demo-head.png", "notes.txt")
    for link in ("out/images", "pv/img"):
        (tmp_path / link).rename(tmp_path / (link + ".moved"))
        (tmp_path / link).symlink_to(elsewhere)
    line = _one_error(run("upgrade", "p", "--out", "out", "--overwrite", cwd=tmp_path))
    assert "out: output folder holds a symlink to a folder (images -> " in line, line
    assert (tmp_path / "out" / "demo.json").is_file()  # refused before anything was removed
    line = _one_error(run("upgrade", "p", "--out", "o2", "--preview", "pv", cwd=tmp_path))
    assert "pv: preview folder holds a symlink to a folder (img -> " in line, line
    assert _contents(elsewhere) == before and not (tmp_path / "o2").exists()


# --- segment and segment-eval: the model's card is read too ----------------------------------------

def test_segment_outputs_never_replace_the_model_or_its_card(tmp_path):
    """``segment``'s ``--out`` and ``segment-eval``'s ``--json``/``--worst`` were checked against
    the ``--model`` file alone: ``--out m.json`` replaced the card beside ``m.onnx`` (read by the
    same run), and with the shipped model, nothing kept an output off it or its card. Refused in
    one line, as an output onto any other input is."""
    from spinemesh.segment import DEFAULT_MODEL, card_path

    _sprite(tmp_path / "hero.png")
    (tmp_path / "m.onnx").write_bytes(b"a model")
    (tmp_path / "m.json").write_text('{"input_size": 64}')
    line = _one_error(run("segment", "hero.png", "--model", "m.onnx", "--out", "m.json", cwd=tmp_path))
    assert "m.json: output file is the input m.json" in line, line
    line = _one_error(run("segment-eval", "--data", "ds", "--model", "m.onnx", "--json", "m.json", cwd=tmp_path))
    assert "m.json: output file is the input m.json" in line, line
    assert (tmp_path / "m.json").read_text() == '{"input_size": 64}'
    shipped = card_path()
    before = shipped.read_bytes()
    line = _one_error(run("segment", "hero.png", "--out", str(shipped), cwd=tmp_path))
    assert "output file is the input" in line, line
    assert shipped.read_bytes() == before and DEFAULT_MODEL.is_file()


def test_mesh_of_a_folder_written_again_leaves_no_stale_mesh(tmp_path):
    """``mesh DIR`` written again into its folders left the mesh and pictures of an image since
    removed (a game's build step would read a mesh of art that is gone). They are removed, as
    ``upgrade --images`` and ``weights --preview`` remove theirs; a file spinemesh did not write
    there stays."""
    art = tmp_path / "art"
    _sprite(art / "hero.png")
    _sprite(art / "gone" / "villain.png", 12)
    options = ("--out", "meshes", "--preview", "previews")
    assert run("mesh", "art", *options, cwd=tmp_path).returncode == 0
    assert (tmp_path / "meshes" / "gone" / "villain.json").is_file()
    (tmp_path / "meshes" / "notes.txt").write_text("mine")
    (art / "gone" / "villain.png").unlink()
    r = run("mesh", "art", *options, cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    left = sorted(p.relative_to(tmp_path).as_posix() for p in tmp_path.glob("[mp]*/**/*") if p.is_file())
    assert left == ["meshes/.spinemesh-written", "meshes/hero.json", "meshes/notes.txt",
                    "previews/.spinemesh-written", "previews/hero.png"], left
