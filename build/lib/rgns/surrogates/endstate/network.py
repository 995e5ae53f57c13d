"""A small U-Net (Ronneberger et al. 2015) with a global context vector at its coarsest level.

Four levels of two 3 × 3 convolutions, average-pool down and bilinear up with skip connections:
on the default 160 × 40 lattice the coarsest level is 20 × 5 pixels, each seeing the whole slope
after the global mean is added back, since a point's fate depends on the slope as a whole.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn


class ConvBlock(nn.Module):
    """Two 3 × 3 convolutions with GELU."""

    def __init__(self, inputs: int, outputs: int):
        super().__init__()
        self.first = nn.Conv2d(inputs, outputs, 3, padding=1)
        self.second = nn.Conv2d(outputs, outputs, 3, padding=1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return F.gelu(self.second(F.gelu(self.first(x))))


class UNet(nn.Module):
    """Image [B, inputs, H, W] to image [B, outputs, H, W]."""

    def __init__(self, inputs: int, outputs: int, widths: tuple[int, ...] = (16, 32, 64, 96)):
        super().__init__()
        self.down = nn.ModuleList(
            [ConvBlock(inputs, widths[0])] + [ConvBlock(widths[k], widths[k + 1]) for k in range(len(widths) - 1)]
        )
        self.up = nn.ModuleList([ConvBlock(widths[k + 1] + widths[k], widths[k]) for k in range(len(widths) - 1)])
        self.context = nn.Linear(widths[-1], widths[-1])
        self.head = nn.Conv2d(widths[0], outputs, 1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        skips = []
        for level, block in enumerate(self.down):
            x = block(x if level == 0 else F.avg_pool2d(x, 2, ceil_mode=True))
            skips.append(x)
        x = x + self.context(x.mean(dim=(2, 3)))[:, :, None, None]
        for level in reversed(range(len(self.up))):
            x = F.interpolate(x, size=skips[level].shape[2:], mode="bilinear", align_corners=False)
            x = self.up[level](torch.cat([x, skips[level]], dim=1))
        return self.head(x)
