"""The configuration of a navigation scenario: everything but the sensor errors.

:class:`ScenarioConfig` is shared by :mod:`rinscal.sim.scenario` (which runs it) and
:mod:`rinscal.sim.sensors` (whose plant follows its chamber, duration, rate and turntable).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from rinscal import _check
from rinscal.errors import ConfigError
from rinscal.nav.align import AlignConfig
from rinscal.nav.rotation import RotationSchedule
from rinscal.nav.strapdown import VerticalMode
from rinscal.sim.field import ChamberProfile
from rinscal.sim.trajectory import Trajectory

__all__ = ["ScenarioConfig"]


@dataclass(frozen=True)
class ScenarioConfig:
    """Everything that defines a navigation run except the sensor errors.

    Parameters
    ----------
    name : str
        Scenario name (free text; the presets use :data:`SCENARIOS`).
    trajectory : Trajectory
        Carrier motion.
    schedule : RotationSchedule
        Turntable schedule.
    duration_s : float [s]
        Length of the run from power-on.
    rate_hz : float [Hz]
        IMU output rate.
    align : AlignConfig or None
        Self-alignment from ``align.start_s`` to ``align.end_s`` after power-on (the
        carrier must stand still until then); None starts navigation from the true state
        at t = 0.
    chamber : ChamberProfile or None
        Ambient (chamber or cabin) temperature for the thermal plant; None: no thermal run.
    chunk_s : float [s]
        Processing chunk length (memory bound).
    out_dt_s : float [s]
        Interval of the reported errors.
    vertical : {"hold", "damped", "free"}
        Vertical channel of the INS; held or damped towards the true altitude (stand-in for
        an altimeter), which a marine or land RINS has.
    """

    name: str
    trajectory: Trajectory
    schedule: RotationSchedule
    duration_s: float
    rate_hz: float = 100.0
    align: AlignConfig | None = field(default_factory=AlignConfig)
    chamber: ChamberProfile | None = None
    chunk_s: float = 60.0
    out_dt_s: float = 1.0
    vertical: VerticalMode = "hold"

    def __post_init__(self) -> None:
        _check.text("name", self.name)
        if not callable(getattr(self.trajectory, "kinematics", None)):
            raise _check.wrong_type("trajectory", self.trajectory, "a carrier motion (Trajectory)")
        _check.instance("schedule", self.schedule, RotationSchedule, "a RotationSchedule")
        for name in ("duration_s", "rate_hz", "chunk_s", "out_dt_s"):
            _check.number(name, getattr(self, name))  # the ranges below
        _check.instance("align", self.align, AlignConfig, "an AlignConfig", optional=True)
        _check.instance("chamber", self.chamber, ChamberProfile, "a ChamberProfile", optional=True)
        _check.one_of("vertical", self.vertical, ("hold", "damped", "free"))
        if not (math.isfinite(self.duration_s) and self.duration_s > 0):
            raise ConfigError(f"scenario: duration_s must be > 0, got {self.duration_s}")
        if not (math.isfinite(self.rate_hz) and self.rate_hz > 0):
            raise ConfigError(f"scenario: rate_hz must be > 0, got {self.rate_hz}")
        if not (math.isfinite(self.chunk_s) and self.chunk_s > 0):
            raise ConfigError(f"scenario: chunk_s must be > 0, got {self.chunk_s}")
        out_every = self.out_dt_s * self.rate_hz
        if not (out_every >= 1 and abs(out_every - round(out_every)) < 1e-9):
            raise ConfigError(
                f"scenario: out_dt_s ({self.out_dt_s} s) must be a whole number of samples "
                f"at {self.rate_hz} Hz"
            )
        if self.align is not None:
            end = self.align.end_s
            if end >= self.duration_s:
                raise ConfigError(
                    f"scenario: alignment (start {self.align.start_s} s + "
                    f"{self.align.total_s} s) must end before the run ({self.duration_s} s)"
                )
            if end > self.trajectory.stationary_until + 1e-9:
                raise ConfigError(
                    f"scenario: the carrier moves at {self.trajectory.stationary_until} s, "
                    f"before the alignment ends at {end} s"
                )

    @property
    def dt(self) -> float:
        """Sample interval [s]."""
        return 1.0 / self.rate_hz

    @property
    def out_every(self) -> int:
        """Samples between reported errors."""
        return round(self.out_dt_s * self.rate_hz)

    @property
    def align_start_s(self) -> float:
        """Start of the alignment since power-on [s] (0 without alignment)."""
        return 0.0 if self.align is None else self.align.start_s

    @property
    def nav_start_s(self) -> float:
        """Start of free navigation since power-on [s]: alignment start + its length."""
        return 0.0 if self.align is None else self.align.end_s
