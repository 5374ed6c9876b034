"""Model selection on held-out runs (Tables 5 and 7, honestly)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from rinscal.calibration.selection.heldout import select_model
from rinscal.calibration.thermal.features import build_features
from rinscal.errors import ConfigError
from tests.calibration._helpers import synthetic_log
from tests.conftest import NEURAL_FAST


def _quadratic_log(seed: int = 0):
    rng = np.random.default_rng(seed)
    log = synthetic_log(rng, runs=5, n=600)
    feats = build_features(log)
    x = [feats.temp, feats.rate, feats.grad]
    y = 50.0 + 0.0  # pulses
    y = (
        y
        + 2.0 * (x[0] - 20)
        + 0.08 * (x[0] - 20) ** 2
        + 30.0 * x[1]
        - 40.0 * x[1] ** 2
        + 5.0 * x[2]
        + 3.0 * x[2] ** 2
    )
    y = y + rng.normal(0, 0.05, y.shape) + rng.normal(0, 0.1, (5, 6))[feats.run_codes]
    for j, c in enumerate(feats.channels):
        log[c] = y[:, j]
    return log, dataclasses.replace(feats, output=y)


def test_selection_recommends_the_true_order() -> None:
    log, feats = _quadratic_log()
    res = select_model(log, "regression", features=feats, channels=("gyro_x", "accel_y"))
    assert res.recommended == {"gyro_x": 2, "accel_y": 2}
    t = res.table.set_index(["channel", "setting"])
    for c in ("gyro_x", "accel_y"):
        # order 1 misses the curvature on held-out runs too; the per-run offsets (turn-on)
        # do not count: both RMS are about the run mean, near the 0.05 white noise
        assert t.loc[(c, 1), "rms_heldout"] > 3 * t.loc[(c, 2), "rms_heldout"]
        assert t.loc[(c, 2), "rms_heldout"] < 0.07
        assert t.loc[(c, 2), "rms_train"] <= t.loc[(c, 2), "rms_heldout"]
    assert res.runs == ("run0", "run1", "run2", "run3", "run4")
    doc = res.to_dict()
    assert doc["recommended"] == res.recommended and len(doc["table"]) == 8


def test_tolerance_picks_the_smallest_good_setting() -> None:
    log, feats = _quadratic_log(1)
    strict = select_model(log, "regression", features=feats, channels=("accel_z",), tolerance=0)
    assert strict.recommended["accel_z"] == strict.best["accel_z"]
    loose = select_model(log, "regression", features=feats, channels=("accel_z",), tolerance=1e3)
    assert loose.recommended["accel_z"] == 1


def test_neural_selection_needs_more_neurons_for_more_curvature() -> None:
    # quadratics in T, Ṫ and ΔT at once: one sigmoid neuron bends along a single direction
    # and misses most of it on held-out runs; two capture most, three nearly all
    log, feats = _quadratic_log()
    res = select_model(
        log,
        "neural",
        settings=(1, 2, 3),
        features=feats,
        channels=("accel_x",),
        estimator_params=NEURAL_FAST,
    )
    y, codes = feats.output[:, 3], feats.run_codes
    spread = np.sqrt(np.mean((y - (np.bincount(codes, y) / np.bincount(codes))[codes]) ** 2))
    held = res.table.set_index("setting")["rms_heldout"]
    assert list(held.index) == [1, 2, 3]
    assert held[1] > 0.1 * spread  # one neuron: a poor model of this surface
    assert held[2] < 0.25 * held[1] and held[3] < held[2]
    assert held[3] < 0.05 * spread
    assert res.recommended["accel_x"] == res.best["accel_x"] == 3


def test_selection_needs_two_runs_and_a_known_method(soak_small) -> None:
    log, _, _ = soak_small
    one = log[log["run"] == log["run"].iloc[0]]
    with pytest.raises(ConfigError, match="at least 2 runs"):
        select_model(one, "regression", channels=("gyro_x",))
    with pytest.raises(ConfigError, match="regression and neural"):
        select_model(log, "sectional")


def test_regression_selection_from_per_run_factors_equals_refitting(soak_small) -> None:
    """Leave-one-run-out from per-run QR factors equals fitting every fold from the data."""
    from rinscal.calibration.thermal.estimators import Regression
    from rinscal.calibration.thermal.features import DerivativeConfig, OutlierConfig, build_features

    res = select_model(soak_small[0], "regression", settings=(1, 2, 3))
    feats = build_features(soak_small[0], DerivativeConfig(), OutlierConfig())
    codes, n_runs = feats.run_codes, len(feats.runs)

    def about_mean(resid, c):
        sums = np.bincount(c, weights=resid, minlength=n_runs)
        cnt = np.bincount(c, minlength=n_runs)
        return np.sqrt(np.mean((resid - (sums / np.maximum(cnt, 1))[c]) ** 2))

    for j, ch in enumerate(feats.channels):
        x, y = feats.matrix(j), feats.output[:, j]
        ok = feats.inlier[:, j] & np.all(np.isfinite(x), axis=1)
        for s in (1, 2, 3):
            est = Regression(s, s, s).fit(x[ok], y[ok])
            train = about_mean(est.predict(x[ok]) - y[ok], codes[ok])
            resid = np.empty(int(ok.sum()))
            for k in range(n_runs):
                te = codes[ok] == k
                fold = Regression(s, s, s).fit(x[ok][~te], y[ok][~te])
                resid[te] = fold.predict(x[ok][te]) - y[ok][te]
            held = about_mean(resid, codes[ok])
            row = res.table[(res.table["channel"] == ch) & (res.table["setting"] == s)].iloc[0]
            assert row["rms_train"] == pytest.approx(train, rel=1e-9), (ch, s)
            assert row["rms_heldout"] == pytest.approx(held, rel=1e-9), (ch, s)


def test_a_run_span_from_the_callers_range_is_the_searched_one() -> None:
    """:func:`run_span` given the run's range (``whole``, a run not cut) is the span it finds
    itself; a run cut into legs ignores it (each segment's range is searched)."""
    from rinscal.calibration.selection.folds import run_span

    rng = np.random.default_rng(5)
    for n in (1, 2, 17, 5000):
        temp = 20 + np.cumsum(rng.normal(0, 0.1, n))
        for cut in (False, True):
            want = run_span(3, temp, cut)
            got = run_span(3, temp, cut, whole=(float(temp.min()), float(temp.max())))
            for f in dataclasses.fields(want):
                a, b = getattr(want, f.name), getattr(got, f.name)
                if isinstance(a, np.ndarray):
                    assert a.tobytes() == b.tobytes() and a.dtype == b.dtype, f.name
                else:
                    assert a == b, f.name
