"""Training loop of paper section 3.1: BCE + Dice, AdamW with two learning rates, cosine
schedule, best checkpoint by validation IoU, JSON-lines log and PNG curves.

Runs on the CPU (a small configuration: 160 px input, a time budget) and on a GPU
(``device="cuda"``) unchanged. On a time budget the cosine schedule follows whichever of
steps and wall time is further along, so the learning rate reaches its floor when the
budget ends rather than being cut off half-way.
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import cv2
import numpy as np
import torch
import torch.nn.functional as F
from torch.utils.data import DataLoader

from ..segment.samples import Sprite, gather_sprites, split_of
from .data import CompositeDataset, FixedValDataset
from .model import SegmentationModel, count_parameters


@dataclass
class TrainConfig:
    """Everything a run depends on; saved with every checkpoint.

    Defaults are the paper's (section 3.1) except where a CPU run needs smaller ones, which
    the ``train`` command's options override.
    """

    shared: str = "../shared"
    out: str = "runs/segment"
    encoder: str = "efficientnet-lite0"
    pretrained: bool = True
    bn_momentum: float = 0.0        # 0: the encoder library's (0.01); use 0.1 from scratch
    image_size: int = 256
    epochs: int = 30
    epoch_samples: int = 0          # 0: one pass over the training sprites
    batch_size: int = 32
    lr_decoder: float = 1e-3
    lr_encoder: float = 1e-4
    weight_decay: float = 1e-4
    time_limit_min: float = 0.0     # 0: no limit
    device: str = "cpu"
    threads: int = 0                # 0: torch's default
    seed: int = 0
    max_side: int = 320
    limit_per_project: int = 0      # 0: all sprites (a few for smoke tests)
    extra: dict = field(default_factory=dict)


def dice_loss(logits: torch.Tensor, target: torch.Tensor, eps: float = 1.0) -> torch.Tensor:
    """1 - Dice of sigmoid(logits) against the target, per image then averaged (paper eq. 3, eps = 1)."""
    p = torch.sigmoid(logits).flatten(1)
    t = target.flatten(1)
    dice = (2 * (p * t).sum(1) + eps) / (p.sum(1) + t.sum(1) + eps)
    return (1 - dice).mean()


def seg_loss(logits: torch.Tensor, target: torch.Tensor) -> tuple[torch.Tensor, float, float]:
    """BCE + Dice (paper eq. 2). Returns the loss and its two parts as floats."""
    bce = F.binary_cross_entropy_with_logits(logits, target)
    dice = dice_loss(logits, target)
    return bce + dice, float(bce.detach()), float(dice.detach())


def batch_metrics(logits: torch.Tensor, target: torch.Tensor) -> dict[str, np.ndarray]:
    """Per-image IoU, Dice and pixel accuracy of the thresholded prediction (p > 0.5).

    An image whose prediction and target are both empty scores 1.
    """
    pred = (logits > 0).flatten(1).float()
    t = target.flatten(1)
    inter = (pred * t).sum(1)
    union = pred.sum(1) + t.sum(1) - inter
    total = pred.sum(1) + t.sum(1)
    iou = torch.where(union > 0, inter / union.clamp(min=1), torch.ones_like(union))
    dice = torch.where(total > 0, 2 * inter / total.clamp(min=1), torch.ones_like(total))
    acc = (pred == t).float().mean(1)
    return {"iou": iou.cpu().numpy(), "dice": dice.cpu().numpy(), "acc": acc.cpu().numpy()}


@torch.no_grad()
def evaluate(model: SegmentationModel, loader: DataLoader, device: str) -> dict[str, float]:
    """Mean loss and per-image metrics over a loader."""
    model.eval()
    sums = {"loss": 0.0, "bce": 0.0, "dice_loss": 0.0}
    per = {"iou": [], "dice": [], "acc": []}
    n = 0
    for x, y in loader:
        x, y = x.to(device), y.to(device)
        logits = model(x)
        loss, bce, dl = seg_loss(logits, y)
        k = len(x)
        sums["loss"] += float(loss) * k
        sums["bce"] += bce * k
        sums["dice_loss"] += dl * k
        for key, v in batch_metrics(logits, y).items():
            per[key].append(v)
        n += k
    out = {k: v / max(n, 1) for k, v in sums.items()}
    out.update({k: float(np.concatenate(v).mean()) if v else 0.0 for k, v in per.items()})
    return out


def train_step(model: SegmentationModel, opt: torch.optim.Optimizer, x: torch.Tensor, y: torch.Tensor
               ) -> tuple[float, float, float]:
    """One optimisation step; returns (loss, bce, dice loss)."""
    model.train()
    opt.zero_grad(set_to_none=True)
    loss, bce, dl = seg_loss(model(x), y)
    loss.backward()
    opt.step()
    return float(loss.detach()), bce, dl


def cosine_factor(progress: float) -> float:
    """Cosine annealing from 1 to 0 as ``progress`` goes from 0 to 1."""
    return 0.5 * (1 + math.cos(math.pi * min(max(progress, 0.0), 1.0)))


def plot_curves(log: list[dict], path: Path) -> None:
    """Loss and validation IoU per epoch, as a PNG."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    ep = [r["epoch"] for r in log]
    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4))
    a.plot(ep, [r["train_loss"] for r in log], label="train")
    a.plot(ep, [r["val"]["loss"] for r in log], label="validation")
    a.set_xlabel("epoch")
    a.set_ylabel("BCE + Dice loss")
    a.legend()
    b.plot(ep, [r["val"]["iou"] for r in log], label="IoU")
    b.plot(ep, [r["val"]["dice"] for r in log], label="Dice")
    b.set_xlabel("epoch")
    b.set_ylabel("validation (held-out games)")
    b.set_ylim(0, 1)
    b.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def split_sprites(cfg: TrainConfig) -> tuple[list[Sprite], list[Sprite]]:
    limit = cfg.limit_per_project or None
    sprites = gather_sprites(cfg.shared, cfg.max_side, limit_per_project=limit)
    train = [s for s in sprites if split_of(s.game) == "train"]
    val = [s for s in sprites if split_of(s.game) == "val"]
    return train, val


def train(cfg: TrainConfig, sprites: tuple[list[Sprite], list[Sprite]] | None = None,
          progress=None) -> dict:
    """Train a segmentation model; see :func:`_train` for the parameters.

    CPU training flushes denormal floats to zero, a process-wide CPU flag; it is switched off
    again afterwards, since it also changes every later float computation in the process
    (it made float32 round trips of skeleton files inexact).
    """
    try:
        return _train(cfg, sprites, progress)
    finally:
        torch.set_flush_denormal(False)


def _train(cfg: TrainConfig, sprites: tuple[list[Sprite], list[Sprite]] | None = None,
          progress=None) -> dict:
    """Train, keeping the checkpoint with the best validation IoU.

    Writes into ``cfg.out``: ``split.json`` (games and sprite ids per side), ``log.jsonl``
    (one line per epoch), ``curves.png``, ``best.pt`` and ``last.pt`` (``{"config", "model",
    "metrics"}``).

    Parameters
    ----------
    cfg : TrainConfig
    sprites : (train, val), optional
        Already gathered sprites (default: gathered from ``cfg.shared``).
    progress : callable(str), optional
        Receives one line per epoch.

    Returns
    -------
    dict
        The best epoch's record.
    """
    torch.manual_seed(cfg.seed)
    if cfg.device == "cpu":
        torch.set_flush_denormal(True)  # denormals make CPU training up to 5x slower
        if cfg.threads:
            torch.set_num_threads(cfg.threads)
            # OpenCV's own thread pool (compositing, resizing) would otherwise spin on every core.
            cv2.setNumThreads(cfg.threads)
    out = Path(cfg.out)
    out.mkdir(parents=True, exist_ok=True)
    train_s, val_s = sprites if sprites is not None else split_sprites(cfg)
    if not train_s or not val_s:
        raise ValueError(f"no training or validation sprites under {cfg.shared}")
    (out / "split.json").write_text(json.dumps({
        "train_games": sorted({s.game for s in train_s}), "val_games": sorted({s.game for s in val_s}),
        "train": [s.id for s in train_s], "val": [s.id for s in val_s]}, indent=1))

    model = SegmentationModel(cfg.encoder, cfg.image_size, cfg.pretrained,
                              bn_momentum=cfg.bn_momentum or None).to(cfg.device)
    opt = torch.optim.AdamW(model.param_groups(cfg.lr_decoder, cfg.lr_encoder, cfg.weight_decay))
    base_lrs = [g["lr"] for g in opt.param_groups]
    train_ds = CompositeDataset(train_s, cfg.image_size, cfg.seed)
    val_loader = DataLoader(FixedValDataset(val_s, cfg.image_size), batch_size=cfg.batch_size)
    per_epoch = cfg.epoch_samples or len(train_ds)
    steps_per_epoch = max(1, per_epoch // cfg.batch_size)
    total_steps = steps_per_epoch * cfg.epochs
    rng = np.random.default_rng(cfg.seed)
    meta = {"parameters": count_parameters(model), "encoder_parameters": count_parameters(model.encoder),
            "train_sprites": len(train_s), "val_sprites": len(val_s)}
    (out / "config.json").write_text(json.dumps({"config": asdict(cfg), **meta}, indent=1))

    log: list[dict] = []
    best: dict = {}
    start = time.monotonic()
    step = 0
    limit_s = cfg.time_limit_min * 60
    for epoch in range(1, cfg.epochs + 1):
        t0 = time.monotonic()
        losses = []
        order = rng.permutation(len(train_ds))[:steps_per_epoch * cfg.batch_size]
        if len(order) < steps_per_epoch * cfg.batch_size:  # fewer sprites than one epoch asks
            order = rng.choice(len(train_ds), steps_per_epoch * cfg.batch_size)
        stop = False
        for b in range(steps_per_epoch):
            idx = order[b * cfg.batch_size:(b + 1) * cfg.batch_size]
            items = [train_ds[int(i)] for i in idx]
            x = torch.stack([t[0] for t in items]).to(cfg.device)
            y = torch.stack([t[1] for t in items]).to(cfg.device)
            elapsed = time.monotonic() - start
            prog = max(step / total_steps, elapsed / limit_s if limit_s else 0.0)
            for g, lr in zip(opt.param_groups, base_lrs):
                g["lr"] = lr * cosine_factor(prog)
            losses.append(train_step(model, opt, x, y)[0])
            step += 1
            if limit_s and time.monotonic() - start >= limit_s:
                stop = True
                break
        val = evaluate(model, val_loader, cfg.device)
        rec = {"epoch": epoch, "step": step, "train_loss": float(np.mean(losses)), "val": val,
               "lr_decoder": opt.param_groups[1]["lr"], "epoch_s": time.monotonic() - t0,
               "elapsed_s": time.monotonic() - start, "samples_seen": step * cfg.batch_size}
        log.append(rec)
        with open(out / "log.jsonl", "a", encoding="utf-8") as f:
            f.write(json.dumps(rec) + "\n")
        plot_curves(log, out / "curves.png")
        ckpt = {"config": model.config, "model": model.state_dict(), "metrics": rec, "meta": meta}
        torch.save(ckpt, out / "last.pt")
        if not best or val["iou"] > best["val"]["iou"]:
            best = rec
            torch.save(ckpt, out / "best.pt")
        if progress:
            progress(f"epoch {epoch}: train loss {rec['train_loss']:.4f}, val loss {val['loss']:.4f}, "
                     f"val IoU {val['iou']:.4f}, Dice {val['dice']:.4f}, acc {val['acc']:.4f} "
                     f"({rec['epoch_s']:.0f} s)")
        if stop:
            break
    return best
