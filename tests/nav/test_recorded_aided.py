"""The recording's aiding helpers (``rinscal.nav.recorded.aided``): the GNSS filter a
variant is handed to after its alignment starts from the alignment's uncertainties with the
heading's floored at the prior, and an in-motion alignment without the IMU's noise is
refused naming what to give."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from rinscal.errors import LogError
from rinscal.nav.aiding import GnssTrack
from rinscal.nav.gnss_ins import HEADING_PRIOR_SD, AidedInertial
from rinscal.nav.recorded.aided import AIDING, gnss_aiding, in_motion_alignment
from rinscal.nav.strapdown import Strapdown


def _track() -> SimpleNamespace:
    t = np.arange(0.0, 10.0)
    return SimpleNamespace(t=t, lat=np.full(10, 0.6), lon=np.full(10, 0.2), h=np.full(10, 30.0))


def test_the_gnss_filter_starts_from_the_alignment_with_a_heading_prior() -> None:
    assert AIDING == ("none", "gnss")
    noise = SimpleNamespace(
        gyro_density=1e-6, accel_density=5e-4, gyro_bias_rw=1e-9, accel_bias_rw=1e-7
    )
    kw = gnss_aiding(_track(), noise, position_sd=1.5, dt=0.01)
    (track,) = kw["aiding"]
    assert isinstance(track, GnssTrack)
    np.testing.assert_array_equal(track.times, np.arange(0.0, 10.0))
    nav = Strapdown(0.6, 0.2, 30.0, np.zeros(3), np.eye(3), 0.01, "free")
    res = SimpleNamespace(
        attitude_sd=np.array([1e-4, 1e-4, 1e-3]),  # heading sd 0.06°: far below the prior
        gyro_bias_sd=np.full(3, 1e-7),
        accel_bias_sd=np.full(3, 1e-4),
    )
    f = kw["aided_filter"](nav, res, np.zeros(3), np.zeros(3))
    assert isinstance(f, AidedInertial)
    sd = np.sqrt(np.diag(f.P))
    np.testing.assert_allclose(sd[:6], 1.5)  # position and velocity from the fix σ
    np.testing.assert_allclose(sd[6:8], 1e-4)  # tilts as the alignment left them
    assert sd[8] == pytest.approx(max(1e-3, HEADING_PRIOR_SD))  # the heading floored
    assert HEADING_PRIOR_SD == pytest.approx(math.radians(3.0))
    np.testing.assert_allclose(sd[9:12], 1e-7)
    np.testing.assert_allclose(sd[12:], 1e-4)


def test_an_in_motion_alignment_without_noise_is_refused() -> None:
    log = SimpleNamespace(noise=None)
    with pytest.raises(LogError, match=r"run\.parquet: the recording moves .* imu="):
        in_motion_alignment(
            log, None, lambda _: None, _track(), 1.5, 0.01, 0.0, 300.0, "run.parquet"
        )


def test_in_motion_lengths_and_a_fast_track_thinned() -> None:
    from rinscal.nav.recorded.aided import in_motion_lengths, track_measurement

    # an alignment that leaves 10 s or more is kept, its coarse window at most 60 s / half
    assert in_motion_lengths(300.0, 371.0) == (300.0, 60.0)
    assert in_motion_lengths(80.0, 100.0) == (80.0, 40.0)
    # one that leaves less: 60 % of the recording
    assert in_motion_lengths(600.0, 100.0) == pytest.approx((60.0, 30.0))
    assert in_motion_lengths(95.0, 100.0) == pytest.approx((60.0, 30.0))
    with pytest.raises(LogError, match="must last 34 s or more"):
        in_motion_lengths(600.0, 33.0)
    # a 100 Hz track with velocities: every 10th fix, equally spaced at 0.1 s
    t = 61.0 + 0.01 * np.arange(1, 1001)
    v = np.column_stack([t, -t, 0 * t])
    tr = SimpleNamespace(t=t, lat=t * 1e-6, lon=t * 2e-6, h=t, v_n=v)
    g = track_measurement(tr, 0.02, 0.05)
    np.testing.assert_allclose(np.diff(g.times), 0.1, atol=1e-9)
    assert g.times.size == 100 and g.v_n is not None
    np.testing.assert_array_equal(g.v_n[:, 0], g.times)
    assert g.position_sd == 0.02
    # a 1 Hz track kept whole, no velocities
    assert track_measurement(_track(), 1.5, 0.1).times.size == 10
