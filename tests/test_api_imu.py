"""One IMU argument in the Python API: ``imu=``, default the paper's own, everywhere.

``rinscal.simulate`` once defaulted to the navigation-grade preset while ``rinscal.navigate``
and the command line defaulted to the paper's, so the tutorial fitted one unit and navigated
another without a word. Every function that takes an IMU takes it as ``imu=`` (a preset
name, a TOML file or an ``ImuConfig``), default ``paper``; ``config=`` is kept as the older
spelling.
"""

from __future__ import annotations

import inspect
from pathlib import Path

import pytest

import rinscal
from rinscal.errors import ArgumentTypeError, ConfigError
from rinscal.presets import DEFAULT_PRESET
from rinscal.sim.config import ImuConfig, load_imu
from rinscal.sim.workflow import navigate_scenario

PAPER = load_imu("paper").name
TINY = {"hours": 0.01, "rate_hz": 1.0, "seed": 3}
#: A multi-position run as short as the simulator allows: one set point, 12 positions.
TINY_MP = {
    "sequence": "12",
    "set_points_c": (20.0,),
    "rates_dps": (50.0,),
    "dwell_s": 2.0,
    "warmup_s": 0.0,
    "rate_hz": 2.0,
}


def test_the_default_is_the_papers_imu_everywhere() -> None:
    assert DEFAULT_PRESET == "paper"
    _, _, meta = rinscal.simulate("soak", **TINY)
    assert meta["imu"] == PAPER
    _, _, mp_meta = rinscal.simulate_multiposition(**TINY_MP)
    assert mp_meta["imu"] == PAPER
    nav = rinscal.navigate("quasi-static", hours=0.05, rate_hz=5.0, align_s=60.0, oracle=False)
    assert nav.imu.name == nav.summary["imu"] == PAPER


def test_what_is_simulated_is_what_is_navigated_by_default() -> None:
    """A model fitted on ``simulate``'s default unit carries that unit into ``navigate``."""
    log, _, meta = rinscal.simulate("soak", hours=0.05, rate_hz=0.5, seed=1)
    result = rinscal.fit(log, "poly-t", meta=meta)
    nav = rinscal.navigate(
        "quasi-static", hours=0.05, rate_hz=5.0, align_s=60.0, models={"m": result.model}
    )
    assert nav.summary["imu"] == meta["imu"]


@pytest.mark.parametrize("fn", ["simulate", "simulate_multiposition", "navigate"])
def test_every_imu_argument_is_spelled_imu(fn: str) -> None:
    target = {
        "simulate": rinscal.simulate,
        "simulate_multiposition": rinscal.simulate_multiposition,
        "navigate": navigate_scenario,
    }[fn]
    params = inspect.signature(target).parameters
    assert "imu" in params
    default = params["imu"].default
    assert default in (None, "paper")  # None: the paper's own, resolved inside


@pytest.mark.parametrize("fn", ["simulate", "simulate_multiposition"])
def test_imu_takes_a_preset_a_toml_file_or_a_configuration(fn: str, tmp_path: Path) -> None:
    sim = rinscal.simulate if fn == "simulate" else rinscal.simulate_multiposition
    args = ("soak",) if fn == "simulate" else ()
    kw = TINY if fn == "simulate" else TINY_MP
    grade = load_imu("navigation_grade")
    toml = tmp_path / "unit.toml"
    toml.write_text((Path(rinscal.__file__).parent / "data" / "navigation_grade.toml").read_text())
    named = sim(*args, imu="navigation_grade", **kw)
    for spec in (grade, toml, str(toml)):
        log, _, meta = sim(*args, imu=spec, **kw)
        assert meta["imu"] == grade.name
        assert log.equals(named[0])
    with pytest.warns(DeprecationWarning, match="config="):  # the older spelling
        old = sim(*args, config="navigation_grade", **kw)
    assert old[0].equals(named[0]) and old[2]["imu"] == grade.name
    assert not sim(*args, **kw)[0].equals(named[0])  # the default is another unit


@pytest.mark.parametrize("fn", ["simulate", "simulate_multiposition"])
def test_imu_and_config_together_are_refused(fn: str) -> None:
    sim = rinscal.simulate if fn == "simulate" else rinscal.simulate_multiposition
    args = ("soak",) if fn == "simulate" else ()
    with pytest.raises(ConfigError, match=r"imu=.*config=.*not both"):
        sim(*args, imu="paper", config=ImuConfig.paper(), **(TINY if args else TINY_MP))


@pytest.mark.parametrize(
    ("call", "name"),
    [
        (lambda: rinscal.simulate("soak", imu=42, **TINY), "imu"),
        (lambda: rinscal.simulate("soak", config=3.5, **TINY), "config"),
        (lambda: rinscal.simulate_multiposition(["paper"], **TINY_MP), "imu"),
        (lambda: rinscal.navigate("quasi-static", imu=7, hours=0.05), "imu"),
        (lambda: rinscal.load_imu(42), "spec"),
    ],
)
def test_a_wrong_imu_is_named(call, name: str) -> None:
    with pytest.raises(ArgumentTypeError, match=rf"^{name}: expected .*(preset|IMU)") as exc:
        call()
    assert isinstance(exc.value, TypeError) and isinstance(exc.value, ValueError)


def test_an_unknown_preset_names_the_presets() -> None:
    with pytest.raises(ConfigError, match="navigation_grade"):
        rinscal.simulate("soak", imu="consumer", **TINY)
