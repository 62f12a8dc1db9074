"""Training loop of paper section 3.1: BCE + Dice, AdamW with two learning rates, cosine
schedule, best checkpoint by validation IoU, JSON-lines log and PNG curves.

Data: data sets made by ``spinemesh dataset`` (``--data``, several allowed), gathered once
into a sprite pack (:mod:`spinemesh.train.data`), or a pack directly; the data sets' game
split decides training and validation sprites. Samples are composited by DataLoader worker
processes (``workers``) as uint8 and normalised on the device.

Runs on the CPU (a small configuration: 160 px input, a time budget) and on a GPU
(``device="cuda"``: bf16 autocast, channels-last) unchanged. On a time budget the cosine
schedule follows whichever of steps and wall time is further along, so the learning rate
reaches its floor when the budget ends rather than being cut off half-way.
"""

from __future__ import annotations

import math
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import cv2
import numpy as np
import torch
import torch.nn.functional as F
from torch.utils.data import DataLoader, IterableDataset

from ..files.atomic import atomic_write_json, atomic_write_stream, atomic_write_text
from ..files.strict_json import finite, strict_json
from ..written_folder import check_written_folder, mark_written_folder, remove_listed_files, temporary_files
from .data import VAL_BACKGROUNDS, flat_sample, normalise, read_pack, training_sample, write_pack
from .model import SegmentationModel, count_parameters, read_checkpoint


@dataclass
class TrainConfig:
    """Everything a run depends on; saved with every checkpoint.

    Defaults are the paper's (section 3.1) except where a CPU run needs smaller ones, which
    the ``train`` command's options override.
    """

    data: list = field(default_factory=list)  # data set folders and/or sprite packs (.npz)
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
    workers: int = 0                # DataLoader processes compositing samples (0: in the loop)
    init: str = ""                  # a state dict (encoder or whole model) to start from
    warmup_steps: int = 100
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
        x, y = prepare(x, y, device)
        with autocast(device):
            logits = model(x).float()
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


def autocast(device: str):
    """bf16 autocast on a GPU (Hopper and Ampere run it at full speed); plain float32 on the CPU."""
    return torch.autocast("cuda", dtype=torch.bfloat16, enabled=device.startswith("cuda"))


def prepare(x: torch.Tensor, y: torch.Tensor, device: str) -> tuple[torch.Tensor, torch.Tensor]:
    """uint8 (N, S, S, 3) images and (N, S, S) masks to normalised float NCHW on the device."""
    x = normalise(x.to(device, non_blocking=True))
    y = y.to(device, non_blocking=True).float()[:, None]
    if device.startswith("cuda"):
        x = x.contiguous(memory_format=torch.channels_last)
    return x, y


def train_step(model: SegmentationModel, opt: torch.optim.Optimizer, x: torch.Tensor, y: torch.Tensor,
               device: str = "cpu") -> tuple[float, float, float]:
    """One optimisation step on a prepared batch; returns (loss, bce, dice loss)."""
    model.train()
    opt.zero_grad(set_to_none=True)
    with autocast(device):
        logits = model(x)
    loss, bce, dl = seg_loss(logits.float(), y)
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
    atomic_write_stream(path, lambda f: fig.savefig(f, format="png", dpi=100))
    plt.close(fig)


class AugmentedSprites(IterableDataset):
    """An endless stream of augmented (image, mask) uint8 pairs of random training sprites.

    Each DataLoader worker draws from its own random stream (seed, worker id).
    """

    def __init__(self, sprites: list[np.ndarray], size: int, seed: int = 0):
        self.sprites, self.size, self.seed = sprites, size, seed

    def __iter__(self):
        info = torch.utils.data.get_worker_info()
        if info is not None:
            cv2.setNumThreads(1)  # one process per core already; OpenCV's pool would oversubscribe
        rng = np.random.default_rng((self.seed, info.id if info else 0))
        while True:
            x, y = training_sample(self.sprites, int(rng.integers(len(self.sprites))), self.size, rng)
            yield torch.from_numpy(x), torch.from_numpy(y)


def fixed_validation(sprites: list[np.ndarray], size: int, seed: int = 12345
                     ) -> tuple[torch.Tensor, torch.Tensor]:
    """One fixed image per held-out sprite, in its own frame as inference sees it, the
    background cycling through :data:`~spinemesh.train.data.VAL_BACKGROUNDS`."""
    xs, ys = [], []
    for i, s in enumerate(sprites):
        x, y = flat_sample(s, VAL_BACKGROUNDS[i % len(VAL_BACKGROUNDS)], size, np.random.default_rng((seed, i)))
        xs.append(x)
        ys.append(y)
    return torch.from_numpy(np.stack(xs)), torch.from_numpy(np.stack(ys))


def load_sprites(cfg: TrainConfig, workers: int = 1) -> dict[str, list]:
    """Training and held-out sprites of ``cfg.data``: packs are read, data set folders are
    first gathered into ``OUT/sprites.npz`` (see :func:`~spinemesh.train.data.write_pack`)."""
    folders = [p for p in cfg.data if Path(p).is_dir()]
    packs = [p for p in cfg.data if not Path(p).is_dir()]
    if folders:
        pack = Path(cfg.out) / "sprites.npz"
        write_pack(folders, pack)
        packs.append(str(pack))
    merged: dict[str, list] = {}
    for p in packs:
        for k, v in read_pack(p, workers).items():
            merged.setdefault(k, []).extend(v)
    return merged


def init_weights(model: SegmentationModel, path: str) -> None:
    """Start from a saved state dict: a whole model's, or the encoder's alone."""
    state = read_checkpoint(path)
    state = state.get("model", state)
    target = model if any(k.startswith("encoder.") for k in state) else model.encoder
    missing, unexpected = target.load_state_dict({k: v.float() for k, v in state.items()}, strict=False)
    if unexpected or (target is model.encoder and missing):
        raise ValueError(f"{path}: weights do not fit the model (missing {missing[:3]}, unexpected {unexpected[:3]})")


def half_state(model: SegmentationModel) -> dict:
    """State dict with float tensors in float16: half the size, and the exported model's
    float32 weights differ by less than the int8 quantisation step."""
    return {k: v.half() if v.is_floating_point() else v for k, v in model.state_dict().items()}


def train(cfg: TrainConfig, sprites: dict | None = None, progress=None) -> dict:
    """Train a segmentation model; see :func:`_train` for the parameters.

    CPU training flushes denormal floats to zero, a process-wide CPU flag; it is switched off
    again afterwards, since it also changes every later float computation in the process
    (it made float32 round trips of skeleton files inexact).
    """
    try:
        return _train(cfg, sprites, progress)
    finally:
        torch.set_flush_denormal(False)


def _train(cfg: TrainConfig, sprites: dict | None = None, progress=None) -> dict:
    """Train, keeping the checkpoint with the best validation IoU.

    Writes into ``cfg.out``: ``split.json`` (games per side), ``log.jsonl`` (one line per
    epoch), ``curves.png``, ``best.pt`` and ``last.pt`` (``{"config", "model", "metrics",
    "meta"}``, float16 weights). A killed run's temporary files there are removed once the run ends.

    Parameters
    ----------
    cfg : TrainConfig
    sprites : dict, optional
        Already loaded sprites, as :func:`load_sprites` returns them.
    progress : callable(str), optional
        Receives one line per epoch.

    Returns
    -------
    dict
        The best epoch's record.
    """
    torch.manual_seed(cfg.seed)
    _set_up_device(cfg)
    out = Path(cfg.out)
    check_written_folder(out, "training folder", "training run")  # a folder of a user's files: refused
    mark_written_folder(out)  # before its first file: a run cut short is written into again
    # A killed run's temporary files go once this run ends; not rewriting_folder's earlier files too:
    # a pack (--data OUT/sprites.npz) or checkpoint (--init OUT/best.pt) read from here is not written again.
    leftovers = temporary_files(out)
    sprites = sprites if sprites is not None else load_sprites(cfg, max(1, cfg.workers))
    train_s, val_s = _write_split(sprites, cfg.data, out)
    model = _build_model(cfg)
    opt = torch.optim.AdamW(model.param_groups(cfg.lr_decoder, cfg.lr_encoder, cfg.weight_decay))
    base_lrs = [g["lr"] for g in opt.param_groups]
    loader = iter(DataLoader(AugmentedSprites(train_s, cfg.image_size, cfg.seed), batch_size=cfg.batch_size,
                             num_workers=cfg.workers, pin_memory=cfg.device.startswith("cuda"),
                             persistent_workers=cfg.workers > 0, prefetch_factor=4 if cfg.workers else None))
    vx, vy = fixed_validation(val_s, cfg.image_size)
    val_loader = list(zip(vx.split(cfg.batch_size), vy.split(cfg.batch_size)))
    per_epoch = cfg.epoch_samples or len(train_s)
    steps_per_epoch = max(1, per_epoch // cfg.batch_size)
    meta = {"parameters": count_parameters(model), "encoder_parameters": count_parameters(model.encoder),
            "train_sprites": len(train_s), "val_sprites": len(val_s),
            "train_games": len(set(sprites.get("train_games", []))), "val_games": len(set(sprites.get("val_games", [])))}
    atomic_write_json(out / "config.json", finite({"config": asdict(cfg), **meta}), indent=1)

    log: list[dict] = []
    best: dict = {}
    run = _RunClock(time.monotonic(), steps_per_epoch * cfg.epochs, cfg.time_limit_min * 60)
    for epoch in range(1, cfg.epochs + 1):
        t0 = time.monotonic()
        losses, wait, stop = _train_epoch(model, opt, base_lrs, loader, run, steps_per_epoch, cfg)
        val = evaluate(model, val_loader, cfg.device)
        rec = {"epoch": epoch, "step": run.step, "train_loss": float(np.mean(losses)), "val": val,
               "lr_decoder": opt.param_groups[1]["lr"], "epoch_s": time.monotonic() - t0,
               "data_wait_s": wait, "elapsed_s": run.elapsed(),
               "samples_seen": run.step * cfg.batch_size}
        best = _save_epoch(out, model, rec, meta, log, best)
        if progress:
            progress(f"epoch {epoch}: train loss {rec['train_loss']:.4f}, val loss {val['loss']:.4f}, "
                     f"val IoU {val['iou']:.4f}, Dice {val['dice']:.4f}, acc {val['acc']:.4f} "
                     f"({rec['epoch_s']:.0f} s, {wait:.0f} s waiting for data)")
        if stop:
            break
    remove_listed_files(out, leftovers)  # only those still holding the bytes found: not another run's
    return best


def _set_up_device(cfg: TrainConfig) -> None:
    """Process-wide settings for the device: CPU threads and denormals, or cuDNN's autotuner."""
    if cfg.device == "cpu":
        torch.set_flush_denormal(True)  # denormals make CPU training up to 5x slower
        if cfg.threads:
            torch.set_num_threads(cfg.threads)
            # OpenCV's own thread pool (compositing, resizing) would otherwise spin on every core.
            cv2.setNumThreads(cfg.threads)
    if cfg.device.startswith("cuda"):
        torch.backends.cudnn.benchmark = True


def _write_split(sprites: dict, data: list, out: Path) -> tuple[list, list]:
    """The training and held-out sprites, with ``split.json`` (games and counts per side) written
    into ``out``; a ValueError when either side is empty."""
    train_s, val_s = sprites["train"], sprites["val"]
    if not train_s or not val_s:
        from ..dataset.extract import empty_side_said

        raise ValueError(empty_side_said(data, "train" if not train_s else "val"))
    atomic_write_json(out / "split.json", {
        "train_games": sorted(set(sprites.get("train_games", []))), "val_games": sorted(set(sprites.get("val_games", []))),
        "train_sprites": len(train_s), "val_sprites": len(val_s), "val_ids": sprites.get("val_ids", [])}, indent=1)
    return train_s, val_s


def _build_model(cfg: TrainConfig) -> SegmentationModel:
    """The model to train, on ``cfg.device``: pretrained, from ``cfg.init``'s weights, or from scratch."""
    model = SegmentationModel(cfg.encoder, cfg.image_size, cfg.pretrained and not cfg.init,
                              bn_momentum=cfg.bn_momentum or None)
    if cfg.init:
        init_weights(model, cfg.init)
    model = model.to(cfg.device)
    if cfg.device.startswith("cuda"):
        model = model.to(memory_format=torch.channels_last)
    return model


@dataclass
class _RunClock:
    """Where a run stands: when it started, the steps taken, and its step and time budgets
    (``limit_s`` 0: no time limit). The learning rate schedule and the time budget read it."""

    start: float
    total_steps: int
    limit_s: float
    step: int = 0

    def elapsed(self) -> float:
        return time.monotonic() - self.start

    def progress(self) -> float:
        """How far along the run is (0..1): steps or wall time, whichever is further."""
        return max(self.step / self.total_steps, self.elapsed() / self.limit_s if self.limit_s else 0.0)

    def out_of_time(self) -> bool:
        return bool(self.limit_s) and self.elapsed() >= self.limit_s


def _train_epoch(model: SegmentationModel, opt: torch.optim.Optimizer, base_lrs: list[float], loader,
                 run: _RunClock, steps: int, cfg: TrainConfig) -> tuple[list[float], float, bool]:
    """Up to ``steps`` training steps, each at its warm-up and cosine learning rate.

    Returns
    -------
    losses : list of float
        One per step taken.
    wait : float
        Seconds spent waiting for batches.
    stop : bool
        Whether the run's time budget ran out (the epoch then ends early).
    """
    losses = []
    wait = 0.0
    for _ in range(steps):
        tw = time.monotonic()
        x, y = prepare(*next(loader), cfg.device)
        wait += time.monotonic() - tw
        prog = run.progress()
        warm = min(1.0, (run.step + 1) / cfg.warmup_steps) if cfg.warmup_steps else 1.0
        for g, lr in zip(opt.param_groups, base_lrs):
            g["lr"] = lr * warm * cosine_factor(prog)
        losses.append(train_step(model, opt, x, y, cfg.device)[0])
        run.step += 1
        if run.out_of_time():
            return losses, wait, True
    return losses, wait, False


def _save_epoch(out: Path, model: SegmentationModel, rec: dict, meta: dict, log: list[dict], best: dict) -> dict:
    """An epoch's record appended to ``log`` and ``log.jsonl``, the curves redrawn, ``last.pt``
    written, and ``best.pt`` when its validation IoU is the best yet; returns the best record.

    Every file is written whole and renamed into place: a run stopped while saving keeps the
    earlier ``best.pt``. ``log.jsonl`` is this run's epochs (an earlier run's into the same
    folder are not mixed in), each a line of strict JSON (a loss that diverged is ``null``).
    """
    log.append(rec)
    atomic_write_text(out / "log.jsonl", "".join(strict_json(finite(r)) + "\n" for r in log))
    plot_curves(log, out / "curves.png")
    ckpt = {"config": model.config, "model": half_state(model), "metrics": rec, "meta": meta}
    atomic_write_stream(out / "last.pt", lambda f: torch.save(ckpt, f))
    if not best or rec["val"]["iou"] > best["val"]["iou"]:
        best = rec
        atomic_write_stream(out / "best.pt", lambda f: torch.save(ckpt, f))
    return best
