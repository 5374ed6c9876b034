"""The reproduction's settings: the methods and their labels, the paper's headline numbers,
the sizes (:class:`ReproConfig`) and the plant every stage simulates (:func:`load_plant`)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from rinscal import units
from rinscal.errors import ConfigError
from rinscal.thermal.config import ImuConfig, load_imu
from rinscal.thermal.presets import DEFAULT_PRESET, PRESETS

__all__ = [
    "LABELS",
    "METHODS",
    "PAPER",
    "VARIANTS",
    "ReproConfig",
    "load_plant",
    "plant_info",
]

#: The calibration methods, in the paper's order, and the field's baseline.
METHODS = ("poly-t", "sectional", "regression", "neural")
#: What each method is called in the paper and the report.
LABELS = {
    "none": "uncompensated",
    "poly-t": "baseline (cubic in T)",
    "sectional": "method 1 (sectional)",
    "regression": "method 2 (regression)",
    "neural": "method 3 (BP network)",
    "true": "true bias (oracle)",
    "regression+sf": "method 2 + scale factor/axes over T",
    "regression-no-dT": "method 2 without ΔT",
}
#: Navigation variants: uncompensated, each model, and the oracle (the best a model can do).
VARIANTS = ("none", *METHODS, "true")

#: The paper's headline numbers (Section 5).
PAPER = {
    "lab_qs_m1_to_m2_pct": 46.30,
    "lab_swing_m1_to_m2_pct": 47.41,
    "lab_qs_m2_to_m3_pct": 17.24,
    "lab_swing_m2_to_m3_pct": 17.66,
    "vehicle_m1_to_m3_max_pct": 65.11,
    "vehicle_m1_to_m3_mean_pct": 56.0,
    "table10_nmi": {
        "sectional": (0.556, 0.724, 0.495),
        "regression": (0.277, 0.343, 0.316),
        "neural": (0.194, 0.296, 0.282),
    },
    # Table 5 (p = q = s = 1..4) and Table 7 RMS in the paper's pulses
    "table5_accel_x": (35.61, 34.41, 34.00, 33.93),
    "table5_gyro_x": (24.36, 24.36, 24.36, 24.35),
    "table7_accel_x": {4: 32.91, 5: 32.86, 6: 32.61, 7: 32.60, 8: 32.59},
    "table7_gyro_x": {1: 24.85, 2: 24.21, 3: 24.14, 4: 24.13, 5: 24.14},
}


# --------------------------------------------------------------------------- configuration
@dataclass(frozen=True)
class ReproConfig:
    """Sizes of the reproduction. :meth:`quick` and :meth:`full` are the two presets.

    Parameters
    ----------
    seed : int
        Seed of every random number (calibration runs, navigation runs).
    cal_rate_hz : float [Hz]
        Sample rate of the calibration logs (soak, repeat, ramp).
    soak_hours, repeat_hours : float [h]
        Length of each soak run and of the repetition-priming run.
    neural_max_samples : int
        Samples (evenly spaced per run) the BP network is trained on, per channel.
    selection_neural_params : dict
        Hyper-parameters of each fit of the neuron table (8 settings x 7 leave-one-run-out
        folds x 6 channels = 336 fits): fewer samples and starts than the final fit.
    nav_rate_hz : float [Hz]
        IMU rate of the quasi-static, vehicle and ramp navigation runs.
    swing_rate_hz : float [Hz]
        IMU rate of the swing runs (the swinging base needs a higher rate for coning).
    qs_hours, swing_hours : float [h]
        Length of each quasi-static and swing cold start, alignment included.
    vehicle_hours : float [h]
        Driving time of each vehicle run (the paper's 1.9 h).
    ramp_hours : float [h]
        Length of the chamber-ramp navigation run.
    lab_temps_c : tuple of float [°C]
        Lab temperature of the five quasi-static and the five swing cold starts.
    vehicle_ambient_c : tuple of float [°C]
        Ambient temperature at the three vehicle cold starts (the cabin warms to 20 °C).
    align_s : float [s]
        Self-alignment time of the cold starts (coarse plus fine).
    align_start_s : float [s]
        Time after power-on at which the alignment starts (0: at power-on).
    imu : str
        The plant: a preset name (:data:`rinscal.thermal.presets.PRESETS`) or the path of an
        IMU TOML file; see :func:`load_plant`.
    jobs : int
        Worker processes (a Dask ``LocalCluster``) for the navigation runs.
    """

    seed: int = 0
    quick: bool = False
    cal_rate_hz: float = 10.0
    soak_hours: float = 3.0
    repeat_hours: float = 3.0
    neural_max_samples: int = 20000
    selection_neural_params: Mapping[str, Any] = field(
        default_factory=lambda: {"max_samples": 2000, "n_init": 1, "refine_max_nfev": 50}
    )
    nav_rate_hz: float = 100.0
    swing_rate_hz: float = 100.0
    qs_hours: float = 4.0
    swing_hours: float = 2.0
    vehicle_hours: float = 1.9
    ramp_hours: float = 4.5
    lab_temps_c: tuple[float, ...] = (18.0, 20.0, 22.0, 24.0, 26.0)
    vehicle_ambient_c: tuple[float, ...] = (5.0, 0.0, 10.0)
    align_s: float = 600.0
    align_start_s: float = 0.0
    imu: str = DEFAULT_PRESET
    jobs: int = 1

    @classmethod
    def full(cls, seed: int = 0, jobs: int = 1, **overrides: Any) -> ReproConfig:
        """The paper's sizes: 3 h soaks at 10 Hz, navigation at 100 Hz, full durations.

        ``overrides`` sets other fields (``imu``, ``align_s``, ``align_start_s``).
        """
        return cls(seed=seed, jobs=jobs, **overrides)

    @classmethod
    def quick_preset(cls, seed: int = 0, jobs: int = 1, **overrides: Any) -> ReproConfig:
        """Shorter runs at lower rates; the same experiments (about 2 minutes on 2 cores).

        ``overrides`` sets other fields (``imu``, ``align_s``, ``align_start_s``).
        """
        kw: dict[str, Any] = dict(
            seed=seed,
            quick=True,
            cal_rate_hz=2.0,
            neural_max_samples=8000,
            selection_neural_params={
                "max_samples": 1000,
                "n_init": 1,
                "max_iter": 200,
                "refine": False,
            },
            nav_rate_hz=10.0,
            swing_rate_hz=50.0,
            qs_hours=2.0,
            swing_hours=1.0,
            ramp_hours=4.5,
            jobs=jobs,
        )
        kw.update(overrides)
        return cls(**kw)

    def __post_init__(self) -> None:
        for name in (
            "cal_rate_hz",
            "soak_hours",
            "repeat_hours",
            "nav_rate_hz",
            "swing_rate_hz",
            "qs_hours",
            "swing_hours",
            "vehicle_hours",
            "ramp_hours",
            "align_s",
        ):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ConfigError(f"reproduction: {name} must be > 0, got {v}")
        if not (math.isfinite(self.align_start_s) and self.align_start_s >= 0):
            raise ConfigError(f"reproduction: align_start_s must be >= 0, got {self.align_start_s}")
        shortest = min(self.qs_hours, self.swing_hours, self.ramp_hours) * units.HOUR_TO_S
        if self.align_start_s + self.align_s >= shortest:
            raise ConfigError(
                f"reproduction: the alignment ends {self.align_start_s + self.align_s:g} s "
                f"after power-on, not before the shortest lab run ({shortest:g} s) ends"
            )
        if self.jobs < 1:
            raise ConfigError(f"reproduction: jobs must be >= 1, got {self.jobs}")
        if len(self.lab_temps_c) < 1 or len(self.vehicle_ambient_c) < 1:
            raise ConfigError("reproduction: need at least one lab and one vehicle run")


def load_plant(spec: str) -> ImuConfig:
    """The IMU the whole reproduction simulates, from a preset name or a TOML file path.

    Raises
    ------
    ConfigError
        Naming the presets, when ``spec`` is neither a preset nor a readable IMU file (a
        preset whose data file is missing from the installation included).
    """
    try:
        return load_imu(spec)
    except ConfigError as e:
        raise ConfigError(f"--imu: {e}") from None
    except OSError as e:
        raise ConfigError(
            f"--imu {spec!r}: cannot read it ({e.strerror or e}); presets: {', '.join(PRESETS)}"
        ) from None


def plant_info(spec: str, imu: ImuConfig) -> dict[str, Any]:
    """Which plant ran, for the report and metrics.json.

    Returns
    -------
    dict
        ``spec`` (as given), ``kind`` (``"preset"`` or ``"file"``), ``name`` (the
        configuration's own name), ``presets`` and ``other_presets`` (the built-in ones not
        run), ``run_other`` (the option to pass to run another preset).
    """
    kind = "preset" if spec in PRESETS else "file"
    others = [p for p in PRESETS if p != spec]
    return {
        "spec": str(spec),
        "kind": kind,
        "name": imu.name,
        "presets": list(PRESETS),
        "default_preset": DEFAULT_PRESET,
        "other_presets": others,
        "run_other": [f"--imu {p}" for p in others],
    }
