"""Recordings "made like the real one", for tests of navigating a real sensor's recording.

The real recording of issue 35: a laser-gyro strapdown IMU on a parked vehicle, people moving
about at first, 100 Hz, 31 min, integer counts of 0.1″ and 125 µg·s; its gyros' Allan
deviation 3-5 °/h at τ = 1 s falling with a slope of about −0.8 out to 100 s; per-second gyro
peaks of hundreds of °/h while disturbed, about the Earth rate's 15 °/h when quiet. The
``ring_laser`` preset makes that curve as the issue describes the unit: a white angle noise
(1.8″ per sample, 3.2 °/h at 1 s with the random walk) over a true random walk of 0.01 °/√h.

:func:`write_realistic` simulates such a recording with ``rinscal navigate --scenario
quasi-static --imu ring_laser --rotation none --disturbed-start 9 --record`` (the library
call) and returns where it is and what is true about it (:class:`Realistic`): the noise terms
the plant drew, the disturbance's interval, the site and heading. Variants: ``"ring_laser"``
(100 Hz counts), ``"ring_laser_1hz"`` (the same unit recorded at 1 Hz),
``"ring_laser_correlated"`` (the same curve from a correlated angle noise over a smaller
random walk: the case a window cannot resolve) and ``"fog"`` (the FOG-like
``navigation_grade`` unit: rates, white rate noise). The recording's metadata keeps
the site, heading, rate and weights but not the noise (a real recording does not say it);
:meth:`Realistic.true_noise` gives it in the metadata's form.

The session-scoped fixtures of ``tests/nav/conftest.py`` write each variant once per test
session (about 20 s for the 100 Hz ones, under a second at 1 Hz).
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from rinscal import units
from rinscal.sim.config import load_imu
from rinscal.sim.workflow import navigate_scenario

#: The variants :func:`write_realistic` writes: (IMU preset, rate [Hz], changes to the
#: preset's ``[noise]``). Each is simulated at 100 Hz (the sway must be resolved); a lower
#: rate sums the counts, as the unit would. ``ring_laser_correlated`` is the harder unit of
#: the same Allan curve: its bend from −1 to −0.8 is a Gauss-Markov angle noise (6″ over
#: 100 s) over a smaller true random walk (0.0075 °/√h), which a 10 min window cannot tell
#: from a random walk of 0.014 °/√h (docs/navigation.md, "the correlated angle").
VARIANTS: dict[str, tuple[str, float, dict[str, float]]] = {
    "ring_laser": ("ring_laser", 100.0, {}),
    "ring_laser_1hz": ("ring_laser", 1.0, {}),
    "ring_laser_correlated": (
        "ring_laser",
        100.0,
        {
            "gyro_arw_deg_rth": 0.0075,
            "gyro_angle_white_arcsec": 2.3,
            "gyro_angle_markov_arcsec": 6.0,
            "gyro_angle_markov_tau_s": 100.0,
        },
    ),
    "fog": ("navigation_grade", 100.0, {}),
}
SIM_RATE_HZ = 100.0


@dataclass(frozen=True)
class Realistic:
    """A simulated recording and its truth.

    Attributes
    ----------
    path : Path
        The recording (Parquet) with its ``.meta.json``.
    variant : str
        One of :data:`VARIANTS`.
    rate_hz : float [Hz]
        Sample rate.
    duration_s : float [s]
        Length.
    counts : bool
        The sensor columns are integer counts (``dtheta_*``, ``dvel_*``; weights in the
        metadata), else rates (``gyro_*`` [deg/h], ``accel_*`` [µg]).
    weights : tuple of 2 float [rad, m/s]
        One count of a gyro, of an accelerometer (the plant's weights even for rates).
    gyro_arw : float [rad/√s]
        True angle random walk (white rate noise density).
    gyro_angle_white : float [rad]
        White angle noise, standard deviation per sample.
    gyro_angle_markov : float [rad]
        Gauss-Markov angle noise, stationary standard deviation ...
    gyro_angle_markov_tau_s : float [s]
        ... and its correlation time.
    accel_vrw : float [m/s²/√Hz]
        Accelerometer white noise density.
    gyro_bias_rw, accel_bias_rw : float [rad/s/√s, m/s²/√s]
        Bias random walks.
    disturbed : tuple of 2 float [s]
        The disturbance's interval (people about the vehicle); quiet after it.
    site : tuple of 3 float [deg, deg, m]
        Latitude, longitude, height.
    heading_deg : float [deg]
        The body's heading once the disturbance is over (its tilt and heading steps end
        there).
    """

    path: Path
    variant: str
    rate_hz: float
    duration_s: float
    counts: bool
    weights: tuple[float, float]
    gyro_arw: float
    gyro_angle_white: float
    gyro_angle_markov: float
    gyro_angle_markov_tau_s: float
    accel_vrw: float
    gyro_bias_rw: float
    accel_bias_rw: float
    disturbed: tuple[float, float]
    site: tuple[float, float, float]
    heading_deg: float

    @property
    def gyro_arw_deg_rth(self) -> float:
        """True angle random walk [deg/√h]."""
        return self.gyro_arw / units.DPRH_TO_RPRS

    @property
    def accel_vrw_ug_rthz(self) -> float:
        """Accelerometer white noise density [µg/√Hz]."""
        return self.accel_vrw / units.UG_TO_MPS2

    def gyro_adev_dph(self, tau_s: float) -> float:
        """The gyros' true Allan deviation at ``tau_s`` [s] from the noise terms [deg/h]
        (white angle, Gauss-Markov angle, white rate; quantisation and the bias random walk
        are small beside them)."""
        tau = float(tau_s)
        m, tc = self.gyro_angle_markov, self.gyro_angle_markov_tau_s
        var = 3 * self.gyro_angle_white**2 / tau**2
        var += m * m / tau**2 * (3 - 4 * math.exp(-tau / tc) + math.exp(-2 * tau / tc))
        var += self.gyro_arw**2 / tau
        return math.sqrt(var) / units.DPH_TO_RPS

    def true_noise(self) -> dict[str, float]:
        """The true white noise and bias random walks in the metadata's ``noise`` form
        (SI: rad/√s, m/s²/√Hz, rad/s/√s, m/s²/√s): the filter told the truth."""
        return {
            "gyro_noise_density": self.gyro_arw,
            "accel_noise_density": self.accel_vrw,
            "gyro_bias_rw": self.gyro_bias_rw,
            "accel_bias_rw": self.accel_bias_rw,
        }

    def meta(self) -> dict[str, Any]:
        """The recording's metadata as written."""
        return json.loads(Path(f"{self.path}.meta.json").read_text())


def write_realistic(
    folder: str | Path,
    variant: str = "ring_laser",
    *,
    minutes: float = 31.0,
    disturbed_min: float = 9.0,
    seed: int = 35,
    noise_in_meta: bool = False,
) -> Realistic:
    """Simulate a recording made like the real one into ``folder``.

    Parameters
    ----------
    folder : path
        Where ``<variant>.parquet`` and its ``.meta.json`` go.
    variant : str
        ``"ring_laser"`` (100 Hz counts of 0.1″ and 125 µg·s, dithered-laser angle noise),
        ``"ring_laser_1hz"`` (the same at 1 Hz), ``"ring_laser_correlated"`` (6″ of
        Gauss-Markov angle over 100 s, random walk 0.0075 °/√h) or ``"fog"``
        (``navigation_grade``: rates, white rate noise).
    minutes : float [min]
        Length (the real one: 31 min).
    disturbed_min : float [min]
        People about the parked vehicle for the first minutes (0: none).
    seed : int
        Seed of the noise and the disturbance.
    noise_in_meta : bool
        Keep the plant's white noise and bias random walks in the metadata (a real
        recording does not say them; default False).
    """
    preset, rate, noise = VARIANTS[variant]
    cfg = load_imu(preset)
    if noise:
        cfg = dataclasses.replace(cfg, noise=dataclasses.replace(cfg.noise, **noise))
    path = Path(folder) / f"{variant}.parquet"
    sim_path = path if rate == SIM_RATE_HZ else Path(folder) / f"{variant}.sim.parquet"
    nav = navigate_scenario(
        "quasi-static",
        imu=cfg,
        hours=minutes / 60.0,
        rate_hz=SIM_RATE_HZ,
        seed=seed,
        rotation="none",
        oracle=False,
        record=sim_path,
        disturbed_start_min=disturbed_min or None,
    )
    meta = json.loads(Path(f"{sim_path}.meta.json").read_text())
    if sim_path != path:
        _decimate(sim_path, path, round(SIM_RATE_HZ / rate))
        meta["rate_hz"] = rate
        sim_path.unlink()
        Path(f"{sim_path}.meta.json").unlink()
    if not noise_in_meta:
        meta.pop("noise", None)
    Path(f"{path}.meta.json").write_text(json.dumps(meta, indent=2) + "\n")
    wd, rw = cfg.noise.white_density_si(), cfg.noise.bias_rw_si()
    white_a, markov_a, tau_a = cfg.noise.angle_noise_si()
    w = cfg.output.pulse_weight_si()
    tr = nav.config.trajectory
    end = float(nav.summary["disturbance"]["end_s"]) if disturbed_min else 0.0
    heading = float(tr.kinematics([end + 1.0]).euler[0, 0]) / units.DEG_TO_RAD
    return Realistic(
        path=path,
        variant=variant,
        rate_hz=rate,
        duration_s=float(nav.config.duration_s),
        counts=bool(nav.summary["output"]["quantised"]),
        weights=(float(w[0]), float(w[3])),
        gyro_arw=float(wd[0]),
        gyro_angle_white=white_a,
        gyro_angle_markov=markov_a,
        gyro_angle_markov_tau_s=tau_a,
        accel_vrw=float(wd[3]),
        gyro_bias_rw=float(rw[0]),
        accel_bias_rw=float(rw[3]),
        disturbed=(0.0, end),
        site=(meta["site"]["lat_deg"], meta["site"]["lon_deg"], meta["site"]["h_m"]),
        heading_deg=heading,
    )


def _decimate(src: Path, dst: Path, k: int) -> None:
    """Write ``src`` at 1/``k`` of its rate into ``dst``: counts summed over each ``k``
    samples (what the unit's own lower-rate output holds), everything else (time, encoder,
    temperatures, reference heading) as at the last of them."""
    df = pd.read_parquet(src)
    m = len(df) // k
    df = df.iloc[: m * k]
    group = np.arange(m * k) // k
    sums = [c for c in df.columns if c.startswith(("dtheta_", "dvel_"))]
    rest = [c for c in df.columns if c not in sums]
    out = df[rest].groupby(group).last()
    for c in sums:
        out[c] = df[c].groupby(group).sum().astype(df[c].dtype)
    out[list(df.columns)].reset_index(drop=True).to_parquet(dst, index=False)
