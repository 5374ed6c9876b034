"""The outcome of a navigation, simulated or recorded (:class:`NavResult`), and the error
series of INS rows against the truth (:func:`error_frame`; positions in m and nmi,
velocities in m/s, attitudes in rad).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from rinscal import earth, units
from rinscal.nav.align import AlignResult
from rinscal.nav.attitude import C_nb_from_euler, attitude_error, euler_from_C_nb
from rinscal.nav.rotation import C_br
from rinscal.nav.strapdown import quat_to_dcm


@dataclass
class NavResult:
    """Outcome of a navigation scenario.

    Attributes
    ----------
    config : ScenarioConfig or RecordedRun
        What was run (a simulated scenario or a recording).
    truth : pandas.DataFrame
        True state at the reported times: ``time_s, lat_deg, lon_deg, alt_m, v_e, v_n,
        v_u`` [s, deg, deg, m, m/s ×3], ``heading_deg, pitch_deg, roll_deg, encoder_deg``.
    errors : dict of str to pandas.DataFrame
        Per variant, from the start of free navigation on: ``time_s``, position error
        ``east_m, north_m, horizontal_m, horizontal_nmi, up_m``, INS position ``lat_deg,
        lon_deg``, velocity error ``v_e_err, v_n_err`` [m/s], attitude error of the body
        frame ``att_e, att_n, att_u`` [rad] (small angles, ENU) and the same as Euler-angle
        errors, INS minus truth, ``heading_err, pitch_err, roll_err`` [rad] (heading
        clockwise from north, wrapped to ±π).
    alignment : dict of str to AlignResult or None
        Per variant.
    """

    config: Any  # rinscal.sim.scenario_config.ScenarioConfig or a RecordedRun
    truth: pd.DataFrame
    errors: dict[str, pd.DataFrame]
    alignment: dict[str, AlignResult | None]

    def max_error_m(self, variant: str) -> float:
        """Maximum horizontal position error of a variant [m]."""
        return float(self.errors[variant]["horizontal_m"].max())

    def summary(self) -> dict[str, Any]:
        """JSON-able summary: per variant max/final/RMS error [m, nmi] and alignment.

        Per variant: ``max_error_m``, ``max_error_nmi``, ``time_of_max_s``,
        ``final_error_m``, ``rms_error_m``, ``attitude_error_at_nav_start`` (``{"heading_arcsec",
        "pitch_arcsec", "roll_arcsec"}``: INS body heading, pitch and roll minus the truth at
        the first navigation output, heading clockwise from north, wrapped to ±180°), with an
        alignment also ``alignment`` (bias estimates, filter attitude sd and the small-angle
        ``attitude_error_arcsec``), and ``improvement_vs_none_pct`` beside a ``none`` variant.
        """
        c = self.config
        out: dict[str, Any] = {
            "scenario": c.name,
            "duration_s": c.duration_s,
            "rate_hz": c.rate_hz,
            "rotation": c.schedule.name,
            "alignment_s": None if c.align is None else c.align.total_s,
            "alignment_start_s": c.align_start_s,
            "navigation_start_s": c.nav_start_s,
            "variants": {},
        }
        for name, df in self.errors.items():
            h = df["horizontal_m"].to_numpy()
            i = int(np.argmax(h)) if h.size else 0
            v: dict[str, Any] = {
                "max_error_m": float(h.max()) if h.size else float("nan"),
                "max_error_nmi": float(h.max() / units.NMI_TO_M) if h.size else float("nan"),
                "time_of_max_s": float(df["time_s"].iloc[i]) if h.size else float("nan"),
                "final_error_m": float(h[-1]) if h.size else float("nan"),
                "rms_error_m": float(np.sqrt(np.mean(h**2))) if h.size else float("nan"),
            }
            eul = df[["heading_err", "pitch_err", "roll_err"]].to_numpy()
            e0 = eul[0] / units.ARCSEC_TO_RAD if h.size else np.full(3, np.nan)
            # a recording knows at most its heading: an unknown truth is left out, not NaN
            v["attitude_error_at_nav_start"] = {
                f"{k}_arcsec": float(x)
                for k, x in zip(("heading", "pitch", "roll"), e0, strict=True)
                if math.isfinite(x)
            }
            a = self.alignment.get(name)
            if a is not None:
                v["alignment"] = {
                    "gyro_bias_dph": (a.gyro_bias / units.DPH_TO_RPS).tolist(),
                    "accel_bias_ug": (a.accel_bias / units.UG_TO_MPS2).tolist(),
                    "attitude_sd_arcsec": (a.attitude_sd / units.ARCSEC_TO_RAD).tolist(),
                }
                att = df[["att_e", "att_n", "att_u"]].to_numpy()
                if att.shape[0] and np.isfinite(att[0]).all():
                    v["alignment"]["attitude_error_arcsec"] = (
                        att[0] / units.ARCSEC_TO_RAD
                    ).tolist()
            out["variants"][name] = v
        if "none" in out["variants"]:
            base = out["variants"]["none"]["max_error_m"]
            for name, v in out["variants"].items():
                if name != "none" and base > 0:
                    v["improvement_vs_none_pct"] = 100.0 * (1.0 - v["max_error_m"] / base)
        return out


def error_frame(truth: NDArray[np.float64], ins: NDArray[np.float64]) -> pd.DataFrame:
    """Errors of INS rows against truth rows, one row per time (the columns of
    :attr:`NavResult.errors`: position [m, nmi, deg], velocity [m/s], attitude [rad]).

    ``truth`` holds ``time_s, lat, lon, alt, v_e, v_n, v_u, heading, pitch, roll, encoder``
    [s, rad, rad, m, m/s ×3, rad ×4]; ``ins`` the strapdown rows ``lat, lon, alt, v_e, v_n,
    v_u, q0..q3`` [rad, rad, m, m/s ×3, quaternion of ``C_nr``].
    """
    if ins.shape[0] != truth.shape[0]:
        raise AssertionError("internal: INS and truth rows differ")  # pragma: no cover
    lat_t, lon_t, alt_t = truth[:, 1], truth[:, 2], truth[:, 3]
    east, north, up = np.moveaxis(
        earth.enu_difference(ins[:, 0], ins[:, 1], ins[:, 2], lat_t, lon_t, alt_t), -1, 0
    )
    horiz = np.hypot(east, north)
    C_true = C_nb_from_euler(truth[:, 7:10])
    C_est = quat_to_dcm(ins[:, 6:10]) @ np.swapaxes(C_br(truth[:, 10]), -1, -2)  # C_nr C_rb
    att = attitude_error(C_true, C_est) if truth.shape[0] else np.empty((0, 3))
    eul = euler_from_C_nb(C_est) - truth[:, 7:10] if truth.shape[0] else np.empty((0, 3))
    eul = (eul + np.pi) % (2 * np.pi) - np.pi  # heading (and roll) wrap to ±π
    return pd.DataFrame(
        {
            "time_s": truth[:, 0],
            "east_m": east,
            "north_m": north,
            "horizontal_m": horiz,
            "horizontal_nmi": horiz / units.NMI_TO_M,
            "up_m": up,
            "lat_deg": ins[:, 0] / units.DEG_TO_RAD,
            "lon_deg": ins[:, 1] / units.DEG_TO_RAD,
            "v_e_err": ins[:, 3] - truth[:, 4],
            "v_n_err": ins[:, 4] - truth[:, 5],
            "att_e": att[:, 0],
            "att_n": att[:, 1],
            "att_u": att[:, 2],
            "heading_err": eul[:, 0],
            "pitch_err": eul[:, 1],
            "roll_err": eul[:, 2],
        }
    )


__all__ = ["NavResult", "error_frame"]
