"""How the reports, the CLI and the fleet quote the Allan noise terms: the units of a data
sheet (a gyro's angle random walk in °/√h, an accelerometer's velocity random walk in µg/√Hz)
and the words, one convention everywhere. The slope reading itself is in
:mod:`rinscal.calibration.allan` (``N`` [u·√s], ``B`` [u], ``K`` [u/√s], ``u`` the log's
unit)."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["NOISE_TERMS_WORDS", "DatasheetUnits", "datasheet_units"]

#: The slope reading's three terms in words, as every report and the CLI name them.
NOISE_TERMS_WORDS = (
    "N, the angle random walk of a gyro [°/√h] or the velocity random walk of an "
    "accelerometer [µg/√Hz] (σ at τ = 1 s on the −½ line); B, the bias instability [°/h, "
    "µg] (the flat minimum ÷ 0.664, at τ(B)); K, the rate random walk [°/h/√h, µg/√s] (σ "
    "at τ = 3 s on the +½ line)"
)


@dataclass(frozen=True)
class DatasheetUnits:
    """How a data sheet quotes the Allan terms of a channel logged in some unit: each
    term's unit and the factor from the slope reading's unit to it (``N`` [u·√s] times
    ``n_factor`` is in ``n_unit``; ``K`` [u/√s] times ``k_factor`` is in ``k_unit``; ``B``
    keeps the log unit)."""

    n_unit: str
    n_factor: float
    b_unit: str
    k_unit: str
    k_factor: float


def datasheet_units(unit: str) -> DatasheetUnits:
    """The data-sheet units of the Allan terms of a channel logged in ``unit``.

    Gyros in deg/h: N in °/√h (deg/h·√s ÷ 60), B in °/h, K in °/h/√h (deg/h/√s × 60).
    Accelerometers in µg: N in µg/√Hz (numerically µg·√s), B in µg, K in µg/√s. Any other
    unit ``u`` keeps the slope reading's own: N [u·√s], B [u], K [u/√s].
    """
    if unit in ("deg/h", "°/h"):
        return DatasheetUnits("°/√h", 1.0 / 60.0, "°/h", "°/h/√h", 60.0)
    if unit in ("ug", "µg"):
        return DatasheetUnits("µg/√Hz", 1.0, "µg", "µg/√s", 1.0)
    u = unit or "unit"
    return DatasheetUnits(f"{u}·√s", 1.0, u, f"{u}/√s", 1.0)
