"""One selection rule (issue 37.6): its quantity, its three users, ``select(log, "auto")``.

The tolerance is the relative excess of a candidate's held-out RMS over the least
[dimensionless] in ``fit --method auto``, ``select`` and the IMU laws alike; the API's
``select(log, "auto")`` is the command's ``select`` (default ``--method auto``). The fitter
and the fitted model have names of their own; the old names still work.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

import rinscal
from rinscal.calibration.imu.laws import fit_law
from rinscal.calibration.selection.auto import choose
from rinscal.calibration.selection.candidates import Candidate
from rinscal.calibration.selection.heldout import AutoSelectionResult, _result
from rinscal.calibration.selection.rule import (
    DEFAULT_TOLERANCES,
    from_mean_square,
    simplest_within,
    within_tolerance,
)
from rinscal.cli import app
from rinscal.errors import ConfigError
from rinscal.io.metadata import read_meta, write_meta
from rinscal.io.tables import read_log, write_log
from rinscal.schema import CHANNELS


def test_within_is_a_relative_excess_of_the_rms() -> None:
    rms = [1.0, 1.019, 1.021, np.nan, np.inf]
    assert within_tolerance(rms, 0.02).tolist() == [True, True, False, False, False]
    assert within_tolerance(rms, 0.0).tolist() == [True, False, False, False, False]
    assert not within_tolerance([np.nan, np.nan], 0.5).any()
    # the first listed is the simplest, unless a complexity says otherwise
    assert simplest_within([1.05, 1.0, 0.99, 1.2], 0.02) == 1
    assert simplest_within([1.2, 1.0, 0.99, 1.05], 0.07, complexity=[4, 2, 3, 1]) == 3
    with pytest.raises(ValueError, match="finite"):
        simplest_within([np.nan], 0.1)


def test_a_mean_square_tolerance_converts_to_the_same_choice() -> None:
    """An old ``fit --tolerance m`` (on the mean square) is the RMS tolerance √(1+m) − 1."""
    assert from_mean_square(0.0) == 0.0
    assert from_mean_square(0.21) == pytest.approx(0.1, rel=1e-12)
    rng = np.random.default_rng(3)
    for _ in range(200):
        ms = rng.uniform(1.0, 2.0, 6)
        m = float(rng.uniform(0.0, 0.9))
        old = ms <= ms.min() * (1.0 + m)  # the rule as fit --tolerance had it
        assert within_tolerance(np.sqrt(ms), from_mean_square(m)).tolist() == old.tolist()


def _cands() -> list[Candidate]:
    return [
        Candidate("a", "poly-t", "poly-t", {}, 1, (1,)),
        Candidate("b", "regression", "regression", {}, 3, (2, 1)),
    ]


def test_auto_choice_takes_the_tolerance_on_the_rms() -> None:
    """One scoring unit (no paired test): the simpler ``a`` at 1.1× ``b``'s RMS (1.21× its
    mean square) is within a tolerance of 0.105 and not of 0.095."""
    mse = np.array([[1.21], [1.0]])
    assert choose(_cands(), mse, tolerance=0.105).name == "a"
    assert choose(_cands(), mse, tolerance=0.095).name == "b"


def test_select_recommends_the_smallest_setting_by_the_same_rule() -> None:
    scores = {"gyro_x": [(0.9, 1.05), (0.8, 1.0), (0.7, 0.99), (0.6, 1.2)]}
    assert _result("regression", (1, 2, 3, 4), 0.02, ("r1", "r2"), scores).recommended == {
        "gyro_x": 2
    }
    assert _result("regression", (1, 2, 3, 4), 0.07, ("r1", "r2"), scores).recommended == {
        "gyro_x": 1
    }
    assert _result("regression", (1, 2, 3, 4), 0.0, ("r1", "r2"), scores).best == {"gyro_x": 3}


def test_an_imu_law_is_the_simplest_within_its_tolerance() -> None:
    """A straight line in T with noise of its sd: the law is the simplest candidate within
    the tolerance of its own held-out scores, at the default and at a wider tolerance."""
    rng = np.random.default_rng(7)
    temp = np.linspace(0.0, 48.0, 7)
    sd = np.full(7, 1e-4)
    values = 2e-3 + 5e-5 * temp + sd * rng.standard_normal(7)
    for tol in (DEFAULT_TOLERANCES["imu-law"], 5.0):
        law = fit_law(temp, values, sd, 24.0, tolerance=tol)
        names = list(law.scores)
        pick = names[simplest_within(list(law.scores.values()), tol)]
        assert pick == f"T{law.degree}"
    # a wide tolerance takes the constant although the slope is 35 sd over the range
    assert fit_law(temp, values, sd, 24.0, tolerance=1e6).degree == 0
    assert fit_law(temp, values, sd, 24.0).degree == 1


def test_old_names_are_the_new_classes() -> None:
    from rinscal.calibration.modelfile import FittedModel, ThermalModelFile
    from rinscal.calibration.thermal.model import ThermalFitter, ThermalModel

    assert ThermalModel is ThermalFitter and ThermalModelFile is FittedModel
    assert rinscal.ThermalModel is rinscal.ThermalFitter is ThermalFitter
    assert rinscal.ThermalModelFile is rinscal.FittedModel is FittedModel
    assert {"ThermalFitter", "FittedModel"} <= set(rinscal.__all__)


@pytest.fixture(scope="module")
def soak_file(tmp_path_factory, soak_small):
    log, _, meta = soak_small
    path = tmp_path_factory.mktemp("rule") / "soak.csv"
    write_log(log, path)
    write_meta(meta, path)
    return path


def test_select_auto_through_the_api_is_the_command(soak_file) -> None:
    """``rinscal.select(log, "auto")`` prints, as JSON, what ``rinscal select --json`` does,
    at a tolerance given and at the default; ``fit`` at that tolerance chooses the same."""
    log, meta = read_log(soak_file), read_meta(soak_file)
    res = rinscal.select(log, "auto", tolerance=0.05, meta=meta, source=str(soak_file))
    assert isinstance(res, AutoSelectionResult) and res.tolerance == 0.05
    out = CliRunner().invoke(app, ["select", str(soak_file), "--tolerance", "0.05", "--json"])
    assert out.exit_code == 0, out.output
    doc = json.loads(out.output)
    assert doc == {"log": soak_file.name, **json.loads(json.dumps(res.to_dict()))}
    assert all(ch["tolerance"] == 0.05 for ch in doc["channels"].values())
    fit = rinscal.fit(log, "auto", meta=meta, tolerance=0.05)
    assert {c: fit.model.models[c].selection["chosen"] for c in CHANNELS} == res.chosen
    default = rinscal.select(log, "auto", meta=meta)
    assert default.tolerance == DEFAULT_TOLERANCES["auto"] == 0.0


def test_select_auto_refuses_the_settings_of_a_sweep(soak_small) -> None:
    with pytest.raises(ConfigError, match="settings"):
        rinscal.select(soak_small[0], "auto", settings=(1, 2))
    with pytest.raises(ConfigError, match="candidates"):
        rinscal.select(soak_small[0], "regression", candidates=("px4",))
