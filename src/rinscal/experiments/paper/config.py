"""The reproduction's settings: the methods and their labels, the paper's headline numbers,
the sizes (:class:`ReproConfig`) and the plant every stage simulates (:func:`load_plant`)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from rinscal import units
from rinscal.errors import ConfigError
from rinscal.presets import DEFAULT_PRESET, PRESETS
from rinscal.sim.config import ImuConfig, load_imu

__all__ = [
    "LABELS",
    "METHODS",
    "PAPER",
    "PAPER_TABLES",
    "VARIANTS",
    "ReproConfig",
    "group_label",
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
    "field": "field (from parked cold starts)",
}


def group_label(experiment: str, scenario: str) -> str:
    """A group of navigation runs in words: "ramp", "vehicle", "lab quasi-static" (an
    experiment whose only scenario has its name is not named twice, "ramp ramp")."""
    return scenario if scenario == experiment else f"{experiment} {scenario}"


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

#: The paper's Tables 4-9 as printed, in its pulses (Tables 4-7; converted to physical
#: units by :mod:`rinscal.experiments.paper.paper_tables`) or as printed (Tables 8, 9).
#: Keys of the coefficient tables: ``a0`` and ``T^k``, ``Ṫ^k``, ``ΔT^k`` (our names of the
#: paper's A_0, A_T1..3 / A_Ṫ1..3 / A_ΔT1..3; Table 4's A_T4..6 are its Ṫ terms).
PAPER_TABLES: dict[str, Any] = {
    # Table 4, x axis, per temperature segment (edges [°C]; T ≤ edge[0] is segment 1)
    "table4": {
        "accel_x": {
            "edges": (4.0, 10.0, 17.0, 23.0, 30.0, 37.0),
            "a0": (7071.18, 7243.84, 7607.06, 8138.59, 9129.55, 8919.01, 12730.53),
            "T^1": (-7.09, -66.89, -112.95, -145.75, -217.33, -148.79, -388.56),
            "T^2": (3.52, 7.41, 7.41, 6.36, 7.43, 3.83, 8.73),
            "T^3": (-0.32, -0.26, -0.16, -0.0915, -0.0842, -0.0324, -0.0650),
            "Ṫ^1": (196.73, 69.73, 62.25, 93.10, 104.29, 37.32, -31.43),
            "Ṫ^2": (-153.01, 62.48, 479.76, 521.83, 411.17, 476.53, 544.07),
            "Ṫ^3": (389.25, 273.51, -129.38, -188.77, -111.36, -98.80, -101.98),
        },
        "gyro_x": {
            "edges": (3.0, 9.0, 16.0, 23.0, 29.0, 36.0),
            "a0": (7367.37, 7370.21, 7363.00, 7366.31, 7370.28, 7374.67, 7355.78),
            "T^1": (0.468, -0.478, 0.322, 0.115, -0.0574, -0.209, 0.316),
            "Ṫ^1": (34.99, 5.47, 36.58, 24.21, 36.96, 24.13, 36.03),
        },
    },
    # Table 5: training RMS [pulses] for p = q = s = 1..4
    "table5": {
        "accel_x": (35.61, 34.41, 34.00, 33.93),
        "accel_y": (36.39, 34.79, 32.99, 32.93),
        "accel_z": (41.85, 41.68, 39.37, 39.18),
        "gyro_x": (24.36, 24.36, 24.36, 24.35),
        "gyro_y": (22.06, 22.05, 22.04, 22.04),
        "gyro_z": (14.10, 14.10, 14.09, 14.08),
    },
    # Table 6: method 2 (p = q = s = 3 for accelerometers, 1 for gyros) [pulses]
    "table6": {
        "accel_x": {
            "a0": 7411.39,
            "T": (-8.52, 0.180, -1.84e-3),
            "Ṫ": (92.22, 256.82, -148.15),
            "ΔT": (-533.16, 280.29, -45.09),
        },
        "accel_y": {
            "a0": 7051.03,
            "T": (3.41, 0.0575, -1.73e-3),
            "Ṫ": (94.10, 118.68, -18.01),
            "ΔT": (-407.06, 191.04, -27.73),
        },
        "accel_z": {
            "a0": 465231.31,
            "T": (-10.31, 0.122, -2.61e-4),
            "Ṫ": (-128.82, -23.17, -1.41),
            "ΔT": (-290.31, 163.01, -25.43),
        },
        "gyro_x": {"a0": 7361.77, "T": (-0.0175,), "Ṫ": (40.48,), "ΔT": (3.87,)},
        "gyro_y": {"a0": -3.56, "T": (-0.0158,), "Ṫ": (14.85,), "ΔT": (0.592,)},
        "gyro_z": {"a0": 3617.88, "T": (-0.0419,), "Ṫ": (4.82,), "ΔT": (0.397,)},
    },
    # Table 7: training RMS [pulses] per number of hidden neurons
    "table7": {
        "accel_x": {4: 32.91, 5: 32.86, 6: 32.61, 7: 32.60, 8: 32.59},
        "accel_y": {4: 32.22, 5: 32.45, 6: 32.20, 7: 32.19, 8: 32.21},
        "accel_z": {4: 38.97, 5: 38.82, 6: 38.68, 7: 38.67, 8: 38.67},
        "gyro_x": {1: 24.85, 2: 24.21, 3: 24.14, 4: 24.13, 5: 24.14},
        "gyro_y": {1: 22.14, 2: 22.02, 3: 22.00, 4: 22.02, 5: 22.01},
        "gyro_z": {1: 14.09, 2: 14.07, 3: 14.04, 4: 14.03, 5: 14.04},
    },
    # Table 8: the x-axis networks (W[i][j]: neuron i, input j = T, Ṫ, ΔT; dimensionless,
    # on the paper's normalised inputs and output)
    "table8": {
        "accel_x": {
            "W": (
                (-1.36, -4.14, 8.01),
                (-7.24, -0.540, 1.16),
                (-0.316, -0.153, 0.562),
                (-0.137, -0.0919, 0.227),
                (-2.038, -0.490, 1.10),
                (-17.37, -1.24, 5.06),
            ),
            "b": (6.55, -1.01, -0.356, 0.0561, 1.56, -12.13),
            "v": (-0.0327, 0.0927, 3.87, -10.00, 0.632, 0.116),
            "b_out": 1.35,
        },
        "gyro_x": {
            "W": ((-1.25, 0.414, -0.588), (0.228, 0.355, 0.124)),
            "b": (1.40, -1.54),
            "v": (7.84e-3, 0.148),
            "b_out": 0.125,
        },
    },
    # Table 9 as printed (garbled in our copy: three numbers per axis under four headings);
    # our reading is in rinscal.sim.trajectory (held heading 45°; swing amplitudes 2/2/8°,
    # periods 3/3/5 s).
    "table9": {
        "heading": (45.0, 2.0, 3.0),
        "pitch": (0.0, 2.0, 3.0),
        "roll": (0.0, 8.0, 5.0),
    },
    # The static outputs the pulse scales are read from (Table 6): gravity on z, Earth rate
    # on x (north) and z (up); the lab at Nanjing.
    "lab_latitude_deg": 32.06,
    "lab_altitude_m": 10.0,
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
        The plant: a preset name (:data:`rinscal.presets.PRESETS`) or the path of an
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
        """Shorter runs at lower rates; the same experiments (wall time: data/timings.json).

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
