"""The ``field`` study variant (issue 38): its ``[calibration]`` keys, each refusal naming
its key; a unit's field model is the field calibration of that unit's own parked starts; the
mean paired ratio and the field claims of a study's comparisons."""

from __future__ import annotations

import copy
import json
import math

import numpy as np
import pandas as pd
import pytest
from scipy import stats

import rinscal
from rinscal.calibration.modelfile import FittedModel
from rinscal.errors import ConfigError
from rinscal.experiments.paper.config import load_plant
from rinscal.experiments.study.compare import (
    FIELD_VARIANT,
    paired_against,
    study_claims,
)
from rinscal.experiments.study.spec import FIELD_AMBIENTS_C, load_spec, spec_from_dict
from rinscal.experiments.study.tasks import CalTask, calibrate_unit, task_seed, unit_config
from rinscal.report.study_words import field_lines

BASE = {
    "study": {"name": "f", "seed": 5, "units": 5, "coefficient_spread": 0.1,
              "methods": ["none", "field", "true"]},
    "calibration": {"hours": 0.2, "rate_hz": 0.5, "field_runs": 3, "field_hours": 0.3,
                    "field_rate_hz": 10.0, "field_ambient_c": [0.0, 20.0, 40.0]},
    "plants": [{"imu": "paper"}],
    "scenarios": [{"name": "qs", "kind": "quasi-static", "hours": 0.3, "rate_hz": 5.0,
                   "ambient_c": [20.0], "align_s": 120.0}],
    "quick": {"calibration": {"field_hours": 0.25, "field_runs": 4}},
}  # fmt: skip


def _with(key: str, value: object) -> dict:
    d = copy.deepcopy(BASE)
    d["calibration"][key] = value
    return d


def test_field_keys_parse_with_defaults_and_quick_overrides() -> None:
    spec = spec_from_dict(BASE, "s")
    c = spec.calibration
    assert (c.field_runs, c.field_hours, c.field_rate_hz) == (3, 0.3, 10.0)
    assert c.field_ambient_c == (0.0, 20.0, 40.0)
    assert spec.models == (FIELD_VARIANT,)
    quick = spec_from_dict(BASE, "s", quick=True).calibration
    assert (quick.field_runs, quick.field_hours) == (4, 0.25)
    d = copy.deepcopy(BASE)
    d["calibration"] = {"hours": 0.2}
    c = spec_from_dict(d, "s").calibration  # defaults: Table 3's seven ambients, 4 h at 10 Hz
    assert (c.field_runs, c.field_hours, c.field_rate_hz) == (7, 4.0, 10.0)
    assert c.field_ambient_c == FIELD_AMBIENTS_C == (0.0, 7.0, 14.0, 21.0, 28.0, 35.0, 42.0)
    assert c.field_method == "regression"  # method 2's form, like for like with method 2
    assert spec_from_dict(_with("field_method", "auto"), "s").calibration.field_method == "auto"
    assert (
        spec_from_dict(_with("field_method", "auto"), "s").fingerprint()
        != spec_from_dict(BASE, "s").fingerprint()
    )


@pytest.mark.parametrize(
    ("key", "value", "message"),
    [
        ("field_runs", 2, "calibration.field_runs must be an integer >= 3, got 2"),
        ("field_runs", 3.5, "calibration.field_runs must be an integer >= 3"),
        ("field_hours", 0.0, "calibration.field_hours must be > 0, got 0.0"),
        ("field_rate_hz", 2.5, "calibration.field_rate_hz must be a whole number of Hz"),
        ("field_rate_hz", "10", "calibration.field_rate_hz must be a finite number"),
        ("field_ambient_c", [], "calibration.field_ambient_c must list at least one"),
        ("field_ambient_c", [20.0, 90.0], r"calibration.field_ambient_c = 90.0 °C is outside"),
        ("field_seed", 1, r"\[calibration\]: unknown key\(s\) field_seed"),
        ("field_method", "cubic", "calibration.field_method must be one of auto, poly-t"),
    ],
)
def test_bad_field_keys_are_named(key: str, value: object, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        spec_from_dict(_with(key, value), "my.toml")


def test_field_keys_decide_the_fingerprint_only_where_field_is_run() -> None:
    a, b = spec_from_dict(BASE, "s"), spec_from_dict(_with("field_hours", 0.4), "s")
    assert a.fingerprint() != b.fingerprint()
    no_field = copy.deepcopy(BASE)
    no_field["study"]["methods"] = ["none", "poly-t", "true"]
    other = copy.deepcopy(no_field)
    other["calibration"]["field_hours"] = 0.4
    assert spec_from_dict(no_field, "s").fingerprint() == spec_from_dict(other, "s").fingerprint()


def test_builtin_field_study() -> None:
    spec = load_spec("field")
    assert [p.imu for p in spec.plants] == ["paper", "paper_mechanistic"]
    assert {"none", "regression", "field", "true"} <= set(spec.methods)
    assert [s.kind for s in spec.scenarios] == ["quasi-static", "swing", "vehicle"]
    # the verdict rule's five units, and at least 10 held-out cold starts per group
    assert spec.units >= 5
    assert all(spec.units * len(s.ambient_c) >= 10 for s in spec.scenarios)
    assert spec.calibration.field_ambient_c == FIELD_AMBIENTS_C
    quick = load_spec("field", quick=True)
    assert quick.calibration.field_hours < spec.calibration.field_hours


def test_a_units_field_model_is_the_field_calibration_of_its_own_starts(tmp_path) -> None:  # type: ignore[no-untyped-def]
    spec = spec_from_dict(BASE, "s")
    plant = load_plant("paper")
    res = calibrate_unit(spec, plant, CalTask(0, 2))
    model = FittedModel.from_dict(json.loads(res["models"][FIELD_VARIANT]))
    assert model.source["protocol"] == "field"
    assert set(model.channels) == set(rinscal.schema.CHANNELS)
    assert set(res["field"]["chosen"]) == set(model.channels) and res["field"]["runs"] == 3
    # the same as calibrating, by hand, the starts of unit 2 (its spread, its seed)
    imu = unit_config(spec, plant, 2)
    assert imu != plant  # the unit's own coefficients
    seed = task_seed(spec.seed, 2, 3)
    paths = rinscal.simulate_field_starts(
        tmp_path, runs=3, ambient_c=(0.0, 20.0, 40.0), hours=0.3, rate_hz=10.0, imu=imu, seed=seed
    )
    ref = rinscal.calibrate_field(
        paths, imu=imu, method=spec.calibration.field_method, seed=seed
    ).model.to_dict()["payload"]
    got = model.to_dict()["payload"]
    assert got.pop("source")["log"] == "study f, unit 2, parked starts"
    ref.pop("source")
    assert got == ref


def _results(n_units: int) -> pd.DataFrame:
    """Per run (two starts a unit): regression = 1 + u/10 + noise, field = regression ×
    (1.1 on start 0, 1.3 on start 1) × (1 + u/50), none = 2 × regression."""
    rng = np.random.default_rng(7)
    rows = []
    for u in range(n_units):
        for s in range(2):
            reg = 1.0 + u / 10 + rng.normal(0, 0.05)
            vals = {"none": 2 * reg, "regression": reg,
                    FIELD_VARIANT: reg * (1.1 + 0.2 * s) * (1 + u / 50)}  # fmt: skip
            for v, e in vals.items():
                rows.append({"plant": 0, "plant_label": "p", "unit": u, "scenario": "qs",
                             "start": s, "variant": v, "max_error_nmi": e})  # fmt: skip
    return pd.DataFrame(rows)


def test_mean_ratio_and_the_field_claims() -> None:
    res = _results(6)
    c = paired_against(res, ("regression", "none"), (FIELD_VARIANT,)).set_index("reference")
    r = c.loc["regression"]
    # per unit: the mean of 1.1 (1 + u/50) and 1.3 (1 + u/50)
    unit = 1.2 * (1 + np.arange(6) / 50)
    assert r["mean ratio"] == pytest.approx(unit.mean())
    assert (r["mean ratio ci low"], r["mean ratio ci high"]) == pytest.approx(
        stats.t.interval(0.95, 5, loc=unit.mean(), scale=stats.sem(unit))
    )
    assert r["verdict"] == "reversed"  # field has more error than method 2 in every run
    assert c.loc["none"]["mean ratio"] == pytest.approx((unit / 2).mean())
    # the report's words carry the same figures
    lo, hi = stats.t.interval(0.95, 5, loc=unit.mean(), scale=stats.sem(unit))
    (line,) = field_lines(c.reset_index())
    assert line.startswith("p, qs (6 units, 12 starts): mean ratio field / method 2 ")
    assert f"{unit.mean():.2f} [{lo:.2f}, {hi:.2f}]" in line
    assert "field better than method 2: reversed" in line
    claims = study_claims(res).set_index(["method", "reference"])
    assert claims.loc[(FIELD_VARIANT, "regression"), "verdict"] == "reversed"
    assert claims.loc[(FIELD_VARIANT, "none"), "verdict"] == "holds"
    assert "field" in claims.loc[(FIELD_VARIANT, "none"), "claim"]
    # below five units: a ratio, no interval
    r3 = paired_against(_results(3), ("regression",), (FIELD_VARIANT,)).iloc[0]
    assert math.isfinite(r3["mean ratio"]) and math.isnan(r3["mean ratio ci low"])
