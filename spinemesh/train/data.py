"""Training samples: real sprites flattened onto random backgrounds (paper section 3.4, broadened).

The sprites come from data sets made by ``spinemesh dataset`` (the one data path, see
:mod:`spinemesh.segment.samples`). For training they are first gathered into a *pack*: each
useful sprite of both sides of the split, cropped to its visible box, at most 256 px, as a
lossy-colour / lossless-alpha WebP, in one ``.npz`` (8,000 sprites take about 40 MB). A pack
is what travels to a GPU machine; decoding it takes seconds on a few cores.

Every training sample is drawn afresh (:func:`training_sample`):

- *frame* (40 %): the sprite in its own frame, with a random margin on each side (negative:
  cut off, so it touches or crosses the border), stretched to the square input, which is
  what inference sees;
- *placed* (60 %): scaled (0.25-1.3 of the side), stretched a little, sometimes rotated, and
  put anywhere, also partly outside;
- a background kind drawn from :data:`TRAIN_BACKGROUNDS` (coarse noise at any scale from
  fine grain to large blotches), sometimes with crops of other sprites pasted over it as
  clutter;
- horizontal (and rarely vertical) flips, colour jitter, blur, JPEG compression.

The target is the placed sprite's alpha > 128 (section 3.1). Samples are uint8; the
ImageNet normalisation (:func:`normalise`) runs on the training device.
"""

from __future__ import annotations

import io
from concurrent.futures import ProcessPoolExecutor
from itertools import pairwise
from pathlib import Path

import cv2
import numpy as np
from PIL import Image

from ..errors import SpineMeshError
from ..files.atomic import atomic_write_stream
from ..images.decode import decode_rgba
from ..segment.composite import coarse_noise_background, make_background
from ..segment.preprocess import IMAGENET_MEAN, IMAGENET_STD, resize
from ..segment.samples import dataset_rows, shrink, useful

#: Background kinds drawn for training, with their weights.
TRAIN_BACKGROUNDS = {"solid": 0.18, "gradient": 0.12, "noise": 0.22, "radial": 0.1, "perlin": 0.12,
                     "grain": 0.1, "texture": 0.16}
#: The kinds validation cycles through (the three of the issue's held-out check).
VAL_BACKGROUNDS = ("solid", "gradient", "noise")
#: Longest side of a sprite in a pack, pixels.
PACK_MAX_SIDE = 256


# --- packs -------------------------------------------------------------------------------

def visible_box(rgba: np.ndarray) -> tuple[int, int, int, int]:
    """``(x, y, w, h)`` of the pixels with alpha > 0 (the whole image if none)."""
    x, y, w, h = cv2.boundingRect((rgba[..., 3] > 0).astype(np.uint8))
    if w == 0 or h == 0:
        return 0, 0, rgba.shape[1], rgba.shape[0]
    return x, y, w, h


def encode_sprite(rgba: np.ndarray) -> bytes:
    """WebP bytes: lossy colour (quality 90), lossless alpha."""
    buf = io.BytesIO()
    Image.fromarray(rgba, "RGBA").save(buf, format="WEBP", quality=90, alpha_quality=100, method=4)
    return buf.getvalue()


def decode_sprite(data: bytes) -> np.ndarray:
    """(H, W, 4) uint8 straight-alpha sprite from :func:`encode_sprite`'s bytes."""
    return decode_rgba(data).copy()


def write_pack(datasets: list[str | Path], out: str | Path, max_side: int = PACK_MAX_SIDE) -> dict:
    """Gather every useful sprite of the data sets (both sides of the split) into one ``.npz``.

    Parameters
    ----------
    datasets : list of path
        Data set folders (``spinemesh dataset``).
    out : path
        The pack to write.
    max_side : int
        Longest side kept after cropping to the visible box, pixels.

    Returns
    -------
    dict
        Counts: ``{"train": n, "val": n, "bytes": size}``.
    """
    blobs, ids, games, splits = [], [], [], []
    for ds, row in dataset_rows(datasets):
        rgba = ds.load_image(row)
        if not useful(rgba):
            continue
        x, y, w, h = visible_box(rgba)
        blobs.append(encode_sprite(shrink(np.ascontiguousarray(rgba[y:y + h, x:x + w]), max_side)))
        ids.append(row["id"])
        games.append(row["game"])
        splits.append(row["split"])
    offsets = np.cumsum([0] + [len(b) for b in blobs]).astype(np.int64)
    out = Path(out)
    # a uniquely named temporary file beside it, removed whatever ends the run (a fixed name was left behind)
    atomic_write_stream(out, lambda f: np.savez(
        f, blob=np.frombuffer(b"".join(blobs), np.uint8), offsets=offsets, ids=np.array(ids),
        games=np.array(games), splits=np.array(splits), max_side=np.array(max_side)))
    return {"train": splits.count("train"), "val": splits.count("val"), "bytes": out.stat().st_size}


def empty_sides(data: list[str | Path]) -> list[str]:
    """The sides of the game split (``"train"``, ``"val"``) that ``data`` (data set folders and
    sprite packs) gives no sprite, read from the indexes and the packs' split lists alone: a run
    refuses them before writing anything (a data set of one game wrote its pack into OUT, then
    stopped on a traceback). A pack of another form is refused here too, before anything is written
    (:func:`read_pack`'s line)."""
    from ..dataset import open_dataset

    sides = set()
    for path in data:
        if Path(path).is_dir():
            ds = open_dataset(path)
            sides |= {side for side in ("train", "val") if next(iter(ds.rows(side)), None) is not None}
            continue
        sides |= set(_pack_fields(path)[4])
    return [side for side in ("train", "val") if side not in sides]


def _decode_range(args: tuple[bytes, list[int]]) -> list[np.ndarray]:
    blob, offsets = args
    return [decode_sprite(blob[a:b]) for a, b in pairwise(offsets)]


def _pack_fields(path: str | Path) -> tuple[np.ndarray, np.ndarray, list, list, list]:
    """``blob, offsets, ids, games, splits`` of a sprite pack, checked (see :func:`read_pack`)."""
    import zipfile

    from ..files.inputs import regular_file

    def bad(what: str) -> SpineMeshError:
        return SpineMeshError(f"not a sprite pack of `spinemesh train --write-pack`: {what}", path)

    regular_file(path, "sprite pack")  # a FIFO waited for ever: only regular files are read
    try:
        with np.load(path) as z:
            blob, offsets = z["blob"], z["offsets"]
            ids, games, splits = z["ids"].tolist(), z["games"].tolist(), z["splits"].tolist()
    except FileNotFoundError:
        raise SpineMeshError("sprite pack not found", path) from None
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as e:
        raise bad(str(e).strip().splitlines()[0][:200] if str(e).strip() else type(e).__name__) from None
    n = len(ids)
    if blob.dtype != np.uint8 or blob.ndim != 1 or offsets.ndim != 1 or offsets.dtype.kind not in "iu":
        raise bad("its blob is not bytes or its offsets not integers")
    if len(offsets) != n + 1 or len(games) != n or len(splits) != n:
        raise bad(f"{n} ids, {len(games)} games, {len(splits)} sides and {len(offsets)} offsets")
    if n and (offsets[0] < 0 or offsets[-1] > blob.size or bool((np.diff(offsets) < 0).any())):
        raise bad("its offsets do not cut its bytes in order")
    others = sorted({str(s) for s in splits} - {"train", "val"})
    if others:
        raise bad(f"a sprite's side is {others[0]!r}, not 'train' or 'val'")
    return blob, offsets, ids, games, splits


def read_pack(path: str | Path, workers: int = 1) -> dict[str, list]:
    """Decode a pack: ``{"train": [...], "val": [...], "train_games", "val_games", "val_ids"}``.

    Sprites are (H, W, 4) uint8 straight alpha, cropped to their visible box.

    Raises
    ------
    SpineMeshError
        In one line naming the pack, when it is no pack ``--write-pack`` writes (a file cut
        short, a field missing or of objects, offsets that do not cut its bytes in order, a
        side other than train and val) or a sprite in it cannot be decoded; each was a
        traceback or a line naming no file.
    """
    blob, offsets, ids, games, splits = _pack_fields(path)
    blob, offsets = blob.tobytes(), offsets.tolist()
    n = len(ids)
    chunks = [(i, min(n, i + 256)) for i in range(0, n, 256)]
    jobs = [(blob[offsets[a]:offsets[b]], [o - offsets[a] for o in offsets[a:b + 1]]) for a, b in chunks]
    try:
        if workers > 1:
            with ProcessPoolExecutor(workers) as pool:
                parts = list(pool.map(_decode_range, jobs))
        else:
            parts = [_decode_range(j) for j in jobs]
    except SpineMeshError as e:  # its words name no file: the bytes came from the pack
        raise SpineMeshError(f"a sprite of the pack cannot be read ({e.message})", path) from None
    sprites = [s for part in parts for s in part]
    out: dict[str, list] = {"train": [], "val": [], "train_games": [], "val_games": [], "val_ids": []}
    for s, g, sp, i in zip(sprites, games, splits, ids):
        out[sp].append(s)
        out[f"{sp}_games"].append(g)
        if sp == "val":
            out["val_ids"].append(i)
    return out


# --- one sample --------------------------------------------------------------------------

def premultiplied_float(rgba: np.ndarray) -> np.ndarray:
    """(H, W, 4) float32: colour times alpha, and alpha, all in 0..1."""
    f = rgba.astype(np.float32) / 255.0
    f[..., :3] *= f[..., 3:4]
    return f


def warp(pm: np.ndarray, matrix: np.ndarray, size: int) -> np.ndarray:
    """Premultiplied sprite through a 2x3 affine map onto a transparent (size, size) canvas."""
    scale = float(np.sqrt(abs(np.linalg.det(matrix[:, :2]))))
    if scale < 0.5:  # shrink first with area averaging, so thin lines fade instead of aliasing
        h, w = pm.shape[:2]
        small = cv2.resize(pm, (max(1, round(w * scale * 1.5)), max(1, round(h * scale * 1.5))),
                           interpolation=cv2.INTER_AREA)
        sx, sy = w / small.shape[1], h / small.shape[0]
        matrix = matrix @ np.array([[sx, 0, 0], [0, sy, 0], [0, 0, 1]], np.float64)
        pm = small
    return cv2.warpAffine(pm, matrix, (size, size), flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT,
                          borderValue=(0, 0, 0, 0))


def _affine(scale_x: float, scale_y: float, angle: float, src_centre, dst_centre, flip_x: bool,
            flip_y: bool) -> np.ndarray:
    """2x3 map: move ``src_centre`` to the origin, flip, scale, rotate, move to ``dst_centre``."""
    c, s = np.cos(angle), np.sin(angle)
    rot = np.array([[c, -s], [s, c]])
    lin = rot @ np.diag([scale_x * (-1 if flip_x else 1), scale_y * (-1 if flip_y else 1)])
    t = np.asarray(dst_centre, float) - lin @ np.asarray(src_centre, float)
    return np.hstack([lin, t[:, None]])


def frame_matrix(h: int, w: int, size: int, rng: np.random.Generator, margin=(-0.08, 0.3)) -> np.ndarray:
    """The sprite's own frame with random margins, stretched to (size, size)."""
    left, right = rng.uniform(*margin, 2) * w
    top, bottom = rng.uniform(*margin, 2) * h
    fw, fh = max(w + left + right, 2.0), max(h + top + bottom, 2.0)
    sx, sy = size / fw, size / fh
    flip = rng.random() < 0.5
    centre = (w / 2 + (right - left) / 2, h / 2 + (bottom - top) / 2)
    return _affine(sx, sy, 0.0, centre, (size / 2, size / 2), flip, False)


def placed_matrix(h: int, w: int, size: int, rng: np.random.Generator) -> np.ndarray:
    """Scaled, a little stretched, sometimes rotated, anywhere (sometimes partly outside)."""
    side = size * rng.uniform(0.25, 1.3)
    s = side / max(h, w)
    stretch = np.exp(rng.uniform(-0.3, 0.3))
    angle = rng.uniform(-0.5, 0.5) if rng.random() < 0.25 else 0.0
    half = 0.5 * side
    lo, hi = (-0.2 * half, size + 0.2 * half) if rng.random() < 0.3 else (min(half, size / 2), max(size - half, size / 2))
    centre = rng.uniform(lo, hi, 2)
    return _affine(s * stretch, s / stretch, angle, (w / 2, h / 2), centre, rng.random() < 0.5,
                   rng.random() < 0.05)


def background(size: int, rng: np.random.Generator) -> np.ndarray:
    """A training background: (size, size, 3) float32 in 0..255 (see :data:`TRAIN_BACKGROUNDS`)."""
    kinds = list(TRAIN_BACKGROUNDS)
    kind = kinds[rng.choice(len(kinds), p=np.array(list(TRAIN_BACKGROUNDS.values())) / sum(TRAIN_BACKGROUNDS.values()))]
    if kind == "noise":  # every scale from fine grain to large blotches
        return coarse_noise_background(size, size, rng, cell=float(np.exp(rng.uniform(np.log(1.5), np.log(64)))))
    return make_background(kind, size, size, rng)


def add_clutter(bg: np.ndarray, pool: list[np.ndarray], rng: np.random.Generator, n: int) -> np.ndarray:
    """Paste ``n`` random sprites from ``pool`` over the background (cut off by its edges like
    crops of an atlas page): art that is not the sprite to segment."""
    size = bg.shape[0]
    for _ in range(n):
        pm = premultiplied_float(pool[rng.integers(len(pool))])
        h, w = pm.shape[:2]
        m = placed_matrix(h, w, size, rng)
        # Clutter sits at the edges: move its centre near a random border.
        edge = rng.integers(4)
        m[edge % 2, 2] += (-1 if edge < 2 else 1) * size * rng.uniform(0.3, 0.6)
        layer = warp(pm, m, size)
        bg = layer[..., :3] * 255.0 + bg * (1.0 - layer[..., 3:4])
    return bg


def finish(img: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Photometric augmentations on the flattened (size, size, 3) float image: colour jitter,
    blur, sensor noise, JPEG. Returns uint8."""
    if rng.random() < 0.3:
        img = (img - 128.0) * rng.uniform(0.7, 1.3) + 128.0 + rng.uniform(-30, 30)
    if rng.random() < 0.1:
        img = cv2.GaussianBlur(img, (0, 0), rng.uniform(0.4, 1.2))
    if rng.random() < 0.1:
        img = img + rng.normal(0, rng.uniform(2, 10), img.shape).astype(np.float32)
    out = np.clip(img + 0.5, 0, 255).astype(np.uint8)
    if rng.random() < 0.3:
        ok, enc = cv2.imencode(".jpg", out, [cv2.IMWRITE_JPEG_QUALITY, int(rng.integers(30, 96))])
        out = cv2.imdecode(enc, cv2.IMREAD_UNCHANGED)
    return out


def training_sample(sprites: list[np.ndarray], i: int, size: int, rng: np.random.Generator
                    ) -> tuple[np.ndarray, np.ndarray]:
    """One augmented (image, mask) pair of sprite ``i`` (see the module notes).

    Returns
    -------
    image : ndarray, shape (size, size, 3), uint8, RGB
    mask : ndarray, shape (size, size), uint8 in {0, 1}
    """
    pm = premultiplied_float(sprites[i])
    h, w = pm.shape[:2]
    m = frame_matrix(h, w, size, rng) if rng.random() < 0.4 else placed_matrix(h, w, size, rng)
    layer = warp(pm, m, size)
    bg = background(size, rng)
    if rng.random() < 0.12:
        bg = add_clutter(bg, sprites, rng, int(rng.integers(1, 4)))
    img = layer[..., :3] * 255.0 + bg * (1.0 - layer[..., 3:4])
    return finish(img, rng), (layer[..., 3] > 128 / 255).astype(np.uint8)


def flat_sample(rgba: np.ndarray, kind: str, size: int, rng: np.random.Generator
                ) -> tuple[np.ndarray, np.ndarray]:
    """A sprite in its own frame flattened onto one background kind and resized to the input,
    as inference sees it (validation, int8 calibration): (size, size, 3) uint8, (size, size) uint8."""
    from ..foreground import alpha_mask
    from ..segment.composite import flatten

    rgb = flatten(rgba, kind, rng)
    mask = resize(alpha_mask(rgba).astype(np.float32), size, size) > 0.5
    return resize(rgb, size, size), mask.astype(np.uint8)


def normalise(x, mean=IMAGENET_MEAN, std=IMAGENET_STD):
    """uint8 NHWC or NCHW batch (torch) to ImageNet-normalised float NCHW (paper section 3.4)."""
    import torch

    if x.shape[-1] == 3:
        x = x.permute(0, 3, 1, 2)
    m = torch.as_tensor(mean, device=x.device).view(1, 3, 1, 1)
    s = torch.as_tensor(std, device=x.device).view(1, 3, 1, 1)
    return (x.float() / 255.0 - m) / s
