"""The oracle's decomposition on error vectors built here: the angle between the thermal
part and the rest, the signed thermal part, and which runs the oracle loses and why."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from rinscal import units
from rinscal.experiments.paper.mechanism import (
    ORACLE_NO_OFFSETS,
    error_growth_table,
    group_cep_table,
    oracle_decomposition_table,
    oracle_loss_reasons,
)

NMI = units.NMI_TO_M


def _run(index: int, thermal: tuple[float, float], rest: tuple[float, float], z=(0.001, -0.007)):
    """A quasi-static run whose errors grow linearly to the given end vectors [nmi]:
    oracle = rest, none = rest + thermal, the oracle without offsets = rest / 2."""
    t = np.linspace(600.0, 7200.0, 12)
    s = (t - t[0]) / (t[-1] - t[0])
    e = {"time_s": t}
    for v, (x, y) in {
        "none": (thermal[0] + rest[0], thermal[1] + rest[1]),
        "true": rest,
        ORACLE_NO_OFFSETS: (rest[0] / 2, rest[1] / 2),
    }.items():
        e[f"{v}_east"], e[f"{v}_north"] = x * NMI * s, y * NMI * s
        e[v] = np.hypot(e[f"{v}_east"], e[f"{v}_north"])
    variants = {v: {"attitude_error_at_nav_start": {"heading_arcsec": 1.0}} for v in
                ("none", "true", ORACLE_NO_OFFSETS)}  # fmt: skip
    mech = {"none": {"gyro_z_nav_dph": z[0], "gyro_z_offset_dph": z[1]}}
    job = SimpleNamespace(experiment="lab", scenario="quasi-static", index=index)
    return SimpleNamespace(job=job, errors=pd.DataFrame(e), summary={"variants": variants},
                           mechanism=mech)  # fmt: skip


def _modulation(runs) -> pd.DataFrame:
    return pd.DataFrame(
        [
            {
                "run": f"quasi-static {r.job.index}",
                "variant": "none",
                "z gyro residual in nav [°/h]": r.mechanism["none"]["gyro_z_nav_dph"],
                "z gyro turn-on offset [°/h]": r.mechanism["none"]["gyro_z_offset_dph"],
            }
            for r in runs
        ]
    )


def test_decomposition_angle_and_signed_thermal_part() -> None:
    # run 1: thermal (1, 0) against rest (−1.5, 0): opposite, none = 0.5 < oracle = 1.5
    # run 2: thermal (0, 1) beside rest (1, 0): 90°, none = √2 > oracle = 1
    runs = [_run(1, (1.0, 0.0), (-1.5, 0.0)), _run(2, (0.0, 1.0), (1.0, 0.0), z=(0.001, 0.002))]
    d = oracle_decomposition_table(runs).set_index("run")
    assert d.loc["quasi-static 1", "angle thermal/rest [°]"] == pytest.approx(180.0)
    assert d.loc["quasi-static 2", "angle thermal/rest [°]"] == pytest.approx(90.0)
    assert d.loc["quasi-static 1", "thermal part (none − oracle) [nmi]"] == pytest.approx(-1.0)
    assert d.loc["quasi-static 2", "thermal part (none − oracle) [nmi]"] == pytest.approx(
        np.sqrt(2) - 1
    )
    assert d.loc["quasi-static 1", "oracle w/o offsets [nmi]"] == pytest.approx(0.75)
    losses = oracle_loss_reasons(d.reset_index(), _modulation(runs))
    assert [x["run"] for x in losses] == ["quasi-static 1"]
    (x,) = losses
    assert x["offsets_cost_nmi"] == pytest.approx(0.75)
    assert x["z_cancel"] is True  # +0.001 against −0.007 °/h


def test_drift_rate_and_cep_of_a_group() -> None:
    runs = [_run(i, (0.0, 0.0), (float(i), 0.0)) for i in (1, 2, 3)]
    g = error_growth_table(runs, ["true"])
    hours = (7200.0 - 600.0) / 3600.0
    np.testing.assert_allclose(g["drift rate [nmi/h]"], [1 / hours, 2 / hours, 3 / hours])
    np.testing.assert_allclose(g["final [nmi]"], [1.0, 2.0, 3.0])
    cep = group_cep_table(g, runs)
    assert cep["CEP (median final) [nmi]"].iloc[0] == pytest.approx(2.0)
    assert cep["n runs"].iloc[0] == 3
    assert cep["runs"].iloc[0] == "lab quasi-static"


def test_no_cep_from_one_run_and_no_group_named_twice() -> None:
    # issue 36: a group of one run (the chamber ramp) gets no CEP, and is called "ramp",
    # not "ramp ramp"; the page says n = 1 where the CEP would stand
    ramp = _run(1, (0.0, 0.0), (1.0, 0.0))
    ramp.job = SimpleNamespace(experiment="ramp", scenario="ramp", index=1)
    g = error_growth_table([ramp], ["true"])
    cep = group_cep_table(g, [ramp])
    assert list(cep["runs"]) == ["ramp"] and cep["n runs"].iloc[0] == 1
    assert np.isnan(cep["CEP (median final) [nmi]"].iloc[0])
    assert cep["median max [nmi]"].iloc[0] == pytest.approx(1.0)  # the run's own figures stay
