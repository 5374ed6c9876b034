"""The mechanistic presets (issue 23, item 2): reproduced by their script, their match
residual as the files say, and the held-out fraction the regression leaves on them.

``docs/scripts/fit_mechanistic.py`` fits them; these tests re-run its linear solve at the
committed nonlinear parameters (and check those are the optimum of their neighbourhood)
instead of its whole grid (about a minute per preset), so an edited coefficient fails here.
"""

from __future__ import annotations

import importlib.util
import math
import re
import sys
from functools import cache
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest

from rinscal.schema import CHANNELS
from rinscal.thermal.config import ImuConfig, load_imu
from rinscal.thermal.field import N_GYROS
from rinscal.thermal.presets import PRESETS
from rinscal.thermal.protocols import simulate_protocol

ROOT = Path(__file__).resolve().parents[2]
SCRIPTS = ROOT / "docs" / "scripts"


def _script(name: str) -> ModuleType:
    spec = importlib.util.spec_from_file_location(name, SCRIPTS / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault(name, module)
    spec.loader.exec_module(module)
    return module


fm = _script("fit_mechanistic")
mh = _script("mechanistic_heldout")

MECH = {"paper": "paper_mechanistic", "navigation_grade": "navigation_grade_mechanistic"}


@cache
def _fields(base: str) -> list:
    return fm.soak_fields(load_imu(base))


@pytest.mark.parametrize("base", list(MECH))
def test_presets_are_listed_load_and_simulate(base: str) -> None:
    name = MECH[base]
    assert name in PRESETS
    cfg = load_imu(name)
    assert cfg.thermal_law == "mechanistic" and cfg.mechanistic is not None
    assert cfg == ImuConfig.from_toml(fm.DATA / f"{name}.toml")
    # everything but the thermal law is the base preset's
    ref = load_imu(base)
    assert cfg.network == ref.network and cfg.noise == ref.noise and cfg.effects == ref.effects
    for a, b in zip(cfg.thermal, ref.thermal, strict=True):
        for k in (
            "shupe",
            "hysteresis",
            "scale_factor_ppm_per_c",
            "misalignment_arcsec_per_c",
            "scale_factor_ppm",
            "misalignment_arcsec",
            "sf_asym_ppm",
            "sf_asym_ppm_per_c",
            "sf_quad",
            "sf_quad_per_c",
        ):
            assert getattr(a, k) == getattr(b, k)
    log, truth, _ = simulate_protocol("repeat", hours=0.2, rate_hz=1.0, seed=0, config=cfg)
    bias = truth[[f"bias_{c}" for c in CHANNELS]].to_numpy()
    assert len(log) == len(truth) == 720 and np.all(np.isfinite(bias))
    assert np.all(bias.std(axis=0) > 0)


@pytest.mark.parametrize("base", list(MECH))
def test_committed_preset_reproduced_by_its_script(base: str) -> None:
    """Each channel's linear coefficients are the script's solve at the committed nonlinear
    parameters (to the 6 digits written), and those parameters are a bounded optimum: no
    better cost 5 % away in either (unless held at a bound)."""
    cfg = load_imu(base)
    committed = load_imu(MECH[base])
    assert committed.mechanistic is not None
    fields = _fields(base)
    target = np.concatenate([fm.polynomial_target(f, cfg) for f in fields])
    runs = fm.run_index(fields)
    for j, ch in enumerate(CHANNELS):
        law = committed.mechanistic[j]
        assert law.t_mount_c == cfg.t_cal_c
        assert fm.T_SAT_BOUNDS[0] <= law.t_sat_c <= fm.T_SAT_BOUNDS[1]
        assert fm.TAU_ELEC_BOUNDS[0] <= law.tau_elec_s <= fm.TAU_ELEC_BOUNDS[1]

        def cost(t_sat: float, tau: float, j: int = j) -> float:
            X = np.concatenate(
                [fm.regressors(f, j, cfg.t_ref_c, t_sat, cfg.t_cal_c, tau) for f in fields]
            )
            c = fm._solve(X, target[:, j], runs)
            return float(np.mean((X @ c - target[:, j]) ** 2)), c

        best, coef = cost(law.t_sat_c, law.tau_elec_s)
        got = np.array([getattr(law, k) for k in fm.LINEAR])
        if j >= N_GYROS:
            coef[fm.LINEAR.index("k_coil")] = 0.0
        # each term to 1e-4 of the drift's SD (the written digits move b0 that much)
        X = np.concatenate(
            [
                fm.regressors(f, j, cfg.t_ref_c, law.t_sat_c, cfg.t_cal_c, law.tau_elec_s)
                for f in fields
            ]
        )
        sd = X.std(axis=0)
        sd[0] = 1.0
        tol = 1e-4 * target[:, j].std() / np.where(sd > 0, sd, 1.0)
        np.testing.assert_array_less(np.abs(got - coef), tol, err_msg=ch)
        for dt, dl in ((1.05, 1.0), (1 / 1.05, 1.0), (1.0, 1.05), (1.0, 1 / 1.05)):
            ts = min(max(law.t_sat_c * dt, fm.T_SAT_BOUNDS[0]), fm.T_SAT_BOUNDS[1])
            tau = min(max(law.tau_elec_s * dl, fm.TAU_ELEC_BOUNDS[0]), fm.TAU_ELEC_BOUNDS[1])
            assert cost(ts, tau)[0] >= best * (1 - 1e-6), (ch, ts, tau)


@pytest.mark.parametrize("base", list(MECH))
def test_match_residual_is_what_the_header_says(base: str) -> None:
    name = MECH[base]
    text = (fm.DATA / f"{name}.toml").read_text()
    assert "GENERATED by docs/scripts/fit_mechanistic.py" in text
    said = {
        m[1]: (float(m[2]), float(m[3]))
        for m in re.finditer(r"^#\s+(\w+)\s+([-0-9.e]+) (?:deg/h|ug) \(([0-9.]+) %\)", text, re.M)
    }
    assert set(said) == set(CHANNELS)
    res = fm.match_residual(_fields(base), load_imu(base), load_imu(name))
    for ch in CHANNELS:
        assert math.isclose(res[ch]["rms"], said[ch][0], rel_tol=1e-3), ch
        assert abs(res[ch]["pct"] - said[ch][1]) < 0.006, ch


ACCELS = ["accel_x", "accel_y", "accel_z"]


@cache
def _worst_accel(preset: str, methods: tuple[str, ...]) -> dict[str, float]:
    frac = mh.heldout_fractions(preset, methods)
    return {m: float(frac.loc[ACCELS, m].max()) for m in methods}


def test_every_method_leaves_more_of_the_swing_on_the_mechanistic_paper() -> None:
    """Trained on soak (7 × 3 h, 1 Hz), held out on repeat: the worst accelerometer's share
    of the thermal swing left. The regression: 2-7 % on paper, >= 20 % (measured 25.7 %) on
    paper_mechanistic; poly-t and sectional leave more than that there (docs/plant.md)."""
    methods = ("poly-t", "sectional", "regression")
    paper = _worst_accel("paper", methods)
    mech = _worst_accel("paper_mechanistic", methods)
    assert 0.02 <= paper["regression"] <= 0.07
    assert mech["regression"] >= 0.20
    assert mech["regression"] > 3 * paper["regression"]
    assert min(mech.values()) >= 0.20


def test_navigation_grade_mechanistic_is_not_told_apart_by_the_regression() -> None:
    """On navigation_grade's class the regression leaves >= 10 % on the mechanistic preset,
    but as much on the polynomial one: the common hysteresis and noise, not the law."""
    nav = _worst_accel("navigation_grade", ("regression",))["regression"]
    mech = _worst_accel("navigation_grade_mechanistic", ("regression",))["regression"]
    assert mech >= 0.10 and nav >= 0.10
    assert abs(mech - nav) < 0.03


@pytest.mark.slow
def test_neural_and_auto_leave_more_of_the_swing_on_the_mechanistic_paper() -> None:
    """The same fraction for the network and auto (measured 20.6 % and 27.3 %)."""
    mech = _worst_accel("paper_mechanistic", ("neural", "auto"))
    assert mech["auto"] >= 0.20 and mech["neural"] >= 0.15
