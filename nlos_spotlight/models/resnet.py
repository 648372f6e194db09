"""A compact ResNet-18 feature extractor (He et al., "Deep Residual Learning for Image Recognition", CVPR 2016).

torchvision's wheel does not load with the CPU build of torch used here, so the 18-layer network is
written out: a stem, four stages of two BasicBlocks (64, 128, 256, 512 channels, stride 2 from the
second stage), global average pooling. Layer for layer it equals ``torchvision.models.resnet18`` minus
its classifier (11,176,512 parameters with the ImageNet stem). For the small images of NLOS captures
(32-64 pixels) the ``cifar`` stem (3x3 convolution, stride 1, no max-pool) keeps spatial detail.

Shapes:
    images (B, C, H, W) -> features (B, 512).
"""

from __future__ import annotations

import torch
from torch import nn


STEM_STRIDE = {"cifar": 1, "half": 2}
"""Stride of the single 3x3 convolution of the small-image stems."""


class BasicBlock(nn.Module):
    """y = relu(bn(conv(relu(bn(conv(x))))) + shortcut(x))."""

    def __init__(self, cin: int, cout: int, stride: int = 1):
        super().__init__()
        self.conv1 = nn.Conv2d(cin, cout, 3, stride, 1, bias=False)
        self.bn1 = nn.BatchNorm2d(cout)
        self.conv2 = nn.Conv2d(cout, cout, 3, 1, 1, bias=False)
        self.bn2 = nn.BatchNorm2d(cout)
        self.down = None
        if stride != 1 or cin != cout:
            self.down = nn.Sequential(nn.Conv2d(cin, cout, 1, stride, bias=False), nn.BatchNorm2d(cout))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        out = torch.relu(self.bn1(self.conv1(x)))
        out = self.bn2(self.conv2(out))
        return torch.relu(out + (x if self.down is None else self.down(x)))


class ResNet(nn.Module):
    """A ResNet feature extractor: stem, stages of BasicBlocks (stride 2 from the second stage), pooling.

    Args:
        in_channels: input channels.
        stem: 'cifar' (3x3, stride 1), 'half' (3x3, stride 2) or 'imagenet' (7x7 stride 2 + max-pool).
        widths: channels of each stage.
        blocks: BasicBlocks per stage.
        pool_grid: 1 pools globally (the classic ResNet); g > 1 averages the last feature map to g x g
            cells and flattens them, so the heads still see where in the frame the light fell.
    """

    def __init__(self, in_channels: int = 3, stem: str = "cifar", widths=(64, 128, 256, 512), blocks=(2, 2, 2, 2),
                 pool_grid: int = 1):
        super().__init__()
        w0 = widths[0]
        conv = lambda k, stride: nn.Conv2d(in_channels, w0, k, stride, k // 2, bias=False)
        if stem == "imagenet":
            self.stem = nn.Sequential(conv(7, 2), nn.BatchNorm2d(w0), nn.ReLU(), nn.MaxPool2d(3, 2, 1))
        elif stem in STEM_STRIDE:
            self.stem = nn.Sequential(conv(3, STEM_STRIDE[stem]), nn.BatchNorm2d(w0), nn.ReLU())
        else:
            raise ValueError(f"stem must be one of imagenet, {', '.join(STEM_STRIDE)}; got {stem!r}")
        if pool_grid < 1:
            raise ValueError(f"pool_grid must be at least 1, got {pool_grid}")
        stages, cin = [], w0
        for i, (cout, n) in enumerate(zip(widths, blocks)):
            stride = 1 if i == 0 else 2
            stages.append(nn.Sequential(BasicBlock(cin, cout, stride), *[BasicBlock(cout, cout) for _ in range(n - 1)]))
            cin = cout
        self.stages = nn.Sequential(*stages)
        self.pool = nn.Sequential(nn.AdaptiveAvgPool2d(pool_grid), nn.Flatten())
        self.out_features = widths[-1] * pool_grid**2
        self.reset_parameters()

    def reset_parameters(self) -> None:
        for m in self.modules():
            if isinstance(m, nn.Conv2d):
                nn.init.kaiming_normal_(m.weight, mode="fan_out", nonlinearity="relu")
            elif isinstance(m, nn.BatchNorm2d):
                nn.init.ones_(m.weight)
                nn.init.zeros_(m.bias)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.pool(self.stages(self.stem(x)))


class ResNet18(ResNet):
    """ResNet-18 without its classifier (see module docstring)."""

    out_features = 512

    def __init__(self, in_channels: int = 3, stem: str = "cifar"):
        super().__init__(in_channels, stem)


BACKBONES = {
    "resnet18": dict(widths=(64, 128, 256, 512), blocks=(2, 2, 2, 2)),
    "resnet10-narrow": dict(widths=(32, 64, 128, 256), blocks=(1, 1, 1, 1)),
}
"""Backbone name -> ResNet widths and blocks. 'resnet10-narrow' (one block per stage at half width,
1.2 M parameters against 11.2 M) is the lighter network the learning-curve sweeps train on CPU."""


def backbone(name: str, in_channels: int, stem: str, pool_grid: int = 1) -> ResNet:
    """A backbone of :data:`BACKBONES` by name."""
    if name not in BACKBONES:
        raise ValueError(f"backbone must be one of {', '.join(BACKBONES)}, got {name!r}")
    return ResNet(in_channels, stem, pool_grid=pool_grid, **BACKBONES[name])
