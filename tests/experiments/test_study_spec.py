"""Study specs: every error names its key; sweeps, unit spread and seeds do what they say."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from rinscal.errors import ConfigError
from rinscal.experiments.study.spec import (
    BUILTIN_STUDIES,
    SPREAD_FIELDS,
    load_spec,
    spec_from_dict,
)
from rinscal.experiments.study.tasks import plant_config, study_tasks, task_seed, unit_config
from rinscal.sim.config import ImuConfig

BASE = {
    "study": {"name": "t", "seed": 3, "units": 4, "methods": ["none", "poly-t", "true"]},
    "calibration": {"hours": 0.5, "rate_hz": 1.0},
    "plants": [{"imu": "paper"}],
    "scenarios": [
        {
            "name": "qs",
            "kind": "quasi-static",
            "hours": 0.3,
            "rate_hz": 5.0,
            "ambient_c": [18.0, 24.0],
            "align_s": 120.0,
        }
    ],
    "quick": {"calibration": {"rate_hz": 0.5}, "scenarios": {"quasi-static": {"hours": 0.25}}},
}


def _with(path: str, value: object) -> dict:
    d = copy.deepcopy(BASE)
    node = d
    keys = path.split(".")
    for k in keys[:-1]:
        node = node[int(k)] if k.isdigit() else node[k]
    last = keys[-1]
    if value is _DELETE:
        del node[last]
    else:
        node[last] = value
    return d


_DELETE = object()


@pytest.mark.parametrize(
    ("path", "value", "message"),
    [
        ("colour", 1, r"top level: unknown key\(s\) colour"),
        ("study.unitz", 3, r"\[study\]: unknown key\(s\) unitz"),
        ("study.units", -2, "study.units must be an integer >= 1, got -2"),
        ("study.units", 0, "study.units must be an integer >= 1, got 0"),
        ("study.seed", -1, "study.seed must be an integer >= 0"),
        ("study.coefficient_spread", -0.1, "study.coefficient_spread must be >= 0"),
        ("study.coefficient_spread", 1.5, "study.coefficient_spread must be < 1"),
        ("study.methods", ["none", "magic"], "study.methods: unknown method 'magic'"),
        ("study.methods", ["none", "none"], "study.methods lists a method twice"),
        ("calibration.hours", 0, "calibration.hours must be > 0, got 0"),
        (
            "calibration.neural_max_samples",
            5,
            "calibration.neural_max_samples must be an integer >= 100",
        ),
        ("plants.0.imu", "no_such_unit", r"plants\[0\].imu = 'no_such_unit' is neither a preset"),
        (
            "plants.0.sweep",
            {"accel_magic": [1, 2]},
            r"plants\[0\].sweep: unknown key\(s\) "
            "accel_magic",
        ),
        ("plants.0.sweep", {"accel_t_scale": []}, r"plants\[0\].sweep.accel_t_scale is empty"),
        (
            "plants.0.sweep",
            {"accel_t_scale": [-1.0]},
            r"plants\[0\].sweep.accel_t_scale must "
            "be >= 0",
        ),
        ("plants.0.colour", "red", r"plants\[0\]: unknown key\(s\) colour"),
        ("scenarios.0.kind", "submarine", r"scenarios\[0\].kind must be one of"),
        ("scenarios.0.hourz", 1.0, r"scenarios\[0\]: unknown key\(s\) hourz"),
        ("scenarios.0.rate_hz", -5.0, r"scenarios\[0\].rate_hz must be > 0"),
        ("scenarios.0.ambient_c", [], r"scenarios\[0\].ambient_c must list at least one start"),
        ("scenarios.0.ambient_c", [200.0], r"scenarios\[0\].ambient_c = 200.0 °C is outside"),
        ("scenarios.0.align_start_s", -1.0, r"scenarios\[0\].align_start_s must be >= 0"),
        ("scenarios.0.align_s", 5000.0, r"scenarios\[0\]: the alignment ends 5000 s"),
        ("scenarios.0.rate_hz", _DELETE, r"scenarios\[0\].rate_hz is missing"),
        ("plants", [], r"\[\[plants\]\] must list at least one plant"),
        ("quick.calibration", {"rate": 2}, r"\[quick.calibration\]: unknown key\(s\) rate"),
    ],
)
def test_spec_errors_name_the_key(path: str, value: object, message: str) -> None:
    with pytest.raises(ConfigError, match=message) as e:
        spec_from_dict(_with(path, value), "my_study.toml", quick=True)
    assert "my_study.toml" in str(e.value)


def test_more_spec_errors() -> None:
    d = copy.deepcopy(BASE)
    d["scenarios"].append(dict(d["scenarios"][0]))
    with pytest.raises(ConfigError, match="name 'qs' is used twice"):
        spec_from_dict(d, "s.toml")
    d = copy.deepcopy(BASE)
    del d["quick"]
    with pytest.raises(ConfigError, match="--quick: this spec has no \\[quick\\] section"):
        spec_from_dict(d, "s.toml", quick=True)
    with pytest.raises(ConfigError, match="--units must be an integer >= 1, got 0"):
        spec_from_dict(BASE, "s.toml", units_override=0)
    with pytest.raises(ConfigError, match="missing \\[scenarios\\]"):
        spec_from_dict({k: v for k, v in BASE.items() if k != "scenarios"}, "s.toml")
    with pytest.raises(ConfigError, match="neither a built-in study"):
        load_spec("no-such-study")


def test_bad_toml_names_the_file(tmp_path) -> None:
    p = tmp_path / "broken.toml"
    p.write_text("[study\nname = 1\n")
    with pytest.raises(ConfigError, match=r"broken\.toml: not valid TOML"):
        load_spec(p)


def test_builtin_studies_load_and_quick_applies() -> None:
    for name in BUILTIN_STUDIES:
        full, quick = load_spec(name), load_spec(name, quick=True)
        assert quick.calibration.rate_hz < full.calibration.rate_hz
        assert quick.fingerprint() != full.fingerprint()
    paper = load_spec("paper", units_override=7)
    assert paper.units == 7
    assert [s.kind for s in paper.scenarios] == ["quasi-static", "swing", "vehicle"]
    # the paper's Section 5: five lab temperatures, three vehicle runs
    assert [len(s.ambient_c) for s in paper.scenarios] == [5, 5, 3]
    # both thermal laws (issue 23): the polynomial preset and its mechanistic twin
    assert [p.imu for p in paper.plants] == ["paper", "paper_mechanistic"]
    sens = load_spec("sensitivity")
    assert len(sens.plants) == 2 * 4 * 2
    assert {p.imu for p in sens.plants} == {"navigation_grade", "navigation_grade_mechanistic"}
    assert {s.align_start_s for s in sens.scenarios} == {0.0, 1800.0}


def test_units_do_not_change_the_fingerprint() -> None:
    a = spec_from_dict(BASE, "s")
    b = spec_from_dict(BASE, "s", units_override=40)
    c = spec_from_dict(_with("study.seed", 4), "s")
    assert a.fingerprint() == b.fingerprint() != c.fingerprint()


def test_sweep_scales_only_the_named_coefficients() -> None:
    spec = spec_from_dict(_with("plants.0.sweep", {"accel_dynamic_scale": [1.0, 3.0]}), "s")
    base, tripled = (plant_config(p) for p in spec.plants)
    ref = ImuConfig.paper()
    assert base.thermal == ref.thermal
    for j in range(6):
        a, b = ref.thermal[j], tripled.thermal[j]
        k = 3.0 if j >= 3 else 1.0  # accelerometers only
        np.testing.assert_allclose(b.rate, np.array(a.rate) * k)
        np.testing.assert_allclose(b.grad, np.array(a.grad) * k)
        assert b.t_rate == pytest.approx(a.t_rate * k)
        assert b.t_grad == pytest.approx(a.t_grad * k)
        assert b.t == a.t and b.stress == a.stress and b.b0 == a.b0


def test_unit_spread_has_the_stated_size_and_is_per_unit() -> None:
    spec0 = spec_from_dict(BASE, "s")
    plant = plant_config(spec0.plants[0])
    assert unit_config(spec0, plant, 5) is plant  # no spread: identical units
    spec = spec_from_dict(_with("study.coefficient_spread", 0.1), "s")
    ratios = []
    for u in range(200):
        cfg = unit_config(spec, plant, u)
        ratios.append(cfg.thermal[3].rate[0] / plant.thermal[3].rate[0])
        assert cfg.thermal[3].b0 == plant.thermal[3].b0  # offsets come from turn-on draws
    r = np.array(ratios)
    assert r.mean() == pytest.approx(1.0, abs=0.03)
    assert r.std(ddof=1) == pytest.approx(0.1, rel=0.15)
    assert unit_config(spec, plant, 3) == unit_config(spec, plant, 3)
    assert "hysteresis" in SPREAD_FIELDS


def test_seeds_are_stable_and_independent_of_the_task_list() -> None:
    assert task_seed(0, 1, 2) == task_seed(0, 1, 2)
    seeds = {task_seed(0, u, k) for u in range(50) for k in range(3)}
    assert len(seeds) == 150
    spec = spec_from_dict(BASE, "s")
    tasks = study_tasks(spec)
    assert len(tasks) == 4 and all(len(n) == 2 for _, n in tasks)
    keys = [t.key for cal, navs in tasks for t in (cal, *navs)]
    assert len(set(keys)) == len(keys)


def test_imu_override_replaces_every_plant_and_keeps_the_sweep() -> None:
    sens = load_spec("sensitivity", imu_override="paper")
    assert {p.imu for p in sens.plants} == {"paper"}
    assert len(sens.plants) == 8
    both = load_spec("sensitivity", imu_override=["paper", "paper_mechanistic"])
    assert [p.imu for p in both.plants] == ["paper"] * 8 + ["paper_mechanistic"] * 8
    assert [p.params for p in both.plants[:8]] == [p.params for p in both.plants[8:]]
    two = copy.deepcopy(BASE)
    two["plants"] = [{"imu": "paper"}, {"imu": "paper", "sweep": {"accel_t_scale": [2.0]}}]
    with pytest.raises(ConfigError, match="different sweeps"):
        spec_from_dict(two, "s", imu_override="navigation_grade")
    assert sens.fingerprint() != load_spec("sensitivity").fingerprint()
    with pytest.raises(ConfigError, match="--imu = 'nope' is neither a preset"):
        load_spec("paper", imu_override="nope")
