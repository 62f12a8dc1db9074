"""ONNX export of a trained checkpoint and static int8 quantisation.

Dynamic int8 quantisation in ONNX Runtime is 5-8x slower than fp32 on this network;
static quantisation (QDQ, per-channel weights, activations calibrated on real composites)
is faster than fp32 and loses little IoU. :func:`parity` measures both.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import torch

from ..files.atomic import atomic_write_files, utf8
from ..files.strict_json import strict_json
from ..segment import card_path
from ..segment.preprocess import IMAGENET_MEAN, IMAGENET_STD
from .decoder import DECODER_CHANNELS
from .model import SegmentationModel, build_model, read_checkpoint


def load_checkpoint(path: str | Path, image_size: int | None = None) -> SegmentationModel:
    """A float32 model in eval mode from a ``best.pt``/``last.pt`` written by the training loop.

    ``image_size`` builds it for another input side than it was trained at (a multiple of
    32: the network is fully convolutional and its static padding is the same for all of
    them), to trade accuracy for speed at inference.
    """
    return model_of(read_checkpoint(path), path, image_size)


def checkpoint_config(ckpt: dict, path: str | Path) -> dict:
    """The training config of ``ckpt`` (what :func:`~.model.read_checkpoint` read from ``path``),
    refused in one line naming ``path`` when it is no checkpoint of the training loop."""
    if not isinstance(ckpt.get("config"), dict) or not isinstance(ckpt.get("model"), dict):
        from ..errors import SpineMeshError

        raise SpineMeshError("not a checkpoint of `spinemesh train` (no model and config in it)", path)
    return ckpt["config"]


#: Most channels a checkpoint's decoder stage may have (the shipped model's largest is 256): the
#: network is built before its weights are compared, so a config of 100000 would ask for 360 GB.
MAX_DECODER_CHANNELS = 2048


def model_of(ckpt: dict, path: str | Path, image_size: int | None = None) -> SegmentationModel:
    """:func:`load_checkpoint` of a checkpoint already read from ``path`` (named by its errors).

    Raises
    ------
    SpineMeshError
        In one line naming ``path``, for a checkpoint this network cannot be made from: an
        ``image_size`` that is not a multiple of 32 (from 32 to the largest input a model card may
        say), another encoder or config, weights missing, extra or of other shapes (another
        architecture), or weights of NaN or infinity (a training run that diverged: its model
        masks nothing, and its parity of NaN read as 0).
    """
    from ..errors import SpineMeshError
    from ..segment import MAX_INPUT_SIZE
    from ..skeleton_check import is_int

    config = dict(checkpoint_config(ckpt, path), **({"image_size": image_size} if image_size else {}))
    side = config.get("image_size")
    if not is_int(side) or side % 32 or not 32 <= side <= MAX_INPUT_SIZE:
        raise SpineMeshError(f"the checkpoint's image_size is {side!r}, not a multiple of 32 from 32 to "
                             f"{MAX_INPUT_SIZE}", path)
    channels = config.get("decoder_channels", DECODER_CHANNELS)
    if not (isinstance(channels, (list, tuple)) and 1 <= len(channels) <= 8
            and all(is_int(c) and 1 <= c <= MAX_DECODER_CHANNELS
                    for c in channels)):  # 100000 channels asked torch for 360 GB
        raise SpineMeshError(f"the checkpoint's decoder_channels are {str(channels)[:100]}, not 1 to 8 counts "
                             f"from 1 to {MAX_DECODER_CHANNELS}", path)
    try:
        model = build_model(config)
    except (KeyError, ValueError, TypeError, RuntimeError) as e:
        raise SpineMeshError(f"not a checkpoint of spinemesh's network: its config makes none "
                             f"({type(e).__name__}: {str(e)[:200]})", path) from None
    weights, expected = ckpt["model"], model.state_dict()
    not_tensors = [k for k, v in weights.items() if not isinstance(v, torch.Tensor)]
    missing = [k for k in expected if k not in weights]
    extra = [k for k in weights if k not in expected]
    shaped = [k for k in expected if k in weights and k not in not_tensors
              and tuple(weights[k].shape) != tuple(expected[k].shape)]
    for names, what in ((not_tensors, "not tensors"), (missing, "missing"), (extra, "not in the network"),
                        (shaped, "of another shape than the network's")):
        if names:
            raise SpineMeshError(f"not a checkpoint of this network ({config.get('encoder')!r}, U-Net): "
                                 f"{len(names)} weight(s) {what}, the first {str(names[0])[:100]!r}", path)
    broken = [k for k, v in weights.items() if v.is_floating_point() and not bool(torch.isfinite(v).all())]
    if broken:
        raise SpineMeshError(f"{len(broken)} weight(s) of NaN or infinity, the first {broken[0]!r}: the "
                             "training diverged", path)
    model.load_state_dict({k: v.float() if v.is_floating_point() else v for k, v in weights.items()})
    return model.eval()


def export_onnx(model: SegmentationModel, out: str | Path, opset: int = 17) -> Path:
    """Write the model as ONNX with a fixed (1, 3, S, S) input ``image`` and output ``logits``.

    A batch of one is fixed so that ONNX Runtime can fold every shape; inference runs one
    image at a time.
    """
    model = model.eval()
    model.encoder.set_exportable()
    size = model.config["image_size"]
    x = torch.zeros(1, 3, size, size)
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    torch.onnx.export(model, (x,), str(out), input_names=["image"], output_names=["logits"],
                      opset_version=opset, dynamo=False)
    return out


class _Calibration:
    """Feeds calibration inputs to ONNX Runtime's static quantiser."""

    def __init__(self, inputs: list[np.ndarray], name: str = "image"):
        self._it = iter([{name: x[None].astype(np.float32)} for x in inputs])

    def get_next(self):
        return next(self._it, None)


def quantize_int8(fp32: str | Path, out: str | Path, calibration: list[np.ndarray]) -> Path:
    """Static int8 (QDQ, per-channel weights, unsigned activations) calibrated on ``calibration``.

    Parameters
    ----------
    fp32 : path
        The exported fp32 model.
    out : path
        Where to write the int8 model.
    calibration : list of ndarray, each (3, S, S) float32
        Preprocessed model inputs; a hundred or so composites of training sprites.
    """
    from onnxruntime.quantization import CalibrationMethod, QuantFormat, QuantType, quantize_static
    from onnxruntime.quantization.shape_inference import quant_pre_process

    prep = Path(out).with_suffix(".prep.onnx")
    quant_pre_process(str(fp32), str(prep))
    try:
        quantize_static(str(prep), str(out), _Calibration(calibration), quant_format=QuantFormat.QDQ,
                        per_channel=True, activation_type=QuantType.QUInt8, weight_type=QuantType.QInt8,
                        calibrate_method=CalibrationMethod.MinMax)
    finally:
        prep.unlink(missing_ok=True)
    return Path(out)


@torch.no_grad()
def parity(model: SegmentationModel, onnx_path: str | Path, inputs: list[np.ndarray]) -> dict[str, float]:
    """How far ONNX Runtime's output is from torch's on the same inputs.

    Returns the largest absolute logit difference, and the mean fraction of pixels whose
    thresholded mask differs.
    """
    from ..segment import onnx_runtime

    sess = onnx_runtime().InferenceSession(str(onnx_path), providers=["CPUExecutionProvider"])
    worst, flips = 0.0, []
    for x in inputs:
        ref = model(torch.from_numpy(x[None])).numpy()
        got = sess.run(None, {"image": x[None].astype(np.float32)})[0]
        worst = float(np.max([worst, np.abs(ref - got).max()]))  # a NaN stays one (max() kept 0 over it)
        flips.append(float(((ref > 0) != (got > 0)).mean()))
    return {"max_abs_logit_diff": worst, "mask_pixels_differing": float(np.mean(flips))}


def card_of(model: SegmentationModel, extra: dict) -> dict:
    """The JSON model card the inference side reads (input size, normalisation, threshold),
    with ``extra`` (precision, parity, training figures) added."""
    card = {
        "format": "onnx",
        "input": "image", "output": "logits",
        "input_size": model.config["image_size"],
        "layout": "NCHW, RGB, 0..1 then (x - mean) / std",
        "mean": IMAGENET_MEAN.tolist(), "std": IMAGENET_STD.tolist(),
        "threshold": 0.5,
        "resize": "stretch to input_size (area when shrinking), output resized back bilinearly",
        "architecture": {"encoder": model.config["encoder"], "decoder": "U-Net",
                         "decoder_channels": model.config["decoder_channels"],
                         "parameters": int(sum(p.numel() for p in model.parameters()))},
        "training_data": "sprites of data sets made by `spinemesh dataset` (no data ships)",
    }
    card.update(extra)
    return card


def release(checkpoint: str | Path, out: str | Path, calibration: list[np.ndarray], check: list[np.ndarray],
            int8: bool = True, image_size: int | None = None, read: dict | None = None,
            model: SegmentationModel | None = None) -> dict:
    """Export a checkpoint as the model that ships: ONNX (static int8 or fp32) plus its card.

    The fp32 export and the int8 model are made in a temporary folder, removed whatever ends
    the run; the model and its card are then written together, each atomically (both or
    neither): no file beside ``out`` is made or replaced but those two.

    Parameters
    ----------
    checkpoint : path
        ``best.pt`` from the training loop.
    out : path
        The ``.onnx`` to write; the card goes beside it as ``.json``
        (:func:`spinemesh.segment.card_path`).
    calibration : list of (3, S, S) float32
        Inputs to calibrate int8 activations on (training composites).
    check : list of (3, S, S) float32
        Inputs to measure torch/ONNX parity on (held-out composites).
    int8 : bool
        Quantise (default) or ship fp32.
    image_size : int, optional
        Input side of the exported model (default: the training side).
    read : dict, optional
        What :func:`~.model.read_checkpoint` read from ``checkpoint``, when the caller read it
        already (it is read here otherwise: once either way).
    model : SegmentationModel, optional
        :func:`model_of` of ``read``, ``checkpoint`` and ``image_size``, when the caller made it
        already (made here otherwise: built and checked once either way).

    Returns
    -------
    dict
        The card written.

    Raises
    ------
    SpineMeshError
        When the card would hold a non-finite number (a parity of NaN: a checkpoint whose
        weights diverged); nothing is written then.
    OutputError
        When the file system refuses either file; neither is written then.
    """
    import tempfile

    out = Path(out)
    ckpt = read if read is not None else read_checkpoint(checkpoint)
    model = model if model is not None else model_of(ckpt, checkpoint, image_size)
    with tempfile.TemporaryDirectory(prefix="spinemesh-export-") as work:
        fp32 = export_onnx(model, Path(work) / "model.fp32.onnx")
        extra = {"precision": "int8" if int8 else "fp32",
                 "parity_fp32": parity(model, fp32, check),
                 "training": {"best_epoch": ckpt.get("metrics"),
                              **(ckpt["meta"] if isinstance(ckpt.get("meta"), dict) else {})}}
        made = fp32
        if int8:
            made = quantize_int8(fp32, Path(work) / "model.int8.onnx", calibration)
            extra["parity_int8"] = parity(model, made, check)
            extra["quantisation"] = "static QDQ, per-channel int8 weights, uint8 activations, MinMax calibration"
        data = made.read_bytes()
    extra["size_bytes"] = len(data)
    card = card_of(model, extra)
    card_file = card_path(out)
    atomic_write_files({out: data, card_file: utf8(strict_json(card, 1, card_file) + "\n", card_file)})
    return json.loads(card_file.read_text("utf-8"))
