"""The one compensator's three modes give one bias: batch, streaming and causal (held)."""

from __future__ import annotations

import numpy as np
import pytest

from rinscal.calibration.compensator import Compensator, hold
from rinscal.schema import CHANNELS, NavSamples
from tests.calibration._helpers import linear_model, synthetic_log


def _stream(comp: Compensator, log, channels) -> tuple[np.ndarray, np.ndarray]:  # type: ignore[no-untyped-def]
    """Every row of ``log`` through :meth:`Compensator.update`, in order."""
    temps = log[[f"temp_{c}" for c in channels]].to_numpy()
    raw = log[list(channels)].to_numpy()
    t_out = log["temp_out"].to_numpy()
    rows, flags = [], []
    for i in range(len(log)):
        out, flag = comp.update(log["time_s"].iat[i], raw[i], temps[i], t_out[i])
        rows.append(out)
        flags.append(flag)
    return np.array(rows), np.array(flags)


@pytest.mark.parametrize("policy", ["clamp", "extrapolate"])
def test_streaming_equals_batch_to_1e_12(policy, fitted_models, repeat_small) -> None:  # type: ignore[no-untyped-def]
    """A fitted regression model (with ΔT): the same samples give the same output, batch
    with the causal rate or one sample at a time, and the same out-of-range flags."""
    mf = fitted_models["regression"]
    log = repeat_small[0].iloc[:900].reset_index(drop=True)
    comp = Compensator(mf, policy)
    values, flagged = comp.batch(log, derivative_kind="causal")
    got, flags = _stream(comp, log, mf.channels)
    want = np.column_stack([values[c] for c in mf.channels])
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=0)
    np.testing.assert_array_equal(flags, flagged)


def _pieces(log, dt: float, sizes: int):  # type: ignore[no-untyped-def]
    """A log's rows as NavSamples pieces of ``sizes`` samples (zero increments)."""
    t = log["time_s"].to_numpy()
    temps = log[[f"temp_{c}" for c in CHANNELS]].to_numpy()
    for a in range(0, t.size, sizes):
        b = slice(a, a + sizes)
        n = t[b].size
        yield NavSamples(t[b], np.full(n, dt), np.zeros((n, 3)), np.zeros((n, 3)), temps=temps[b])


def test_causal_read_every_sample_equals_batch() -> None:
    """Thermometers read at every sample (1 Hz samples, ``update_s`` 1 s): the causal mode
    subtracts what batch compensation with the causal rate removes, and the bias of the
    thermometer record (the simulator's path) is the same."""
    log = synthetic_log(np.random.default_rng(3), runs=1, n=400, dt=1.0, gradient=False)
    comp = Compensator(linear_model(), "clamp", update_s=1.0)
    values, _ = comp.batch(log, derivative_kind="causal")
    batch = -np.column_stack([values[c] for c in CHANNELS])  # N = 0: N − (f − r) = −bias
    causal = np.concatenate([comp(s) for s in _pieces(log, 1.0, 37)])
    np.testing.assert_allclose(causal, batch, rtol=1e-12, atol=1e-18)
    temps = log[[f"temp_{c}" for c in CHANNELS]].to_numpy()
    record = comp.record_bias_si(log["time_s"].to_numpy(), temps)
    np.testing.assert_allclose(record, batch, rtol=1e-12, atol=1e-18)
    assert comp.readings == 400 and np.ptp(batch) > 1e-7  # a bias that changes


def test_causal_holds_between_readings_the_known_bias() -> None:
    """Samples at 10 Hz, thermometers read once a second, temperatures rising linearly at
    ``a_j`` °C/s: the sample at ``t`` holds the reading of its second ``n`` (the first sample
    of that second, ``T = 20 + a_j (n + 0.1)``) and the causal slope of the readings
    (``60 a_j`` °C/min, 0 at the first reading), through ``f = 1e-6 T + 1e-5 Ṫ``."""
    rate_hz, n = 10.0, 600
    t = (np.arange(n) + 1.0) / rate_hz
    a = np.array([0.01, 0.02, -0.01, 0.005, 0.03, -0.02])  # °C/s
    temps = 20.0 + t[:, None] * a
    comp = Compensator(linear_model(), "clamp", update_s=1.0)
    dt = np.full(n, 1.0 / rate_hz)
    z = np.zeros((n, 3))
    got = np.concatenate(
        [comp(NavSamples(t[s], dt[s], z[s], z[s], temps=temps[s])) for s in np.split(
            np.arange(n), [7, 130, 131, 400])]
    )  # fmt: skip
    second = np.floor(t - 0.05 + 1e-9)
    want = 1e-6 * (20.0 + (second[:, None] + 0.1) * a) + 1e-5 * 60.0 * a * (second[:, None] > 0)
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=0)
    # held: constant within each second, a step at each new reading
    steps = np.flatnonzero(np.any(np.diff(got, axis=0) != 0, axis=1)) + 1
    np.testing.assert_array_equal(steps, np.flatnonzero(np.diff(second)) + 1)
    assert comp.readings == 60


def test_hold_takes_the_last_reading_at_or_before() -> None:
    grid = np.array([0.0, 1.0, 2.0])
    values = np.array([10.0, 11.0, 12.0])
    np.testing.assert_array_equal(
        hold(grid, values, np.array([-0.5, 0.0, 0.99, 1.0, 2.5])), [10.0, 10.0, 10.0, 11.0, 12.0]
    )


def test_reset_forgets_the_history_of_every_mode() -> None:
    """A second power-on after :meth:`Compensator.reset` gives what a fresh compensator
    gives, in the streaming and the causal mode alike."""
    log = synthetic_log(np.random.default_rng(4), runs=1, n=120, dt=1.0, gradient=True)
    comp = Compensator(linear_model(), "clamp")
    first = _stream(comp, log, CHANNELS)[0], np.concatenate([comp(s) for s in _pieces(log, 1, 50)])
    comp.reset()
    again = _stream(comp, log, CHANNELS)[0], np.concatenate([comp(s) for s in _pieces(log, 1, 50)])
    fresh = Compensator(linear_model(), "clamp")
    np.testing.assert_array_equal(again[0], first[0])
    np.testing.assert_array_equal(again[1], first[1])
    np.testing.assert_array_equal(_stream(fresh, log, CHANNELS)[0], first[0])
