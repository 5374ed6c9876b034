"""Properties of the navigation package: attitude round trips, schedules, chunking, rest."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from rinscal.nav.rotation import C_br, RotationSchedule
from rinscal.nav.strapdown import Strapdown, dcm_to_quat, quat_to_dcm, rotvec_to_dcm
from rinscal.sim.ideal_imu import ImuSynthesizer
from rinscal.sim.trajectory import (
    C_nb_from_euler,
    StaticMotion,
    euler_from_C_nb,
    vehicle_route,
)

angle = st.floats(-math.pi, math.pi, allow_nan=False)
FAST = settings(max_examples=40, deadline=None)


@FAST
@given(st.lists(st.floats(-3.0, 3.0, allow_nan=False), min_size=3, max_size=3))
def test_rotvec_quaternion_dcm_round_trip(rv: list[float]) -> None:
    C = rotvec_to_dcm(rv)
    np.testing.assert_allclose(C @ C.T, np.eye(3), atol=1e-14)
    assert np.linalg.det(C) > 0.999999
    np.testing.assert_allclose(quat_to_dcm(dcm_to_quat(C)), C, atol=1e-13)
    # the rotation axis is left unchanged
    np.testing.assert_allclose(C @ np.asarray(rv), np.asarray(rv), atol=1e-12)


@FAST
@given(st.lists(st.floats(-1.0, 1.0, allow_nan=False), min_size=4, max_size=4))
def test_one_quaternions_dcm_is_the_batchs_to_the_bit(q: list[float]) -> None:
    """A single quaternion's matrix (Python floats) and the same in a batch (numpy): the
    same bits, and the textbook matrix of a rotation where the quaternion is a unit one."""
    x = np.asarray(q)
    one = quat_to_dcm(x)
    batch = quat_to_dcm(np.stack([x, x]))
    np.testing.assert_array_equal(one, batch[0])
    if np.linalg.norm(x) > 0.1:
        u = x / np.linalg.norm(x)
        w, v = u[0], u[1:]
        skew_v = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
        textbook = np.eye(3) + 2 * w * skew_v + 2 * skew_v @ skew_v  # Rodrigues in quaternions
        np.testing.assert_allclose(quat_to_dcm(u), textbook, atol=1e-12)


@FAST
@given(angle, st.floats(-1.5, 1.5), angle)
def test_euler_round_trip(h: float, p: float, r: float) -> None:
    e = euler_from_C_nb(C_nb_from_euler([h, p, r]))
    np.testing.assert_allclose(C_nb_from_euler(e), C_nb_from_euler([h, p, r]), atol=1e-12)


@FAST
@given(
    st.floats(0.0, 120.0),
    st.floats(1.0, 30.0),
    st.one_of(st.none(), st.floats(1.0, 50.0)),
    st.floats(0.0, 1e5),
)
def test_four_position_schedule_is_periodic_and_bounded(
    dwell: float, rate: float, accel: float | None, t0: float
) -> None:
    s = RotationSchedule.four_position(dwell_s=dwell, rate_dps=rate, accel_dps2=accel)
    t = t0 + np.linspace(0.0, s.period, 257)
    phi, w, _ = s.evaluate(t)
    np.testing.assert_allclose(s.angle(t + s.period), phi, atol=1e-7)
    assert np.all(np.abs(w) <= rate * math.pi / 180 * (1 + 1e-12))
    assert np.all(np.abs(phi) <= math.pi * 135 / 180 + 1e-9)
    # continuity across every break point of one cycle
    for b in s.breakpoints(0.0, s.period):
        np.testing.assert_allclose(s.angle(b - 1e-7), s.angle(b + 1e-7), atol=1e-6)


@settings(max_examples=10, deadline=None)
@given(st.lists(st.integers(1, 700), min_size=1, max_size=6))
def test_synthesis_does_not_depend_on_chunking(sizes: list[int]) -> None:
    route = vehicle_route(duration_s=300.0, stationary_s=5.0)
    sched = RotationSchedule.four_position(dwell_s=5.0)
    n = sum(sizes)
    one = ImuSynthesizer(route, sched, 20.0).next_chunk(n)
    syn = ImuSynthesizer(route, sched, 20.0)
    parts = [syn.next_chunk(k) for k in sizes]
    for name in ("dtheta", "dv", "encoder", "v_n"):
        np.testing.assert_allclose(
            np.concatenate([getattr(p, name) for p in parts]),
            getattr(one, name),
            rtol=0,
            atol=1e-15,
        )
    for name in ("lat", "lon"):
        np.testing.assert_allclose(
            np.concatenate([getattr(p, name) for p in parts]),
            getattr(one, name),
            rtol=0,
            atol=1e-13,
        )


@FAST
@given(st.floats(-80.0, 80.0), angle, angle)
def test_exact_static_outputs_keep_the_ins_at_rest(
    lat_deg: float, heading: float, enc: float
) -> None:
    st_ = StaticMotion(lat_deg=lat_deg, heading_deg=math.degrees(heading))
    sched = RotationSchedule.none(math.degrees(enc))
    ch = ImuSynthesizer(st_, sched, 100.0).next_chunk(2000)
    C_nr = C_nb_from_euler(st_.euler0) @ C_br(enc)
    nav = Strapdown(st_.lat0, st_.lon0, st_.alt0, np.zeros(3), C_nr, 0.01)
    nav.run(ch.dtheta, ch.dv)
    assert np.max(np.abs(nav.v_n)) < 1e-9
    assert abs(nav.lat - st_.lat0) * 6.4e6 < 1e-8
    np.testing.assert_allclose(nav.C_nr, C_nr, atol=1e-12)
