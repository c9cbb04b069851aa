"""The tangle CNN's layers: AlexNet's shape (paper Fig. 4), shrunk to run in milliseconds on a CPU.

conv1 (7x7, stride 4) - pool1 - conv2 (5x5) - pool2 - conv3 - conv4 - conv5 (3x3) - pool3 -
fc1 - fc2 - fc3 -> one logit per class of the model's objective (:mod:`.objectives`; the
tangle CNN's two: index 0 *not tangled*, 1 *tangled*, the dataset's label). Every
convolution is batch-normalised (which AlexNet predates); every layer but the
last is followed by a ReLU; weights start from He (Kaiming) initialisation; pools are 2x2
max-pools; the hidden fully connected layers have dropout. With the defaults (96 px input) it
has about 270 k parameters (1.1 MB of float32), and five candidates take a few milliseconds on
one CPU core (``tools/bench_cnn.py``).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import torch
from torch import nn

_CONV1 = {"kernel_size": 7, "stride": 4, "padding": 3}
_CONV2 = {"kernel_size": 5, "padding": 2}
_CONV345 = {"kernel_size": 3, "padding": 1}


@dataclass(frozen=True)
class NetworkConfig:
    """Sizes of the network; stored in every checkpoint so the weights can be rebuilt."""

    input_size: int = 96
    """Side of the square crop, pixels (the crop spec's ``size_px``)."""
    input_channels: int = 1
    """Channels of the input: the heights, and the target mask when the normalisation has
    one (``Normalisation.channels``)."""
    channels: tuple[int, int, int, int, int] = (16, 32, 64, 64, 64)
    """Output channels of conv1..conv5."""
    hidden: tuple[int, int] = (256, 64)
    """Widths of fc1 and fc2 (fc3 has one output per class)."""
    dropout: float = 0.5
    """Dropout probability after fc1 and fc2 (training only)."""
    classes: int = 2
    """Outputs of fc3: the objective's classes (2; 3 for the pick-outcome model)."""

    def __post_init__(self) -> None:
        if len(self.channels) != 5 or len(self.hidden) != 2:
            raise ValueError("NetworkConfig needs 5 channel counts and 2 hidden widths")
        if min(*self.channels, *self.hidden, self.input_channels) < 1:
            raise ValueError("NetworkConfig channel counts and widths must be positive")
        if self.classes < 2:
            raise ValueError(f"NetworkConfig.classes must be at least 2, got {self.classes}")
        if not 0 <= self.dropout < 1:
            raise ValueError(f"NetworkConfig.dropout must be in [0, 1), got {self.dropout}")
        if self.final_side() < 1:
            raise ValueError(f"NetworkConfig.input_size {self.input_size} is too small: "
                             "the crop must be at least 29 pixels square")

    def final_side(self) -> int:
        """Side of conv5's feature map after pool3: stride-4 conv1, then three halvings."""
        side = (self.input_size + 2 * _CONV1["padding"] - _CONV1["kernel_size"]) \
            // _CONV1["stride"] + 1
        return side // 8

    def to_dict(self) -> dict:
        """Plain lists and numbers, for JSON logs and ``weights_only`` checkpoints."""
        return {key: list(value) if isinstance(value, tuple) else value
                for key, value in asdict(self).items()}

    @staticmethod
    def from_dict(data: dict) -> NetworkConfig:
        """Inverse of :meth:`to_dict`; raises ``TypeError``/``ValueError`` on a bad config."""
        return NetworkConfig(**{key: tuple(value) if isinstance(value, list) else value
                                for key, value in data.items()})


class TangleNet(nn.Module):
    """Network input (N, C, S, S) -> class logits (N, classes); class 0 the good outcome."""

    def __init__(self, config: NetworkConfig = NetworkConfig()) -> None:
        super().__init__()
        self.config = config
        c1, c2, c3, c4, c5 = config.channels
        h1, h2 = config.hidden
        self.features = nn.Sequential(
            *_conv(config.input_channels, c1, _CONV1), nn.MaxPool2d(2),
            *_conv(c1, c2, _CONV2), nn.MaxPool2d(2),
            *_conv(c2, c3, _CONV345),
            *_conv(c3, c4, _CONV345),
            *_conv(c4, c5, _CONV345), nn.MaxPool2d(2),
            nn.Flatten(),
        )
        self.classifier = nn.Sequential(
            nn.Linear(c5 * config.final_side() ** 2, h1), nn.ReLU(), nn.Dropout(config.dropout),
            nn.Linear(h1, h2), nn.ReLU(), nn.Dropout(config.dropout),
            nn.Linear(h2, config.classes),
        )
        for module in self.modules():
            if isinstance(module, nn.Conv2d | nn.Linear):
                nn.init.kaiming_normal_(module.weight, nonlinearity="relu")
                if module.bias is not None:
                    nn.init.zeros_(module.bias)
        # Channels-last tensors make oneDNN's convolutions and pools faster on a CPU.
        self.to(memory_format=torch.channels_last)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.classifier(self.features(x.contiguous(memory_format=torch.channels_last)))


def _conv(inputs: int, outputs: int, shape: dict) -> tuple[nn.Module, ...]:
    """Convolution, batch normalisation, ReLU: without the normalisation (and with PyTorch's
    default initialisation) the differences between crops all but vanished on their way through
    the eight layers, and the network learned nothing from real data."""
    return nn.Conv2d(inputs, outputs, bias=False, **shape), nn.BatchNorm2d(outputs), nn.ReLU()


def parameter_count(network: nn.Module) -> int:
    return sum(p.numel() for p in network.parameters())
