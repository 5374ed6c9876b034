"""The in-motion alignment and GNSS aiding inside the one engine (`navigate_pieces`) are the
array filter of `rinscal.nav.inmotion.navigate_aided` fed piece by piece: same answer."""

from __future__ import annotations

import numpy as np
import pytest

from rinscal.errors import ConfigError
from rinscal.nav.engine import navigate_pieces
from rinscal.nav.gnss_ins import AidedInertial
from rinscal.nav.inmotion import InMotionAligner, navigate_aided
from rinscal.schema import NavSamples
from rinscal.sim.config import load_imu
from tests.nav._drive import GNSS_SD_M, paper_noise, simulate_drive


class _Truth:
    """The drive's truth at a piece's samples (interpolated from its whole seconds); heading,
    pitch and roll unknown (NaN), no table."""

    def __init__(self, d, s: NavSamples) -> None:  # type: ignore[no-untyped-def]
        self.t = s.t
        at = [np.interp(s.t, d.t, x) for x in (d.lat, d.lon, d.alt, *d.v_n.T)]
        self.table = np.column_stack(at)
        self.alt = self.table[:, 2]
        self.vu = self.table[:, 5]

    def rows(self, sel: np.ndarray) -> np.ndarray:
        m = int(sel.sum())
        return np.column_stack(
            [self.t[sel], self.table[sel], np.full((m, 3), np.nan), np.zeros(m), np.ones(m)]
        )


def _pieces(d, seconds: int):  # type: ignore[no-untyped-def]
    """The drive cut into pieces of ``seconds`` whole seconds."""
    per = round(seconds / d.dt)
    n = d.dtheta.shape[0]
    for a in range(0, n, per):
        b = min(n, a + per)
        t = (np.arange(a, b) + 1) * d.dt
        yield NavSamples(t=t, dt=np.full(b - a, d.dt), dtheta=d.dtheta[a:b], dv=d.dv[a:b])


def test_the_engine_aligns_in_motion_as_the_array_filter_does() -> None:
    d = simulate_drive(150.0, seed=3)
    noise = paper_noise(load_imu("paper"))
    ref = navigate_aided(d.dtheta, d.dv, d.dt, d.track, noise).aided
    made: list[InMotionAligner] = []

    def aligner(k0: int) -> InMotionAligner:
        made.append(InMotionAligner(d.track, noise, d.dt, k0 * d.dt, 150.0, 60.0, "free", k0))
        return made[-1]

    run = navigate_pieces(
        _pieces(d, 7), lambda s: _Truth(d, s), {"none": None}, dt=d.dt, start_s=0.0, out_every=50,
        aligner=aligner,
    )  # fmt: skip
    assert run.aligned and run.n_start == 0
    res = run.alignment["none"]
    assert res is not None
    nav = made[0].nav
    assert nav is not None
    # the same filter on the same data, its steps ending at the same samples (the fixes and
    # the pieces' ends fall on whole seconds): the same answer, to round-off
    assert np.allclose(res.C_nr, ref.C_nr[-1], rtol=0.0, atol=1e-12)
    assert nav.lat == pytest.approx(ref.lat[-1], rel=0, abs=1e-13)
    assert nav.lon == pytest.approx(ref.lon[-1], rel=0, abs=1e-13)
    assert np.allclose(res.gyro_bias, ref.gyro_bias[-1], rtol=1e-9, atol=0.0)
    assert np.allclose(res.accel_bias, ref.accel_bias[-1], rtol=1e-9, atol=0.0)


def test_the_engine_takes_gnss_fixes_after_its_alignment() -> None:
    """After 90 s of in-motion alignment, aided by the fixes for the next 90 s: each
    coordinate's position error RMS at most the fixes' σ; pure inertial from the same
    hand-over drifts further. Aiding without a filter to take it is refused."""
    d = simulate_drive(180.0, seed=4)
    noise = paper_noise(load_imu("paper"))

    def start(k0: int) -> InMotionAligner:
        return InMotionAligner(d.track, noise, d.dt, k0 * d.dt, 90.0, 60.0, "free", k0)

    def aided(nav, res, gb, ab) -> AidedInertial:  # type: ignore[no-untyped-def]
        sd = np.concatenate([np.full(6, GNSS_SD_M), res.attitude_sd, res.gyro_bias_sd,
                             res.accel_bias_sd])  # fmt: skip
        return AidedInertial(nav, np.diag(sd**2), noise, gb, ab)

    kw = {"dt": d.dt, "start_s": 0.0, "out_every": round(1.0 / d.dt), "aligner": start}
    truth = lambda s: _Truth(d, s)  # noqa: E731
    on = navigate_pieces(_pieces(d, 10), truth, {"none": None}, aiding=[d.track],
                         aided_filter=aided, **kw)  # fmt: skip
    off = navigate_pieces(_pieces(d, 10), truth, {"none": None}, **kw)
    e_on, e_off = on.errors["none"], off.errors["none"]
    assert e_on["time_s"].iloc[0] == pytest.approx(91.0) and len(e_on) == len(e_off) == 90
    rms = float(np.sqrt(np.mean(e_on["horizontal_m"] ** 2) / 2))
    assert rms <= GNSS_SD_M, rms
    assert e_off["horizontal_m"].max() > 2 * e_on["horizontal_m"].max()  # 10.3 m against 2.4
    with pytest.raises(ConfigError, match="aided_filter"):
        navigate_pieces(_pieces(d, 10), truth, {"none": None}, aiding=[d.track], **kw)
