"""Foreground masks for sprites, from their alpha or from the shipped network.

Paper section 3.1 has two mask paths: threshold the alpha at 128 when the image has a
meaningful alpha channel, else run the segmentation network. This package holds the
torch-free side: :func:`predict_mask` runs the shipped ONNX model with ONNX Runtime,
:func:`has_meaningful_alpha` decides between the paths, and :func:`mask_for` applies the
``--mask alpha|model|auto`` choice. Training lives in :mod:`spinemesh.train` (needs torch).

ONNX Runtime is imported on first use, so meshing images with alpha never loads it.
"""

from __future__ import annotations

import json
import os
from functools import lru_cache
from pathlib import Path

import cv2
import numpy as np

from ..errors import ImageError, SpineMeshError
from ..foreground import ALPHA_THRESHOLD, alpha_mask
from ..skeleton_check import is_int, is_number
from .preprocess import from_output, to_input

#: Masks modes of ``--mask``: always alpha, always the network, or alpha when meaningful.
MASK_MODES = ("alpha", "model", "auto")

#: The model that ships with the package, and its card (input size, normalisation, threshold).
MODELS_DIR = Path(__file__).resolve().parent.parent / "models"
DEFAULT_MODEL = MODELS_DIR / "segment.onnx"


class ModelError(SpineMeshError):
    """The segmentation model file is missing or unreadable."""


#: Largest square input side a model card may ask for (the shipped model takes 224): one image
#: at that side is a bounded allocation, whatever a card from elsewhere says.
MAX_INPUT_SIZE = 2048


def card_path(model_path: str | Path | None = None) -> Path:
    """Where the card of a model lies: beside it, ``<model>.json`` (the shipped model's by default)."""
    return Path(model_path or DEFAULT_MODEL).with_suffix(".json")


def model_files(model_path: str | Path | None = None) -> list[Path]:
    """The files a command reads for a model (the shipped one by default): the ``.onnx`` and its
    card, which no output may replace."""
    return [Path(model_path or DEFAULT_MODEL), card_path(model_path)]


def model_card(model_path: str | Path | None = None) -> dict:
    """The JSON card beside a model (``<model>.json``): input size, mean, std, threshold, figures.

    Raises
    ------
    ModelError
        Naming the card, when it is missing or unreadable, or what inference reads from it
        (``input_size``, ``threshold``, ``inference``) is not what our models' cards hold.
    """
    from ..limits import check_file_size

    path = card_path(model_path)
    if os.path.lexists(path):  # a FIFO waited for ever, a link to /dev/zero filled the memory
        check_file_size(path, "model card")
    try:
        card = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ModelError("model card not found (it must sit beside the .onnx file)", path) from None
    except (OSError, ValueError) as e:
        raise ModelError(f"unreadable model card: {e}", path) from None
    if not isinstance(card, dict):
        raise ModelError(f"the model card is a JSON {type(card).__name__}, not an object of spinemesh's fields", path)
    size, threshold = card.get("input_size"), card.get("threshold", 0.5)
    if not is_int(size) or not 16 <= size <= MAX_INPUT_SIZE:
        raise ModelError(f"the model card's input_size is {size!r}, not a side in pixels from 16 to "
                         f"{MAX_INPUT_SIZE}", path)
    if not is_number(threshold) or not 0 < threshold < 1:
        raise ModelError(f"the model card's threshold is {threshold!r}, not a probability between 0 and 1", path)
    inference = card.get("inference", {})
    if not isinstance(inference, dict) or not all(isinstance(inference.get(k, False), bool)
                                                  for k in ("flips", "floodfill")):
        raise ModelError("the model card's inference is not an object whose flips and floodfill are true or false",
                         path)
    return card


def onnx_runtime():
    """The ``onnxruntime`` module, imported with its telemetry turned off.

    ONNX Runtime's wheels (1.32 here) collect usage telemetry on Linux too: loading a model wrote
    a device id and a telemetry database of about 900 KB under ``~/.cache/Microsoft/DeveloperTools``
    (making ``HOME`` where it did not exist) and, a few seconds into a run, looked up its
    collector's address on the network (spinemesh uses no network at run time). Its
    ``ORT_DISABLE_TELEMETRY`` turns all of it off, read once, when the module is first imported;
    ``disable_telemetry_events()`` does not. Every import of it in spinemesh goes through here.
    """
    os.environ["ORT_DISABLE_TELEMETRY"] = "1"
    import onnxruntime

    return onnxruntime


@lru_cache(maxsize=4)
def _session(model_path: str, threads: int):
    ort = onnx_runtime()

    from ..files.inputs import regular_file

    if not os.path.lexists(model_path):
        raise ModelError("segmentation model not found", model_path)
    regular_file(model_path, "segmentation model")  # a FIFO or device: said so, never read
    opts = ort.SessionOptions()
    if threads:
        opts.intra_op_num_threads = threads
    try:
        return ort.InferenceSession(model_path, opts, providers=["CPUExecutionProvider"])
    except Exception as e:  # onnxruntime raises its own exception types
        raise ModelError(f"cannot load ONNX model: {e}", model_path) from None


def predict_proba(rgb: np.ndarray, model_path: str | Path | None = None, threads: int = 0,
                  flips: bool = False) -> np.ndarray:
    """Foreground probability at model size.

    Parameters
    ----------
    rgb : ndarray, shape (H, W, 3) or (H, W, 4), uint8
        The image; a fourth channel is ignored.
    model_path : path, optional
        An ONNX model with its card beside it (default: the shipped one).
    threads : int
        ONNX Runtime intra-op threads (0: its default, all cores).
    flips : bool
        Test-time augmentation: also run the mirrored image and average (twice the time).

    Returns
    -------
    ndarray, shape (S, S), float32 in 0..1, S the model's input side.
    """
    path = str(model_path or DEFAULT_MODEL)
    size = int(model_card(path)["input_size"])
    sess = _session(path, threads)
    name = sess.get_inputs()[0].name
    x = to_input(rgb[..., :3], size)[None]
    logits = _logits(sess, name, x, path)
    if flips:
        mirrored = _logits(sess, name, np.ascontiguousarray(x[..., ::-1]), path)
        logits = 0.5 * (logits + mirrored[:, ::-1])
    return (1.0 / (1.0 + np.exp(-logits))).astype(np.float32)


def _logits(sess, name: str, x: np.ndarray, path: str) -> np.ndarray:
    """The model's logits for one input ``x`` (1, 3, S, S), as an (S, S) array; a model that
    does not take it or gives another shape (not one of ours, or its card is another's) is refused."""
    size = x.shape[-1]
    try:
        out = sess.run(None, {name: x})[0]
    except Exception as e:  # onnxruntime raises its own exception types
        first = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise ModelError(f"the model does not take the 1x3x{size}x{size} image its card says ({first})",
                         path) from None
    out = np.asarray(out)
    if out.ndim != 4 or out.shape[:2] != (1, 1) or out.shape[2:] != (size, size):
        raise ModelError(f"the model gives an output of shape {tuple(out.shape)}, not the 1x1x{size}x{size} "
                         "logits of spinemesh's segmentation models", path)
    if not np.isfinite(out).all():  # NaN > threshold is False: an empty mask, said as "the art looks empty"
        raise ModelError("the model gives logits of NaN or infinity (weights of a training run that "
                         "diverged?): it masks nothing", path)
    return out[0, 0]


def combine_with_floodfill(prob: np.ndarray, rgb: np.ndarray, unsure: float = 0.25,
                           min_agreement: float = 0.8) -> np.ndarray | None:
    """Where the network is unsure and the background is flat, the border flood fill decides.

    The background counts as flat when the flood fill from the border reaches at least 90 %
    of the border and its foreground agrees with the network's (IoU at least
    ``min_agreement``): then the two differ only along the outline. Every pixel whose
    probability is within ``unsure`` of 0.5 takes the flood fill's answer.

    Parameters
    ----------
    prob : ndarray, shape (H, W), float32
        The network's probabilities at the image's size.
    rgb : ndarray, shape (H, W, 3), uint8

    Returns
    -------
    ndarray, shape (H, W), bool, or None when the background is not flat.
    """
    from .baseline import floodfill_mask

    fill = floodfill_mask(rgb)
    border = np.concatenate([fill[0], fill[-1], fill[:, 0], fill[:, -1]])
    if border.mean() > 0.1:
        return None
    net = prob > 0.5
    union = np.logical_or(fill, net).sum()
    if union == 0 or np.logical_and(fill, net).sum() / union < min_agreement:
        return None
    return np.where(np.abs(prob - 0.5) >= unsure, net, fill)


def predict_mask(rgb: np.ndarray, model_path: str | Path | None = None, threshold: float | None = None,
                 threads: int = 0, flips: bool | None = None, floodfill: bool | None = None) -> np.ndarray:
    """Binary foreground mask of an image without (meaningful) alpha, by the network.

    The image is resized to the model's square input (area filter, so thin lines fade
    rather than vanish), the probabilities are resized back bilinearly and thresholded
    (paper section 3.1: 0.5, or the model card's value).

    Parameters
    ----------
    rgb : ndarray, shape (H, W, 3) or (H, W, 4), uint8
    model_path : path, optional
        Default: the model shipped in ``spinemesh/models/segment.onnx``.
    threshold : float, optional
        Probability threshold (default: the model card's).
    threads : int
        ONNX Runtime threads (0: all cores).
    flips : bool, optional
        Average with the mirrored image (default: the model card's ``inference.flips``).
    floodfill : bool, optional
        :func:`combine_with_floodfill` (default: the model card's ``inference.floodfill``).

    Returns
    -------
    ndarray, shape (H, W), bool
    """
    if rgb.ndim != 3 or rgb.shape[2] not in (3, 4) or rgb.dtype != np.uint8:
        raise ValueError(f"expected an (H, W, 3|4) uint8 image, got {rgb.shape} {rgb.dtype}")
    card = model_card(model_path)
    options = card.get("inference", {})
    t = card.get("threshold", 0.5) if threshold is None else threshold
    flips = options.get("flips", False) if flips is None else flips
    floodfill = options.get("floodfill", False) if floodfill is None else floodfill
    prob = predict_proba(rgb, model_path, threads, flips)
    h, w = rgb.shape[:2]
    if floodfill:
        full = cv2.resize(prob, (w, h), interpolation=cv2.INTER_LINEAR)
        combined = combine_with_floodfill(full, np.ascontiguousarray(rgb[..., :3]))
        if combined is not None:
            return combined
        return full > t
    return from_output(prob, h, w, t)


def looks_empty(mask: np.ndarray, rgb: np.ndarray, min_fraction: float = 0.001) -> bool:
    """Whether a mask is (nearly) empty although the image visibly holds something.

    An image holds something when its colours are not (nearly) uniform: some pixel differs
    from the median colour by more than 24 levels.
    """
    if mask.mean() >= min_fraction:
        return False
    diff = np.abs(rgb[..., :3].astype(np.int16) - np.median(rgb[..., :3].reshape(-1, 3), axis=0)).max()
    return bool(diff > 24)


def has_meaningful_alpha(rgba: np.ndarray, threshold: int = ALPHA_THRESHOLD, min_fraction: float = 0.001) -> bool:
    """Whether the alpha channel separates a sprite from its background (paper section 3.1).

    It does not when the image has no alpha channel, when it is (nearly) uniformly opaque,
    or when it is (nearly) uniformly transparent (an export that lost its alpha).

    Parameters
    ----------
    rgba : ndarray, shape (H, W, C), uint8
    threshold : int
        Alpha above this is foreground (section 3.1: 128).
    min_fraction : float
        Both foreground and background must cover at least this fraction of the pixels
        (default 0.1%: a few stray edge pixels do not count as an alpha channel).
    """
    if rgba.ndim != 3 or rgba.shape[2] < 4 or rgba.size == 0:
        return False
    fg = np.count_nonzero(alpha_mask(rgba, threshold)) / (rgba.shape[0] * rgba.shape[1])  # = mean, without a float pass
    return min_fraction <= fg <= 1.0 - min_fraction


def mask_for(rgba: np.ndarray, mode: str = "auto", model_path: str | Path | None = None,
             threads: int = 0) -> tuple[np.ndarray, str]:
    """The mask ``--mask`` asks for, and which path made it.

    Parameters
    ----------
    rgba : ndarray, shape (H, W, 3) or (H, W, 4), uint8
    mode : {"alpha", "model", "auto"}
        ``alpha``: threshold alpha at 128 (an image without alpha is all foreground);
        ``model``: the network; ``auto``: alpha when :func:`has_meaningful_alpha`, else the network.

    Returns
    -------
    mask : ndarray, shape (H, W), bool
    used : {"alpha", "model"}
    """
    if mode not in MASK_MODES:
        raise ValueError(f"mask mode must be one of {MASK_MODES}, got {mode!r}")
    if mode == "alpha" or (mode == "auto" and has_meaningful_alpha(rgba)):
        if rgba.ndim == 3 and rgba.shape[2] == 4:
            return alpha_mask(rgba), "alpha"
        return np.ones(rgba.shape[:2], bool), "alpha"
    return predict_mask(rgba, model_path, threads=threads), "model"


__all__ = ["MASK_MODES", "DEFAULT_MODEL", "ModelError", "ImageError", "model_card", "onnx_runtime", "predict_proba",
           "predict_mask", "combine_with_floodfill", "looks_empty", "has_meaningful_alpha", "mask_for"]
