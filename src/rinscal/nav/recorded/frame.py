"""The recorded-navigation log's columns written from a simulated chunk (``navigate --record``)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from rinscal import units
from rinscal.schema import CHANNELS, DTHETA, DVEL, REF_HEADING, REF_TRACK, TABLE, TEMP_OUT

__all__ = [
    "recording_frame",
    "weight_texts",
]

#: Standard gravity of the velocity pulse units µg·s, mg·s, g·s [m/s²].
_G0 = 9.80665


def weight_texts(weights: NDArray[np.float64]) -> dict[str, str]:
    """The metadata's ``weights`` of a recording of counts: one count of each sensor type
    in the units of a mapping's ``[weights]`` (``"0.1 arcsec"``, ``"125 ug*s"``), from the
    weights per channel (6,) [rad, m/s] (one weight per sensor type)."""
    w = np.asarray(weights, dtype=float)
    arcsec = float(w[0]) / units.ARCSEC_TO_RAD
    ugs = float(w[3]) / (1e-6 * _G0)
    return {"gyro": f"{arcsec:.12g} arcsec", "accel": f"{ugs:.12g} ug*s"}


# --------------------------------------------------------------------------- recording
def recording_frame(
    chunk: Any,
    dtheta: NDArray[np.float64],
    dv: NDArray[np.float64],
    *,
    increments: bool = False,
    readings: tuple[NDArray, NDArray, NDArray] | None = None,
    track: bool = False,
    counts: NDArray[np.float64] | None = None,
    heading: bool = True,
) -> pd.DataFrame:
    """The raw recording of a simulated chunk, in the recorded-navigation log's columns.

    Parameters
    ----------
    chunk : rinscal.sim.ideal_imu.ImuChunk
        Truth of the chunk (times, encoder, position, attitude).
    dtheta, dv : ndarray, shape (n, 3) [rad, m/s]
        The IMU's raw increments (errors included).
    increments : bool
        Write ``dtheta_*`` [rad] and ``dvel_*`` [m/s]; else mean rates over each interval
        ``gyro_*`` [deg/h] and ``accel_*`` [µg].
    readings : (grid, inner, outer), optional
        Thermometer readings [s, °C (m, 6), °C (m,)]: each sample carries the last reading
        taken at or before the middle of its interval (what a navigation computer logs).
    track : bool
        Write the true position as ``ref_lat_deg, ref_lon_deg, ref_h_m`` (a moving carrier).
    counts : ndarray, shape (6,) [rad, m/s], optional
        Pulse weights of an IMU whose output is whole pulses (a quantised plant): write
        ``dtheta_*`` and ``dvel_*`` as integer counts per interval (``increments`` is then
        ignored); the metadata's ``weights`` say what one count is.
    heading : bool
        Write the true body heading as ``ref_heading_deg`` [deg] (False: a parked start
        whose heading the calibration must find).

    Returns
    -------
    DataFrame
        ``time_s`` (end of each interval), the IMU, ``table_deg`` (wrapped to ±180°),
        temperatures, the reference track and ``ref_heading_deg`` (true body heading, if
        ``heading``).
    """
    t = chunk.t
    dt = np.diff(t, prepend=t[0] - (t[1] - t[0] if t.size > 1 else 1.0))
    cols: dict[str, Any] = {"time_s": t}
    if counts is not None:
        n = np.rint(np.concatenate([dtheta, dv], axis=1) / np.asarray(counts)).astype(np.int64)
        for j, c in enumerate((*DTHETA, *DVEL)):
            cols[c] = n[:, j]
    elif increments:
        for j, c in enumerate(DTHETA):
            cols[c] = dtheta[:, j]
        for j, c in enumerate(DVEL):
            cols[c] = dv[:, j]
    else:
        for j in range(3):
            cols[CHANNELS[j]] = dtheta[:, j] / dt / units.DPH_TO_RPS
        for j in range(3):
            cols[CHANNELS[3 + j]] = dv[:, j] / dt / units.UG_TO_MPS2
    cols[TABLE] = (np.rad2deg(chunk.encoder) + 180.0) % 360.0 - 180.0
    if readings is not None:
        grid, inner, outer = readings
        k = np.clip(np.searchsorted(grid, t - 0.5 * dt, side="right") - 1, 0, grid.size - 1)
        for j, c in enumerate(CHANNELS):
            cols[f"temp_{c}"] = inner[k, j]
        cols[TEMP_OUT] = outer[k]
    if track:
        cols[REF_TRACK[0]] = np.rad2deg(chunk.lat)
        cols[REF_TRACK[1]] = np.rad2deg(chunk.lon)
        cols[REF_TRACK[2]] = chunk.alt
    if heading:
        cols[REF_HEADING] = np.rad2deg(chunk.euler[:, 0])
    return pd.DataFrame(cols)
