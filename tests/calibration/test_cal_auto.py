"""``fit --method auto``: held-out choice, joint-domain check and fallback.

Physics first: a log whose drift is a cubic in T gets a model of T alone, one with a
temperature-rate term gets a rate term, pure noise gets no compensation; the fast held-out
path equals fitting every fold by hand; the joint domain flags the real log's hot-and-cooling
leg, and the fallback keeps the network from making it worse than no compensation.
"""

from __future__ import annotations

import json
import math
import warnings

import numpy as np
import pandas as pd
import pytest

from rinscal.calibration._domain import fit_domain, inside_domain
from rinscal.calibration.compensate import compensate
from rinscal.calibration.evaluate import evaluate
from rinscal.calibration.modelfile import ThermalModelFile
from rinscal.calibration.selection.auto import (
    _averaging_blocks,
    _polynomial_scores,
    choose,
    select_channel,
)
from rinscal.calibration.selection.candidates import Candidate, candidates
from rinscal.calibration.selection.folds import holdout_folds
from rinscal.calibration.thermal.estimators import Regression
from rinscal.calibration.thermal.model import ThermalModel
from rinscal.schema import CHANNELS
from tests._shared import real_log_path

META = {"units": {"gyro": "deg/h", "accel": "ug"}}


def _runs(n_runs: int = 5, n: int = 1200, seed: int = 0) -> tuple[np.ndarray, ...]:
    """Cold starts at several set points: x (T, Ṫ [°C/min], ΔT), run codes, time."""
    rng = np.random.default_rng(seed)
    xs, codes, ts = [], [], []
    for k in range(n_runs):
        t = (np.arange(n) + 1.0) * 3.0
        tau = 700.0 + 300.0 * k
        temp = 5.0 + 9.0 * k + 15.0 * (1 - np.exp(-t / tau)) + rng.normal(0, 0.01, n)
        rate = 15.0 / tau * np.exp(-t / tau) * 60.0
        grad = 2.0 * np.exp(-t / 500.0) + 0.3
        xs.append(np.column_stack([temp, rate, grad]))
        codes.append(np.full(n, k))
        ts.append(t)
    return np.vstack(xs), np.concatenate(codes), np.concatenate(ts)


def _chosen(y_of_x, seed: int = 0, noise: float = 1.0) -> tuple[Candidate, dict]:
    x, codes, t = _runs(seed=seed)
    rng = np.random.default_rng(seed + 100)
    y = y_of_x(x) + rng.normal(0, noise, x.shape[0])
    cands = candidates("accel", 3)
    sel = select_channel(x, y, codes, [f"r{k}" for k in range(5)], t, cands)
    return sel.chosen, {r["name"]: r for r in sel.table}


def test_a_cubic_in_t_gets_a_model_of_t_alone() -> None:
    chosen, table = _chosen(lambda x: 40 * (x[:, 0] - 25) + 0.5 * (x[:, 0] - 25) ** 2)
    assert chosen.t_only and chosen.family != "none", chosen
    assert table[chosen.name]["heldout_rms"] < 1.1  # the noise, σ = 1


def test_a_rate_term_is_found_when_it_is_there() -> None:
    chosen, table = _chosen(lambda x: 5 * (x[:, 0] - 25) + 300 * x[:, 1])
    assert chosen.orders is not None and chosen.orders[1] >= 1, chosen
    best_t_only = min(
        r["heldout_rms"]
        for r in table.values()
        if r["heldout_rms"] is not None and r["name"].startswith(("poly-t", "px4", "ardupilot"))
    )
    assert table[chosen.name]["heldout_rms"] < 0.5 * best_t_only


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_noise_alone_gets_no_compensation(seed) -> None:
    chosen, _ = _chosen(lambda x: np.zeros(x.shape[0]), seed=seed)
    assert chosen.name == "none"


@pytest.mark.parametrize("seed", [3, 4, 5, 6])
def test_the_choice_is_never_worse_than_none_on_held_out_data(seed) -> None:
    rng = np.random.default_rng(seed)
    a, b = rng.normal(0, 1, 2)
    chosen, table = _chosen(lambda x: a * (x[:, 0] - 25) + b * 20 * x[:, 1], seed=seed)
    assert table[chosen.name]["heldout_rms"] <= table["none"]["heldout_rms"]


def test_held_out_scores_equal_fitting_each_fold_by_hand() -> None:
    x, codes, t = _runs(n_runs=4, n=700, seed=9)
    rng = np.random.default_rng(9)
    y = 3 * x[:, 0] + 50 * x[:, 1] ** 2 - 4 * x[:, 2] + rng.normal(0, 0.3, x.shape[0])
    scored = rng.random(x.shape[0]) > 0.2  # score a subset of each held-out fold
    blocks = _averaging_blocks(codes, codes, t, scored)
    cands = [c for c in candidates("accel", 3) if c.name in ("none", "regression 2,1,3")]
    fast = _polynomial_scores(x, y, codes, 4, cands, blocks)
    for cand in cands:
        ss, _ = fast[cand.name]
        for k in range(4):
            tr, te = codes != k, (codes == k) & scored
            p, q, s = cand.orders
            if p == 0:  # none: a constant, the held-out residual about its own mean
                resid = y[te]
            else:
                est = Regression(t_order=p, rate_order=q, grad_order=s).fit(x[tr], y[tr])
                resid = y[te] - est.predict(x[te])
            # 60 s means of the residual, by hand: (run, minute) of each scored sample
            frame = pd.DataFrame({"r": resid, "m": np.floor(t[te] / 60.0)})
            means = frame.groupby("m")["r"].mean().to_numpy()
            expect = np.sum((means - means.mean()) ** 2)
            assert ss[k] == pytest.approx(expect, rel=1e-8), (cand.name, k)


def test_within_noise_is_a_paired_t_test_on_log_ratios() -> None:
    cands = [
        Candidate("none", "none", "poly-t", {}, 0),
        Candidate("a", "poly-t", "poly-t", {}, 2),
        Candidate("b", "regression", "regression", {}, 6),
    ]
    # b is best (mean 3.6). a against b, unit by unit: ln(4.1/4.1) = 0, ln(3/3) = 0,
    # ln(4.4/3.7) = 0.1733; mean 0.05776, sample sd 0.1000, SE 0.05776: t = 1.000, below
    # the 90 % quantile of Student's t with 2 degrees of freedom (1.886): a is within noise
    # and has fewer parameters. none: ln(9/4.1), ln(9.5/3), ln(8.5/3.7) = 0.786, 1.153, 0.832;
    # t = 8.0: worse.
    mse = np.array([[9.0, 9.5, 8.5], [4.1, 3.0, 4.4], [4.1, 3.0, 3.7]])
    d = np.log(mse[1] / mse[2])
    assert d.mean() / (d.std(ddof=1) / np.sqrt(3)) == pytest.approx(1.0, abs=1e-3)
    assert choose(cands, mse, tolerance=0.0).name == "a"
    # a worse on every unit by 20-70 %: ln ratios 0.198, 0.531, 0.301, t = 3.50 > 1.886
    mse[1] = [5.0, 5.1, 5.0]
    assert choose(cands, mse, tolerance=0.0).name == "b"
    # ... unless the confidence asked for is higher (97.5 %: t quantile 4.303; none still out)
    assert choose(cands, mse, tolerance=0.0, confidence=0.975).name == "a"
    # a relative tolerance widens "within noise": 5.033 <= 1.5 * 3.6
    assert choose(cands, mse, tolerance=0.5).name == "a"
    # a candidate that failed on a fold is never chosen
    mse[2, 0] = np.nan
    assert choose(cands, mse).name == "a"


def test_the_field_s_fit_comes_before_other_models_within_noise() -> None:
    cands = [
        Candidate("none", "none", "poly-t", {}, 0),
        Candidate("ardupilot", "ardupilot", "ardupilot", {}, 3),
        Candidate("px4", "px4", "px4", {}, 3),
        Candidate("poly-t 1", "poly-t", "poly-t", {}, 1),
    ]
    # poly-t 1 best, the two cubics 1-3 % worse unit by unit but not consistently, none
    # ten times worse: ArduPilot's (the least-squares cubic) before PX4's, before poly-t 1
    mse = np.array(
        [[10.0, 11.0, 9.0, 10.0], [1.03, 0.99, 1.02, 1.01], [1.01, 1.0, 1.04, 0.98], [1.0] * 4]
    )
    assert choose(cands, mse).name == "ardupilot"
    mse[1] *= 1.5  # ArduPilot's now clearly worse
    assert choose(cands, mse).name == "px4"


def test_folds_leave_one_run_out_legs_and_blocks() -> None:
    x, codes, _ = _runs(n_runs=3, n=100)
    f = holdout_folds(codes, ["a", "b", "c"], x[:, 0])
    assert f.scheme == "leave-one-run-out" and f.names == ("a", "b", "c")
    assert np.array_equal(f.codes, codes)
    # one thermal cycle: cool, heat, cool
    temp = np.concatenate([np.linspace(50, -10, 400), np.linspace(-10, 70, 500)])
    temp = np.concatenate([temp, np.linspace(70, 40, 300)])
    f = holdout_folds(np.zeros(temp.size, dtype=int), ["cycle"], temp)
    assert f.scheme == "legs" and f.names == ("cycle/cool1", "cycle/heat", "cycle/cool2")
    assert np.abs(np.bincount(f.codes) - [400, 500, 300]).max() <= 1  # turns at the extremes
    # each leg is left out whole, and scored in 3 blocks: 8 scoring units at least
    assert len(f.unit_names) == 9 and f.unit_names[:4] == (
        "cycle/cool1/1",
        "cycle/cool1/2",
        "cycle/cool1/3",
        "cycle/heat/1",
    )
    assert np.array_equal(f.unit_fold, np.repeat([0, 1, 2], 3))
    assert np.array_equal(f.unit_fold[f.units], f.codes)
    assert np.all(np.diff(f.units) >= 0)  # contiguous
    # one monotone warm-up: contiguous blocks
    f = holdout_folds(np.zeros(800, dtype=int), ["w"], np.linspace(10, 30, 800))
    assert f.scheme == "blocks" and len(f.names) == 8 and np.array_equal(f.units, f.codes)
    assert np.all(np.diff(f.codes) >= 0)


def test_domain_grid_flags_what_the_data_never_covered() -> None:
    # an L of training data: low T at any rate, or any T at low rate
    rng = np.random.default_rng(0)
    x = np.column_stack([rng.uniform(0, 60, 20000), rng.uniform(-3, 3, 20000)])
    x = x[(x[:, 0] < 20) | (x[:, 1] < -1)]
    d = fit_domain(x)
    probe = np.array([[50.0, 2.5], [10.0, 2.5], [50.0, -2.5], [61.0, -2.0], [75.0, -2.0]])
    assert inside_domain(d, probe).tolist() == [False, True, True, True, False]
    json.dumps(d)  # a plain JSON object


def test_auto_model_file_round_trip_and_version_1(tmp_path, soak_small) -> None:
    log, _, meta = soak_small
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mf = ThermalModel("auto").fit(log, meta).to_file()
    path = mf.save(tmp_path / "auto.json")
    back = ThermalModelFile.load(path)
    assert back.method == "auto"
    for c in CHANNELS:
        sel = back.models[c].selection
        assert sel["scheme"] == "leave-one-run-out" and len(sel["folds"]) == 7
        assert {r["name"] for r in sel["table"]} >= {"none", "px4", "ardupilot", "poly-t 3"}
        assert back.models[c].fallback is not None
    x = np.column_stack([np.linspace(5, 50, 50), np.zeros(50), np.ones(50)])
    for c in CHANNELS:
        assert np.array_equal(
            back.predict_channel(c, x, "fallback")[0], mf.predict_channel(c, x, "fallback")[0]
        )
    # a version-1 file (no domain, fallback, selection) still loads and compensates
    ref = ThermalModel("regression").fit(log, meta).to_file()
    doc = ref.to_dict()
    doc["schema_version"] = 1
    del doc["payload"]["imu_calibration"]  # schema 3 added it
    for cm in doc["payload"]["channel_models"].values():
        for key in ("domain", "fallback", "selection"):
            del cm[key]
    from rinscal.calibration.modelfile import payload_sha256

    doc["sha256"] = payload_sha256(doc["payload"])
    old = ThermalModelFile.from_dict(doc)
    assert old.models["gyro_x"].domain is None
    inputs = (x[:, 0], x[:, 1], x[:, 2])
    assert np.array_equal(old.predict(*inputs), ref.predict(*inputs))


def _real_legs():
    from rinscal.experiments.paper.calibration import real_log_legs, tofupilot_mapping
    from rinscal.io.tables import read_log

    path = real_log_path()
    if not path.exists():
        pytest.skip(f"real log not found at {path}")
    log = real_log_legs(read_log(path, tofupilot_mapping()))
    units = {c: "rad/s" if c.startswith("gyro") else "m/s^2" for c in CHANNELS}
    return log[log["run"] != "leg3_cool"], log[log["run"] == "leg3_cool"], {"units": units}


def test_joint_domain_flags_the_real_logs_hot_and_cooling_samples() -> None:
    train, test, meta = _real_legs()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mf = ThermalModel("regression").fit(train, meta).to_file()
    out = compensate(test, mf, "clamp")
    flagged = out["out_of_range"].to_numpy()
    t_cool_max = train.loc[train["run"] == "leg1_cool", "temp_in"].max()  # 51.6 °C
    temp = test["temp_in"].to_numpy()
    hot_cooling = temp > t_cool_max + 4.0  # beyond one grid cell (3.8 °C) of the data
    assert hot_cooling.sum() > 1000
    # every input lies in its own training range: only the joint check can flag these
    assert temp.min() > train["temp_in"].min() and temp.max() < train["temp_in"].max() + 0.01
    assert flagged[hot_cooling].mean() > 0.95
    # (the rest of leg 3 cools at −2.5 °C/min where leg 1 cooled at −7 to −8.5 °C/min: it is
    # outside the data too, and flagged); the training legs themselves are not flagged
    assert compensate(train, mf, "clamp")["out_of_range"].mean() < 0.005


def test_fallback_keeps_the_network_from_making_accel_x_worse() -> None:
    train, test, meta = _real_legs()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mf = ThermalModel("neural", channels=("accel_x",), random_state=0).fit(train, meta)
    mf = mf.to_file()
    ev = {p: evaluate(test, mf, p).iloc[0] for p in ("clamp", "fallback")}
    none = ev["clamp"]["rms_before"]
    assert ev["fallback"]["rms_after"] < none
    assert ev["fallback"]["out_of_range"] > 0.4 * len(test)
    # on the flagged rows the output is the channel's cubic in T (clamped), exactly
    out = compensate(test, mf, "fallback")
    flagged = out["out_of_range"].to_numpy()
    cm = mf.models["accel_x"]
    from rinscal.calibration.inference import predict_params

    t = np.clip(test["temp_in"].to_numpy()[flagged], *cm.train_range[0])
    expect = test["accel_x"].to_numpy()[flagged] - predict_params(cm.fallback, t[:, None])
    assert np.allclose(out["accel_x"].to_numpy()[flagged], expect, rtol=0, atol=1e-12)


def test_auto_on_the_real_log_is_never_worse_than_none_on_its_held_out_legs() -> None:
    train, _, meta = _real_legs()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mf = ThermalModel("auto").fit(train, meta).to_file()
    for c in CHANNELS:
        sel = mf.models[c].selection
        assert sel["scheme"] == "legs" and len(sel["folds"]) == 8
        assert sel["folds"][0] == "leg1_cool/cool/1" and sel["folds"][4] == "leg2_heat/heat/1"
        rows = {r["name"]: r for r in sel["table"]}
        assert rows[sel["chosen"]]["heldout_rms"] <= rows["none"]["heldout_rms"]
    frame = pd.DataFrame(mf.models["accel_x"].selection["table"])
    assert len(frame) == 19 and frame["heldout_rms"].notna().all()  # T, Ṫ: no ΔT candidates


def test_the_field_s_final_fit_reuses_its_filter_and_equals_the_tool_s_fit() -> None:
    from rinscal.calibration.selection.auto import _baseline_screens
    from rinscal.calibration.thermal.baselines import ardupilot_fit, px4_fit

    x, codes, t = _runs(n_runs=4, n=900, seed=11)
    rng = np.random.default_rng(11)
    y = 0.02 * (x[:, 0] - 20) ** 2 + rng.normal(0, 0.1, x.shape[0])
    cands = candidates("accel", 3, families=("px4", "ardupilot"))
    fit = _baseline_screens(x[:, 0], y, codes, t, codes, cands)
    want = {
        "px4": px4_fit(x[:, 0], y, codes, sensor="accel"),
        "ardupilot": ardupilot_fit(x[:, 0], y, t, codes, sensor="accel"),
    }
    for method, expect in want.items():
        got = fit(method, None)
        assert got.keys() == expect.keys()
        for key, value in expect.items():
            if isinstance(value, str):
                assert got[key] == value
            else:
                np.testing.assert_allclose(got[key], value, rtol=1e-12, atol=0, err_msg=key)


# ----------------------------------------------------------------------------- streamed choice


def _feed(x, y, codes, t, most: int, tools=("px4", "ardupilot")):
    """What a log read a run at a time leaves of one channel for the choice."""
    from rinscal.calibration.thermal.runs import RowSample

    sample = RowSample(most, tools)
    for k in np.unique(codes):
        r = codes == k
        sample.add(int(k), x[r], y[r], t[r])
    return sample


def _streamed(x, y, codes, runs, t, cands, most: int):
    """The choice made from the streamed sample (as ``fit`` makes it)."""
    from rinscal.calibration.selection.auto import select_thinned

    sample = _feed(x, y, codes, t, most)
    xs, ys, cs, rows, ts, tools = sample.arrays()
    return select_thinned(xs, ys, cs, rows, ts, sample.spans, runs, tools, cands)


def _same_choice(x, y, codes, runs, t, monkeypatch, most: int | None = None) -> None:
    """The streamed choice is :func:`select_channel`'s on the whole rows, to every held-out
    score and the field's fits. ``most``: both keep at most that many rows (the reference
    every ceil(n / most)-th, the stream every 2^j-th: the same rows when that is a power
    of two); the field's held-out fits then see other filtered samples of the same runs
    (their scores within 1 %), the polynomial candidates the same rows."""
    from rinscal.calibration.selection import auto

    cands = candidates("accel", x.shape[1])
    if most is not None:
        monkeypatch.setattr(auto, "SCREEN_SAMPLES", most)
        monkeypatch.setattr(auto, "SCREEN_ROWS", most // 3)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ref = select_channel(x, y, codes, runs, t, cands)
        got = _streamed(x, y, codes, runs, t, cands, most or x.shape[0])
    assert (got.chosen, got.fallback) == (ref.chosen, ref.fallback)
    assert got.to_dict()["folds"] == ref.to_dict()["folds"]
    for a, b in zip(ref.table, got.table, strict=True):
        rel = 1e-2 if most is not None and a["method"] in ("px4", "ardupilot") else 1e-9
        if a["heldout_rms"] is None:
            assert b["heldout_rms"] is None, a["name"]
        else:
            assert b["heldout_rms"] == pytest.approx(a["heldout_rms"], rel=rel), a["name"]
    if most is None:
        for name, params in ref.fitted.items():
            np.testing.assert_allclose(got.fitted[name]["coef"], params["coef"], rtol=1e-9)


@pytest.mark.parametrize(
    "drift",
    [
        lambda x: 40 * (x[:, 0] - 25) + 0.5 * (x[:, 0] - 25) ** 2,
        lambda x: 5 * (x[:, 0] - 25) + 300 * x[:, 1],
        lambda x: 0.02 * (x[:, 0] - 20) ** 2 - 3 * x[:, 2],
        lambda x: np.zeros(x.shape[0]),
    ],
    ids=["cubic-T", "rate", "T2-gradient", "noise"],
)
def test_the_streamed_choice_is_the_whole_rows_choice(drift, monkeypatch) -> None:
    x, codes, t = _runs(seed=4)
    y = drift(x) + np.random.default_rng(4).normal(0, 1.0, x.shape[0])
    _same_choice(x, y, codes, [f"r{k}" for k in range(5)], t, monkeypatch)


@pytest.mark.parametrize("n_runs", [1, 2])
def test_the_streamed_choice_cuts_legs_and_blocks_as_the_whole_rows(n_runs, monkeypatch):
    """One or two runs: legs (a cooling and a heating run) or blocks (one warm-up)."""
    rng = np.random.default_rng(n_runs)
    xs, codes, ts = [], [], []
    for k in range(n_runs):
        t = np.arange(2400) * 3.0
        temp = 40 - 30 * (1 - np.exp(-t / 1500)) if k == 0 else 5 + 40 * (1 - np.exp(-t / 900))
        temp = temp + rng.normal(0, 0.01, t.size)
        rate = np.gradient(temp, t) * 60.0
        xs.append(np.column_stack([temp, rate]))
        codes.append(np.full(t.size, k))
        ts.append(t)
    x, codes, t = np.vstack(xs), np.concatenate(codes), np.concatenate(ts)
    y = 0.3 * (x[:, 0] - 25) ** 2 + 20 * x[:, 1] + rng.normal(0, 0.5, x.shape[0])
    _same_choice(x, y, codes, ["cool", "heat"][:n_runs], t, monkeypatch)


@pytest.mark.parametrize("step", [1, 4])
def test_the_streamed_choice_on_the_simulated_soak_is_today_s(soak_small, step, monkeypatch):
    """Every channel of the simulated soak protocol: the choice ``fit`` makes from the
    stream is the one made on the whole rows, when nothing is thinned and when both keep
    every 4th row."""
    from rinscal.calibration.thermal.features import build_features

    log, _, _ = soak_small
    f = build_features(log)
    for j in range(len(f.channels)):
        x = f.matrix(j)
        ok = f.usable(j, x)
        most = math.ceil(ok.sum() / step) if step > 1 else None
        xo, yo, to = x[ok], f.output[ok, j], f.time_s[ok]
        _same_choice(xo, yo, f.run_codes[ok], f.runs, to, monkeypatch, most)


def test_rows_dropped_when_k_doubles_are_freed() -> None:
    """The rows kept of earlier runs are copied when ``k`` doubles, never views that would
    keep every dropped row in memory."""
    x, codes, t = _runs(n_runs=5, n=1200)
    sample = _feed(x, x[:, 0] ** 2, codes, t, 1000)
    assert sample.step == 8
    for part in sample.parts[:-1]:  # the last run came in at the final k: nothing dropped
        for a in part.values():
            assert a.base is None or a.base.size == a.size


def test_the_choice_keeps_every_kth_row_however_long_the_log() -> None:
    """``auto`` keeps of a channel every k-th usable row of the log, k the smallest power
    of two that keeps at most SCREEN_SAMPLES, not every row: memory does not grow with the
    log. The kept rows are those of rows[::k] of the whole log."""
    from rinscal.calibration.selection.auto import SCREEN_SAMPLES

    x, codes, t = _runs(n_runs=5, n=1200)
    y = x[:, 0] ** 2
    for most in (6000, 1000, 700, 64):
        sample = _feed(x, y, codes, t, most)
        xs, ys, cs, rows, ts, tools = sample.arrays()
        k = 1 << max(0, math.ceil(math.log2(x.shape[0] / most)))
        assert ys.size <= most and sample.step == k
        np.testing.assert_array_equal(xs, x[::k])
        np.testing.assert_array_equal(ys, y[::k])
        np.testing.assert_array_equal(rows, np.tile(np.arange(1200), 5)[::k])
        np.testing.assert_array_equal(cs, codes[::k])
        np.testing.assert_array_equal(ts, t[::k])
        # the PX4 median at each kept row is the one of its whole run
        from rinscal.calibration.thermal.baselines import px4_filtered

        np.testing.assert_array_equal(tools["px4"], px4_filtered(x[:, 0], y, codes)[1][::k])
    # ArduPilot's 2 s moving average at each kept row: the tool's, centred on the row
    from rinscal.calibration.thermal.baselines import ardupilot_smoothed

    t10 = np.tile(np.arange(1200) * 0.1, 5)  # 10 Hz: a 20-sample window
    t_s, y_s, _, _, mid = ardupilot_smoothed(x[:, 0], y, t10, codes)
    sample = _feed(x, y, codes, t10, 700)  # k = 16
    got_t, got_y = sample.arrays()[5]["ardupilot"]
    at = np.full(x.shape[0], -1)
    at[mid] = np.arange(mid.size)
    want = at[::16]
    assert np.isnan(got_t[want < 0]).all() and (want >= 0).sum() > 300
    np.testing.assert_array_equal(got_t[want >= 0], t_s[want[want >= 0]])
    np.testing.assert_array_equal(got_y[want >= 0], y_s[want[want >= 0]])
    # what ThermalModel("auto") keeps per channel
    fits = ThermalModel("auto")._run_fits("accel_x", 3)
    for k in range(40):
        fits.add(k, x, y, t)  # a log 40 times as long as the sample holds: 240 000 rows
    assert fits.n == 40 * x.shape[0] and not fits.rows
    assert fits.screen is not None
    assert sum(p["y"].size for p in fits.screen.parts) <= SCREEN_SAMPLES


def test_rinscal_fit_writes_the_whole_rows_choice_while_keeping_every_4th_row(
    tmp_path, soak_small, monkeypatch
) -> None:
    """``rinscal fit LOG`` (auto, read a run at a time) keeping every 4th row of each channel
    writes the choice that the whole rows, thinned alike, give."""
    from typer.testing import CliRunner

    from rinscal.calibration.selection import auto
    from rinscal.calibration.thermal.features import build_features
    from rinscal.cli import app
    from rinscal.io.tables import write_log

    log, _, _ = soak_small
    path, model = tmp_path / "soak.parquet", tmp_path / "auto.json"
    write_log(log, path)
    f = build_features(log)
    monkeypatch.setattr(auto, "SCREEN_SAMPLES", math.ceil(len(log) / 4))  # k = 4 for all
    monkeypatch.setattr(auto, "SCREEN_ROWS", 1000)
    res = CliRunner().invoke(app, ["fit", str(path), "--out", str(model)])
    assert res.exit_code == 0, res.output
    written = ThermalModelFile.load(model)
    for j, c in enumerate(f.channels):
        x = f.matrix(j)
        ok = f.usable(j, x)
        assert math.ceil(ok.sum() / auto.SCREEN_SAMPLES) == 4
        cands = candidates("gyro" if c.startswith("gyro") else "accel", x.shape[1])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            ref = select_channel(
                x[ok], f.output[ok, j], f.run_codes[ok], f.runs, f.time_s[ok], cands
            )
        sel = written.models[c].selection
        assert (sel["chosen"], sel["fallback"]) == (ref.chosen.name, ref.fallback.name), c


def test_the_fold_fits_of_one_batched_qr_are_the_fits_one_by_one() -> None:
    """The held-out polynomial fits leave each fold's factor out in one batched QR: the same
    numbers as one QR per fold, rank-deficient designs refused alike."""
    from rinscal.calibration.thermal.fitting import fit_factors, fit_factors_leaving_out

    rng = np.random.default_rng(3)
    m = 12
    for trial in range(50):
        rs = [
            np.linalg.qr(rng.normal(size=(40, m)) * rng.uniform(0.1, 100, m), mode="r")
            for _ in range(7)
        ]
        if trial % 5 == 0:  # a collinear design
            for r in rs:
                r[:, 2] = r[:, 1]
        inner = rng.choice(np.arange(1, m - 1), size=int(rng.integers(1, 9)), replace=False)
        sel = [0, *sorted(inner.tolist()), m - 1]
        got = fit_factors_leaving_out(rs, sel)
        for k in range(7):
            want = fit_factors([rs[j] for j in range(7) if j != k], sel)
            assert (got[k] is None) == (want is None)
            if want is not None:
                np.testing.assert_array_equal(got[k], want)
