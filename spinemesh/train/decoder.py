"""U-Net decoder of paper section 3.1.

Four blocks, each: bilinear 2x upsampling, a 1x1 convolution to the block's width,
concatenation with the encoder skip of that resolution, then (Conv3x3-BN-ReLU) x 2.
Widths 1280 -> 256 -> 128 -> 64 -> 32.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn

#: Decoder widths of paper section 3.1.
DECODER_CHANNELS = (256, 128, 64, 32)


def conv_bn_relu(cin: int, cout: int, k: int = 3) -> nn.Sequential:
    return nn.Sequential(nn.Conv2d(cin, cout, k, padding=k // 2, bias=False),
                         nn.BatchNorm2d(cout), nn.ReLU(inplace=True))


class DecoderBlock(nn.Module):
    """Upsample x2, 1x1 conv to ``cout``, concatenate ``skip`` (``cskip`` channels), double conv."""

    def __init__(self, cin: int, cskip: int, cout: int):
        super().__init__()
        self.reduce = nn.Conv2d(cin, cout, 1)
        self.conv = nn.Sequential(conv_bn_relu(cout + cskip, cout), conv_bn_relu(cout, cout))

    def forward(self, x: torch.Tensor, skip: torch.Tensor) -> torch.Tensor:
        x = F.interpolate(x, size=skip.shape[-2:], mode="bilinear", align_corners=False)
        return self.conv(torch.cat([self.reduce(x), skip], dim=1))


class UNetDecoder(nn.Module):
    """U-Net decoder over encoder features at strides 2..32.

    Parameters
    ----------
    encoder_channels : tuple of 5 int
        Channels of the encoder's features, finest first (16, 24, 40, 112, 1280 for B0).
    channels : tuple of 4 int
        Decoder widths, coarsest first (paper: 256, 128, 64, 32).

    Forward
    -------
    feats : list of 5 tensors from the encoder
    returns : tensor, shape (N, channels[-1], S/2, S/2)
    """

    def __init__(self, encoder_channels: tuple[int, ...], channels: tuple[int, ...] = DECODER_CHANNELS):
        super().__init__()
        skips = list(encoder_channels[:-1])[::-1]  # 112, 40, 24, 16
        cin = encoder_channels[-1]
        blocks = []
        for cskip, cout in zip(skips, channels):
            blocks.append(DecoderBlock(cin, cskip, cout))
            cin = cout
        self.blocks = nn.ModuleList(blocks)
        self.out_channels = cin

    def forward(self, feats: list[torch.Tensor]) -> torch.Tensor:
        x = feats[-1]
        for block, skip in zip(self.blocks, feats[-2::-1]):
            x = block(x, skip)
        return x
