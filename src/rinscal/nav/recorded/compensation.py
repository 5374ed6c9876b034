"""Causal compensation of a recording piece by piece: the protocol navigation calls.

The one compensator, :class:`rinscal.calibration.compensator.Compensator`, is what runs a
thermal model on a recording's pieces (its causal mode: the thermometers read once per
``update_s``, the bias held between readings, behind the model file's IMU calibration when it
holds one). ``CausalModelCompensator`` is its old name here, kept for one release.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np
from numpy.typing import NDArray

from rinscal.calibration.compensator import Compensator, forward_fill
from rinscal.schema import NavSamples

__all__ = [
    "CausalModelCompensator",
    "Compensator",
    "PieceCompensator",
]


class PieceCompensator(Protocol):
    """Causal compensation of a recording piece by piece: bias (n, 6) SI to subtract."""

    channels: tuple[str, ...]

    def __call__(self, s: NavSamples) -> NDArray[np.float64]: ...


#: The old name of :class:`~rinscal.calibration.compensator.Compensator` (its causal mode),
#: kept for one release.
CausalModelCompensator = Compensator

#: Forward fill of NaN readings (kept under its old private name for this package).
_ffill = forward_fill
