"""Output heads (paper section 3.1)."""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn

from .decoder import conv_bn_relu


class SegmentationHead(nn.Module):
    """Final 2x bilinear upsampling, Conv3x3-BN-ReLU and a 1x1 conv to one logit per pixel.

    Forward: (N, C, S/2, S/2) -> (N, 1, S, S) logits (apply a sigmoid for probabilities).
    """

    def __init__(self, cin: int):
        super().__init__()
        self.conv = conv_bn_relu(cin, cin)
        self.out = nn.Conv2d(cin, 1, 1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        x = F.interpolate(x, scale_factor=2.0, mode="bilinear", align_corners=False)
        return self.out(self.conv(x))
