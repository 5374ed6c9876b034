"""Field calibration (issue 38) from bias series: the calibration log, what the starts
determine, the fallback where they do not, and the model predicting a held-out start."""

from __future__ import annotations

import numpy as np
import pytest

from rinscal import units
from rinscal.calibration.observability import undetermined
from rinscal.calibration.thermal.features import build_features
from rinscal.errors import ConfigError
from rinscal.nav.fieldbias import BiasSeries
from rinscal.nav.fieldcal import calibrate_field_series, field_orders, series_log
from rinscal.schema import CHANNELS
from tests.nav._fieldseries import true_series

TABLE3 = (0.0, 7.0, 14.0, 21.0, 28.0, 35.0, 42.0)
TURN_ON = [0.003] * 3 + [15.0] * 3  # the paper IMU's, deg/h and µg


@pytest.fixture(scope="module")
def wide() -> dict:
    return true_series(TABLE3)


def test_the_calibration_log_is_the_series_in_log_units(wide) -> None:
    series = {k: s for k, (s, _) in wide.items()}
    log, meta = series_log(series)
    s = series["start_2"]
    rows = log[log["run"] == "start_2"]
    # one row each 10 s from the series' start, every channel from the start (the smoother
    # has told the horizontal biases from the tilt before the table first reversed)
    assert rows["time_s"].iloc[0] == pytest.approx(s.t[0])
    assert np.allclose(np.diff(rows["time_s"]), 10.0)
    k = np.searchsorted(s.t, rows["time_s"].to_numpy())
    assert not rows[list(CHANNELS)].isna().any().any()
    assert np.allclose(rows["gyro_z"], s.bias[k, 2] / units.DPH_TO_RPS)
    assert np.allclose(rows["gyro_y"], s.bias[k, 1] / units.DPH_TO_RPS)
    assert np.allclose(rows["accel_x"], s.bias[k, 3] / units.UG_TO_MPS2)
    assert np.allclose(rows["temp_accel_x"], s.temps[k, 3])
    assert meta["static_reference"] == dict.fromkeys(CHANNELS, 0.0)
    assert meta["unit_to_si"]["gyro_x"] == units.DPH_TO_RPS


def test_a_held_out_start_is_predicted_from_the_others(wide) -> None:
    """Six starts calibrate; the seventh (21 °C, inside their range) is predicted from its
    own thermometers: the horizontal accelerometers' bias over the start within a fifth of
    its swing (about its mean: the turn-on offset is not thermal), and below the
    scatter of a constant, no compensation (measured: 0.76 and 0.48 of it; 0.67 and 0.25
    with method 2's cubic in Ṫ and ΔT, which the field form no longer fits)."""
    train = {k: s for k, (s, _) in wide.items() if k != "start_3"}
    fc = calibrate_field_series(train, turn_on_sd=TURN_ON)
    s, truth = wide["start_3"]
    log, _ = series_log({"start_3": s})
    feats = build_features(log)
    k = np.searchsorted(s.t, log["time_s"].to_numpy())
    for j, c in ((3, "accel_x"), (4, "accel_y")):
        x = fc.model.feature_matrix(c, feats.temp[:, j], feats.rate[:, j], log["temp_out"])
        pred, _ = fc.model.predict_channel(c, x)
        err = pred * units.UG_TO_MPS2 - truth[k, j]
        err -= err.mean()
        swing = np.ptp(truth[k, j])
        assert np.std(err) < 0.2 * swing, (c, np.std(err), swing)
        assert np.std(err) < 0.8 * np.std(truth[k, j]), (c, np.std(err), np.std(truth[k, j]))


def test_the_field_form_is_method_2s_order_in_t_and_first_order_in_tdot_and_dt(wide) -> None:
    """Every start warms the same way, so powers of Ṫ and ΔT are only more functions of the
    time since power-on: the field model keeps method 2's order in T (gyros 1, accelerometers
    3, as the chamber's) and fits Ṫ and ΔT to first order; auto chooses its own."""
    assert field_orders("regression", "accel_y", True) == (3, 1, 1)
    assert field_orders("regression", "gyro_x", True) == (1, 1, 1)
    assert field_orders("regression", "accel_x", False) == (3, 1, 0)
    assert field_orders("sectional", "accel_z", True) == (3, 1)
    assert field_orders("auto", "accel_x", True) is None
    fc = calibrate_field_series({k: s for k, (s, _) in wide.items()}, turn_on_sd=TURN_ON)
    for c in CHANNELS:
        row = fc.table[fc.table["channel"] == c].iloc[0]
        if row["inputs"] == "T, Tdot, dT":
            want = field_orders("regression", c, True)
            assert row["model"] == "regression " + ",".join(map(str, want)), (c, row["model"])
            assert fc.model.models[c].to_dict()["params"]["orders"] == list(want)


def test_starts_spanning_10_c_name_what_they_cannot_determine_and_fall_back() -> None:
    """Seven starts between 15 and 25 °C: the report names the ΔT terms (the gradient
    follows the same warm-up in every start, so it cannot be told from T and Ṫ) as not
    determined, and those channels are fitted without them."""
    narrow = true_series((15.0, 17.0, 19.0, 21.0, 23.0, 25.0, 20.0))
    fc = calibrate_field_series({k: s for k, (s, _) in narrow.items()}, turn_on_sd=TURN_ON)
    missing = undetermined(fc.observability)
    assert missing.get("dT")
    for c in missing["dT"]:
        assert fc.fallback[c] in ("T, Tdot", "T")
        assert fc.model.models[c].n_inputs < 3
        assert any(c in n and "ΔT" in n for n in fc.notes)
    assert set(fc.table["inputs"]) <= {"T, Tdot, dT", "T, Tdot", "T"}
    # while Table 3's seven ambients determine the accelerometers' ΔT terms
    wide = true_series(TABLE3)
    fw = calibrate_field_series({k: s for k, (s, _) in wide.items()}, turn_on_sd=TURN_ON)
    assert "accel_z" not in undetermined(fw.observability).get("dT", ())


def test_too_few_starts_or_no_rotation_are_refused(wide) -> None:
    series = {k: s for k, (s, _) in wide.items()}
    with pytest.raises(ConfigError, match="at least 3"):
        calibrate_field_series(dict(list(series.items())[:2]))
    s = series["start_0"]
    still = BiasSeries(s.t, s.bias, s.sd, s.temps, s.temp_out, s.attitude, s.attitude_sd,
                       float("inf"))  # fmt: skip
    with pytest.raises(ConfigError, match="never completed a rotation period"):
        calibrate_field_series({**series, "start_0": still})
