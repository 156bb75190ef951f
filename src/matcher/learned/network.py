"""The reference learned matcher's network: a siamese patch-feature CNN after MC-CNN-fast.

Žbontar and LeCun's fast architecture (JMLR 2016, §4.1): a stack of 3 x 3 convolutions with a
ReLU after each but the last, whose output at a pixel describes the ``patch x patch`` window
around it (``patch = layers * 2 + 1``); the features are L2-normalised, so the matching score of
a left and a right pixel is their cosine similarity. Both views go through the same weights.

The input is one grey channel standardised per image (zero mean, unit standard deviation over
the whole image, as MC-CNN does), so a gain and a bias between the views cancel out.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass
from typing import Any, ClassVar

import numpy as np
import torch
from torch import nn
from torch.nn import functional as F

from matcher._validation import rgb_to_grey
from matcher.learned.registry import MAX_WEIGHTS, Arch, Option

__all__ = ["ARCHITECTURE", "MAX_CHANNELS", "MAX_LAYERS", "MAX_WEIGHTS", "Architecture",
           "PatchNet", "check_architecture", "standardise"]

#: Name of the architecture in model files (:mod:`matcher.learned.registry`).
ARCHITECTURE = "mccnn-fast"
#: The limits of its options: feature maps per layer and layers (and :data:`MAX_WEIGHTS`, every
#: network's). Checked before a network is built, so a model header cannot size an allocation.
MAX_CHANNELS = 1024
MAX_LAYERS = 32


@dataclass(frozen=True)
class Architecture(Arch):
    """The shape of a :class:`PatchNet` (what a model file's header records).

    Attributes
    ----------
    channels : int
        Feature maps per layer (MC-CNN-fast: 64; ours 32 by default, see docs/learning.md).
    layers : int
        3 x 3 convolutions; the patch side is ``2 * layers + 1``, the halo ``layers``.
    """

    NAME: ClassVar[str] = ARCHITECTURE
    OPTIONS: ClassVar[tuple[Option, ...]] = (
        Option("channels", 32, 1, MAX_CHANNELS, "feature maps per layer"),
        Option("layers", 4, 1, MAX_LAYERS, "3x3 convolutions (patch side 2*layers+1)"),
    )

    channels: int = 32
    layers: int = 4

    @property
    def halo(self) -> int:
        return self.layers

    @property
    def features(self) -> int:
        return self.channels

    @property
    def weights(self) -> int:
        """Weights and biases of the network (3 x 3 kernels)."""
        c = self.channels
        return 10 * c + (self.layers - 1) * (9 * c * c + c)

    def describe(self) -> str:
        return f"{self.channels} maps x {self.layers} layers ({self.patch}x{self.patch} patches)"

    def to_dict(self) -> dict:
        return {"name": ARCHITECTURE, **asdict(self), "kernel": 3, "patch": self.patch}

    def network(self) -> PatchNet:
        return PatchNet(self)

    @classmethod
    def from_header(cls, record: Mapping[str, Any], *, where: str) -> Architecture:
        from stereoforge.errors import ParameterError

        if record.get("kernel", 3) != 3:
            raise ParameterError(f"{where}: a {ARCHITECTURE} variant this version does not read "
                                 f"(kernel {record.get('kernel')!r})")
        return super().from_header(record, where=where)  # type: ignore[return-value]


def check_architecture(channels: object, layers: object, *, where: str = "architecture"
                       ) -> Architecture:
    """The :class:`Architecture` of ``channels`` and ``layers`` within its limits
    (:data:`MAX_CHANNELS`, :data:`MAX_LAYERS`, :data:`MAX_WEIGHTS`); nothing is allocated
    (:meth:`Architecture.from_options`).

    Raises
    ------
    ParameterError
        Not integers, or out of the limit (the message names which).

    Examples
    --------
    >>> check_architecture(64, 4).weights
    111424
    >>> check_architecture(1024, 5)
    Traceback (most recent call last):
    ...
    stereoforge.errors.ParameterError: architecture: 1024 channels x 5 layers has 37,763,072 weights; at most 33,554,432 (use fewer channels or layers)
    """
    return Architecture.from_options({"channels": channels, "layers": layers},
                                     where=where)  # type: ignore[return-value]


class PatchNet(nn.Module):
    """Siamese feature tower: ``(N, 1, H, W)`` standardised grey -> ``(N, C, H - 2L, W - 2L)``
    unit feature vectors (valid convolutions: each output sees only pixels of its input)."""

    def __init__(self, arch: Architecture = Architecture()) -> None:
        super().__init__()
        self.arch = arch
        self.convs = nn.ModuleList(
            nn.Conv2d(1 if i == 0 else arch.channels, arch.channels, 3)
            for i in range(arch.layers))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        last = len(self.convs) - 1
        for i, conv in enumerate(self.convs):
            x = conv(x)
            if i < last:
                x = F.relu(x)
        return F.normalize(x, dim=1)


def standardise(image: np.ndarray) -> np.ndarray:
    """A view as the network's input: grey (BT.601 for RGB), float32, zero mean and unit
    standard deviation over the image (a constant image becomes all zeros).

    Parameters
    ----------
    image : (H, W) or (H, W, 3) array
        Checked by the caller (:func:`matcher._validation.check_image` returns grey already).

    Returns
    -------
    (H, W) float32 array

    Examples
    --------
    >>> import numpy as np
    >>> g = standardise(np.array([[0, 2], [4, 6]], np.uint8))
    >>> g.astype(np.float64).round(3).tolist(), float(standardise(np.full((2, 2), 7, np.uint8)).max())
    ([[-1.342, -0.447], [0.447, 1.342]], 0.0)
    """
    grey = rgb_to_grey(image) if image.ndim == 3 else image
    g = grey.astype(np.float64)
    g -= g.mean()
    std = g.std()
    if std > 1e-12:
        g /= std
    return g.astype(np.float32)
