"""Aiding of a recording's navigation (helpers of :func:`rinscal.nav.recording.navigate_log`):
the GNSS measurements and the filter that takes each variant over after its alignment
(``aiding="gnss"``), and the in-motion alignment of a moving recording on its track file.
"""

from __future__ import annotations

import math
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
    "IN_MOTION_MIN_S",
    "IN_MOTION_NAV_MIN_S",
    "IN_MOTION_SHARE",
    "TRACK_MAX_RATE_HZ",
    "gnss_aiding",
    "in_motion_alignment",
    "in_motion_lengths",
    "track_measurement",
]


#: What ``aiding=`` may be.
AIDING = ("none", "gnss")
#: Said in the report and on the console when the errors are taken against the track that
#: also aided the navigation.
GNSS_NOTE = (
    "GNSS-aided: the errors are taken against the same track the filter used, so they are "
    "not independent of it (they show how closely the filter follows the fixes)"
)


def in_motion_lengths(align_s: float, duration_s: float) -> tuple[float, float]:
    """The alignment and coarse window [s] of an in-motion alignment asked for ``align_s``
    [s] on a recording ``duration_s`` [s] long.

    The alignment is ``align_s`` when it leaves at least :data:`IN_MOTION_NAV_MIN_S` of the
    recording to navigate, else :data:`IN_MOTION_SHARE` of the recording (the rest is
    navigated: a 100 s drive with the default 600 s aligns on 60 s and navigates 40 s);
    the coarse (OBA) window is :data:`IN_MOTION_COARSE_S`, at most half the
    alignment (the filter refines the other half on the track's fixes).

    Raises
    ------
    LogError
        When the alignment would be shorter than :data:`IN_MOTION_MIN_S`.
    """
    length = float(align_s)
    if length > float(duration_s) - IN_MOTION_NAV_MIN_S:
        length = IN_MOTION_SHARE * float(duration_s)
    if length < IN_MOTION_MIN_S:
        raise LogError(
            f"an in-motion alignment of {length:.1f} s (align_s={align_s:g} s, or "
            f"{100 * IN_MOTION_SHARE:.0f} % of the {duration_s:.1f} s recording) is shorter "
            f"than the {IN_MOTION_MIN_S:g} s it needs: a moving recording aligned on its "
            f"track must last {math.ceil(IN_MOTION_MIN_S / IN_MOTION_SHARE)} s or more"
        )
    return length, min(IN_MOTION_COARSE_S, 0.5 * length)


def track_measurement(tr: Any, position_sd: float, velocity_sd: float) -> GnssTrack:
    """The filter's measurement of a track ``tr`` (``t`` [s], ``lat``, ``lon`` [rad], ``h``
    [m], ``v_n`` (m, 3) [m/s] or None): every ``stride``-th fix, so that at most
    :data:`TRACK_MAX_RATE_HZ` fixes a second are used (a FOG-INS's 100 Hz positions are
    correlated from sample to sample, and the coarse stage's five-point derivative wants
    them spaced), with ``position_sd`` [m] per coordinate and, when the track has
    velocities, ``velocity_sd`` [m/s] per component."""
    t = np.asarray(tr.t, dtype=float)
    step = float(np.median(np.diff(t))) if t.size > 1 else 1.0
    stride = max(1, math.ceil(1.0 / (TRACK_MAX_RATE_HZ * step) - 1e-6))
    v = getattr(tr, "v_n", None)
    return GnssTrack(
        t[::stride], tr.lat[::stride], tr.lon[::stride], tr.h[::stride], position_sd,
        v_n=None if v is None else v[::stride], velocity_sd=velocity_sd,
    )  # fmt: skip


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
    duration_s: float = math.inf,
    velocity_sd: float = 0.1,
) -> tuple[Any, Any, Window, Callable[[int], InMotionAligner]]:
    """The noise, alignment settings, window and aligner of an in-motion alignment on the
    track ``tr`` (its measurement: :func:`track_measurement` with ``position_sd`` [m] and
    ``velocity_sd`` [m/s]) from the recording's start ``t_first`` [s], the recording
    ``duration_s`` [s] long, ``align_s`` [s] asked for (cut by :func:`in_motion_lengths`:
    the window says the length used) (the noise the log's metadata's or ``imu=``'s: a
    moving recording has no still stretch to estimate it on: ``noise_of(log)`` reads the
    metadata's)."""
    if imu_noise is None and not log.noise:
        raise LogError(
            f"{path}: the recording moves and is aligned in motion on its track, which needs "
            "the IMU's noise: give imu= (a preset or IMU file), or a 'noise' entry in the "
            "log's metadata"
        )
    try:
        length, coarse_s = in_motion_lengths(align_s, duration_s)
    except LogError as exc:
        raise LogError(f"{path}: {exc}") from None
    noise = imu_noise or noise_of(log)
    window = Window(start_s=t_first, length_s=length, how="in motion")
    align = align_config(noise, window, coarse_s)
    imu = ImuNoise(
        noise.gyro_density, noise.accel_density, align.gyro_bias_sd, align.accel_bias_sd,
        noise.gyro_bias_rw, noise.accel_bias_rw,
    )  # fmt: skip
    track = track_measurement(tr, position_sd, velocity_sd)

    def aligner(k0: int) -> InMotionAligner:
        return InMotionAligner(track, imu, dt, t_first + k0 * dt, length, coarse_s, k0=k0)

    return noise, align, window, aligner


#: Coarse (OBA) window of an in-motion alignment [s], at most half the alignment
#: (:func:`rinscal.nav.inmotion.coarse_in_motion`).
IN_MOTION_COARSE_S = 60.0
#: Share of a moving recording an in-motion alignment takes when the one asked for leaves
#: less than :data:`IN_MOTION_NAV_MIN_S` to navigate (the rest is navigated).
IN_MOTION_SHARE = 0.6
#: Least navigation an in-motion alignment asked for must leave, else it is cut [s].
IN_MOTION_NAV_MIN_S = 10.0
#: Shortest in-motion alignment [s].
IN_MOTION_MIN_S = 20.0
#: Most fixes a second of a track that the filter (and the coarse stage) use [Hz].
TRACK_MAX_RATE_HZ = 10.0


def gnss_aiding(
    tr: Any, noise: Any, position_sd: float, dt: float, velocity_sd: float = 0.1
) -> dict[str, Any]:
    """The ``aiding=`` and ``aided_filter=`` of :func:`rinscal.nav.engine.navigate_pieces`
    for a track's fixes.

    Parameters
    ----------
    tr : Track
        The track (``t`` [s], ``lat``, ``lon`` [rad], ``h`` [m], optionally ``v_n`` [m/s]),
        thinned to :data:`TRACK_MAX_RATE_HZ` (:func:`track_measurement`).
    noise : Noise
        The sensor noise the alignment assumed (densities [rad/√s], [m/s²/√Hz], bias random
        walks [rad/s/√s], [m/s²/√s]).
    position_sd : float [m]
        Each fix coordinate's standard deviation.
    dt : float [s]
        Sample interval.
    velocity_sd : float [m/s]
        Each velocity component's standard deviation (a track with velocities).

    The filter starts where the alignment ended: position uncertain by ``position_sd``,
    velocity by ``position_sd`` per second, attitude and biases by the alignment's own
    standard deviations, the heading's at least
    :data:`rinscal.nav.gnss_ins.HEADING_PRIOR_SD` (the alignment's can be far too small).
    """
    track = track_measurement(tr, position_sd, velocity_sd)

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
