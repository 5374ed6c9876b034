"""Aiding of a recording's navigation (helpers of :func:`rinscal.nav.recording.navigate_log`):
the GNSS measurements and the filter that takes each variant over after its alignment
(``aiding="gnss"``), and the in-motion alignment of a moving recording on its track file.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from rinscal.errors import LogError
from rinscal.nav.aiding import GnssTrack
from rinscal.nav.gnss_ins import HEADING_PRIOR_SD, AidedInertial, ImuNoise
from rinscal.nav.inmotion import InMotionAligner
from rinscal.nav.recorded.window import Window, align_config
from rinscal.nav.strapdown import Strapdown

__all__ = [
    "AIDING",
    "GNSS_NOTE",
    "IN_MOTION_COARSE_S",
    "gnss_aiding",
    "in_motion_alignment",
]


#: What ``aiding=`` may be.
AIDING = ("none", "gnss")
#: Said in the report and on the console when the errors are taken against the track that
#: also aided the navigation.
GNSS_NOTE = (
    "GNSS-aided: the errors are taken against the same track the filter used, so they are "
    "not independent of it (they show how closely the filter follows the fixes)"
)


def in_motion_alignment(
    log: Any,
    imu_noise: Any,
    noise_of: Callable[[Any], Any],
    tr: Any,
    position_sd: float,
    dt: float,
    t_first: float,
    align_s: float,
    path: Any,
) -> tuple[Any, Any, Window, Callable[[int], InMotionAligner]]:
    """The noise, alignment settings, window and aligner of an in-motion alignment on the
    track ``tr`` from the recording's start ``t_first`` [s] for ``align_s`` [s] (the noise
    the log's metadata's or ``imu=``'s: a moving recording has no still stretch to estimate
    it on: ``noise_of(log)`` reads the metadata's)."""
    if imu_noise is None and not log.noise:
        raise LogError(
            f"{path}: the recording moves and is aligned in motion on its track, which needs "
            "the IMU's noise: give imu= (a preset or IMU file), or a 'noise' entry in the "
            "log's metadata"
        )
    noise = imu_noise or noise_of(log)
    coarse_s = min(IN_MOTION_COARSE_S, align_s)
    window = Window(start_s=t_first, length_s=align_s, how="in motion")
    align = align_config(noise, window, coarse_s)
    imu = ImuNoise(
        noise.gyro_density, noise.accel_density, align.gyro_bias_sd, align.accel_bias_sd,
        noise.gyro_bias_rw, noise.accel_bias_rw,
    )  # fmt: skip
    track = GnssTrack(tr.t, tr.lat, tr.lon, tr.h, position_sd)

    def aligner(k0: int) -> InMotionAligner:
        return InMotionAligner(track, imu, dt, t_first + k0 * dt, align_s, coarse_s, k0=k0)

    return noise, align, window, aligner


#: Coarse (OBA) window of an in-motion alignment [s]
#: (:func:`rinscal.nav.inmotion.coarse_in_motion`).
IN_MOTION_COARSE_S = 60.0


def gnss_aiding(tr: Any, noise: Any, position_sd: float, dt: float) -> dict[str, Any]:
    """The ``aiding=`` and ``aided_filter=`` of :func:`rinscal.nav.engine.navigate_pieces`
    for a track's fixes.

    Parameters
    ----------
    tr : Track
        The track (``t`` [s], ``lat``, ``lon`` [rad], ``h`` [m]).
    noise : Noise
        The sensor noise the alignment assumed (densities [rad/√s], [m/s²/√Hz], bias random
        walks [rad/s/√s], [m/s²/√s]).
    position_sd : float [m]
        Each fix coordinate's standard deviation.
    dt : float [s]
        Sample interval.

    The filter starts where the alignment ended: position uncertain by ``position_sd``,
    velocity by ``position_sd`` per second, attitude and biases by the alignment's own
    standard deviations, the heading's at least
    :data:`rinscal.nav.gnss_ins.HEADING_PRIOR_SD` (the alignment's can be far too small).
    """
    track = GnssTrack(tr.t, tr.lat, tr.lon, tr.h, position_sd)

    def aided_filter(nav: Any, res: Any, gyro_bias: Any, accel_bias: Any) -> AidedInertial:
        free = Strapdown(nav.lat, nav.lon, nav.alt, nav.v_n, nav.C_nr, dt, "free")
        free.k = nav.k
        attitude = np.maximum(res.attitude_sd, [0.0, 0.0, HEADING_PRIOR_SD])
        sd = np.concatenate(
            [np.full(3, position_sd), np.full(3, position_sd / 1.0), attitude,
             res.gyro_bias_sd, res.accel_bias_sd]
        )  # fmt: skip
        imu = ImuNoise(
            noise.gyro_density,
            noise.accel_density,
            float(res.gyro_bias_sd.max()),
            float(res.accel_bias_sd.max()),
            noise.gyro_bias_rw,
            noise.accel_bias_rw,
        )
        return AidedInertial(free, np.diag(sd**2), imu, gyro_bias, accel_bias)

    return {"aiding": (track,), "aided_filter": aided_filter}
