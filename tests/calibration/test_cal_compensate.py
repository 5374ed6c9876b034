"""Compensation (Eq. 10) in batch and sample by sample."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from rinscal.calibration.compensate import (
    FLAG_COLUMN,
    StreamingCompensator,
    compensate,
    model_features,
    predict_log,
)
from rinscal.errors import LogError, RangeError
from rinscal.schema import CHANNELS

METHODS = ("poly-t", "sectional", "regression", "neural")


@pytest.mark.parametrize("method", METHODS)
def test_output_generated_by_the_model_compensates_to_the_static_reference(
    method, fitted_models, repeat_small
) -> None:
    # a log whose outputs are exactly the model's f(T, Ṫ, ΔT) compensates to Earth rate and
    # gravity, constant to rounding
    mf = fitted_models[method]
    log = repeat_small[0].copy()
    f, _ = predict_log(log, mf)
    for j, c in enumerate(mf.channels):
        log[c] = f[:, j]
    out = compensate(log, mf, policy="extrapolate")
    ref = np.array([mf.models[c].static_reference for c in mf.channels])
    np.testing.assert_allclose(
        out[list(mf.channels)].to_numpy(),
        np.broadcast_to(ref, f.shape),
        rtol=0,
        atol=1e-9 * np.abs(f).max(),
    )


def test_every_row_and_column_is_kept_in_order(fitted_models, repeat_small) -> None:
    mf = fitted_models["regression"]
    log = repeat_small[0].copy()
    log["note"] = np.arange(len(log)) % 3  # a column the schema does not know
    log.index = np.arange(len(log))[::-1] * 10  # a non-trivial index
    log.loc[log.index[[5, 77]], "accel_y"] = np.nan  # dropped samples
    before = log.copy()
    out = compensate(log, mf)
    pd.testing.assert_frame_equal(log, before)  # input untouched
    assert list(out.columns) == [*log.columns, FLAG_COLUMN]
    pd.testing.assert_index_equal(out.index, log.index)
    untouched = [c for c in log.columns if c not in CHANNELS]
    pd.testing.assert_frame_equal(out[untouched], log[untouched])
    assert out["accel_y"].isna().sum() == 2 and np.isnan(out["accel_y"].iloc[5])
    assert out[FLAG_COLUMN].dtype == bool


@pytest.mark.parametrize(
    "method", [pytest.param(m, marks=pytest.mark.slow) if m == "neural" else m for m in METHODS]
)
def test_streaming_equals_batch_with_the_causal_rate(method, fitted_models, repeat_small) -> None:
    mf = fitted_models[method]
    log = repeat_small[0].iloc[:900].reset_index(drop=True)
    batch = compensate(log, mf, policy="clamp", derivative_kind="causal")
    comp = StreamingCompensator(mf, policy="clamp")
    temps = log[[f"temp_{c}" for c in mf.channels]].to_numpy()
    raw = log[list(mf.channels)].to_numpy()
    rows, flags = [], []
    for i in range(len(log)):
        out, flag = comp.update(log["time_s"].iat[i], raw[i], temps[i], log["temp_out"].iat[i])
        rows.append(out)
        flags.append(flag)
    want = batch[list(mf.channels)].to_numpy()
    np.testing.assert_allclose(np.array(rows), want, rtol=1e-9, atol=0)
    np.testing.assert_array_equal(flags, batch[FLAG_COLUMN].to_numpy())


def test_streaming_with_a_shared_temperature_and_a_new_run(fitted_models, repeat_small) -> None:
    mf = fitted_models["poly-t"]
    log = repeat_small[0].iloc[:400].reset_index(drop=True)
    shared = log.drop(columns=[f"temp_{c}" for c in CHANNELS]).assign(temp_in=log["temp_accel_x"])
    batch = compensate(shared, mf, derivative_kind="causal")[list(CHANNELS)].to_numpy()
    comp = StreamingCompensator(mf)
    for _ in range(2):  # a second power-on starts from scratch after reset()
        got = np.array(
            [
                comp.update(t, r, tin, tout)[0]
                for t, r, tin, tout in zip(
                    shared["time_s"],
                    shared[list(CHANNELS)].to_numpy(),
                    shared["temp_in"],
                    shared["temp_out"],
                    strict=True,
                )
            ]
        )
        np.testing.assert_allclose(got, batch, rtol=1e-9)
        comp.reset()


def test_policies_outside_the_training_range(fitted_models, repeat_small) -> None:
    mf = fitted_models["regression"]
    log = repeat_small[0].iloc[:600].reset_index(drop=True).copy()
    hot = log.index >= 300
    for c in CHANNELS:
        log.loc[hot, f"temp_{c}"] += 40.0  # far above the soak range
    log.loc[hot, "temp_out"] += 40.0
    ext = compensate(log, mf, policy="extrapolate")
    clamp = compensate(log, mf, policy="clamp")
    assert ext[FLAG_COLUMN].to_numpy()[hot].all()
    np.testing.assert_array_equal(ext[FLAG_COLUMN], clamp[FLAG_COLUMN])
    # clamped: the inputs are clipped to the training range before the model is evaluated
    feats = model_features(log, mf)
    j = CHANNELS.index("accel_x")
    x = feats.matrix(j)
    lo, hi = mf.models["accel_x"].train_range.T
    want = mf.predict_channel("accel_x", np.clip(x, lo, hi))[0]
    ref = mf.models["accel_x"].static_reference
    np.testing.assert_allclose(clamp["accel_x"], log["accel_x"] - (want - ref), rtol=1e-12)
    assert not np.allclose(clamp["accel_x"][hot], ext["accel_x"][hot])
    # rows counted from 1 like every other message, the run and time named, plain numbers
    with pytest.raises(
        RangeError, match=r"gyro_x: data row [1-9]\d* \(run 'repeat.*, time .* s\) has T"
    ) as err:
        compensate(log, mf, policy="error")
    assert "np.float64" not in str(err.value) and "sample 0" not in str(err.value)


def test_missing_channel_and_bad_policy(fitted_models, repeat_small) -> None:
    mf = fitted_models["poly-t"]
    with pytest.raises(LogError, match="accel_z"):
        compensate(repeat_small[0].drop(columns="accel_z"), mf)
    with pytest.raises(ValueError, match="policy"):
        compensate(repeat_small[0], mf, policy="wrap")  # type: ignore[arg-type]
