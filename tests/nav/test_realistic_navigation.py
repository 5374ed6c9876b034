"""A recording made like the real one, navigated as a user would: default options (issue 35).

The recordings of ``tests/nav/_realistic.py`` hold what the real ring-laser recording of the
issue held and our simulator used not to make: integer counts of 0.1″ and 125 µg·s at
100 Hz, a dithered laser gyro's white angle noise (σ ≈ 3.2 °/h at τ = 1 s, slope about −0.84 out
to 100 s) over a true random walk of 0.01 °/√h, and a parked vehicle with people about it for
the first 9 minutes. Each test navigates such a recording with default options (the noise,
the window, the checks all from the data) and again with the true noise written into its
metadata on the same window, and compares.

What a single run can show. The heading a 10 min gyrocompass hands over scatters by about
476″ (rms over seeds 35-40 with the true noise told; N/(Ω cos L·√T) = 410″ for the random
walk alone), so one run's heading is compared with the true-noise run's on the same data
(1.5× plus 30″ where both are small), and the slow test compares the rms over seeds, which is
what "as well as its data allow" means. The same curve made by a correlated angle noise over
a smaller random walk (``ring_laser_correlated``) is the case a window cannot resolve: its
slow test is an expected failure that says by how much.
"""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

from rinscal.cli import app
from tests.nav._realistic import Realistic, write_realistic

runner = CliRunner()


def _navigate(log: Path, out: Path, *extra: str) -> tuple[dict[str, Any], str]:
    res = runner.invoke(app, ["navigate", "--log", str(log), "--out", str(out), *extra])
    assert res.exit_code == 0, res.output
    return json.loads((out / "summary.json").read_text()), res.output


def _with_true_noise(rec: Realistic, folder: Path) -> Path:
    """A copy of the recording whose metadata tells the filter the plant's true noise."""
    folder.mkdir(parents=True, exist_ok=True)
    dst = folder / rec.path.name
    shutil.copyfile(rec.path, dst)
    meta = rec.meta()
    meta["noise"] = rec.true_noise()
    Path(f"{dst}.meta.json").write_text(json.dumps(meta))
    return dst


def _pair(rec: Realistic, tmp: Path) -> tuple[dict[str, Any], dict[str, Any], str]:
    """Default options, then the true noise on the window the default found."""
    default, text = _navigate(rec.path, tmp / "default")
    w = default["recording"]["window"]
    true, _ = _navigate(
        _with_true_noise(rec, tmp / "true"),
        tmp / "true_out",
        "--align-start-s",
        str(w["start_s"]),
        "--align-s",
        str(w["length_s"]),
    )
    return default, true, text


def _errors(summary: dict[str, Any]) -> tuple[float, float]:
    v = summary["variants"]["none"]
    return v["attitude_error_at_nav_start"]["heading_arcsec"], v["max_error_nmi"]


def test_a_ring_laser_recording_navigates_as_well_as_its_data_allow(
    realistic_rlg: Realistic, tmp_path: Path
) -> None:
    rec = realistic_rlg
    default, true, text = _pair(rec, tmp_path)
    window = default["recording"]["window"]
    # the window is found after the disturbance, and the disturbance is reported
    assert window["how"] == "found"
    disturbed = window["disturbed"]
    assert disturbed, text
    assert disturbed[0]["start_s"] < 60.0
    assert disturbed[-1]["end_s"] >= 0.9 * rec.disturbed[1]
    assert window["start_s"] >= disturbed[-1]["end_s"]
    assert "disturbed: gyro peaks" in text
    # the random walks: within 1.5× where resolved, else a bound the truth lies under
    allan = default["recording"]["noise"]["allan"]
    for sensor, truth in (("gyro", rec.gyro_arw_deg_rth), ("accel", rec.accel_vrw_ug_rthz)):
        n = allan[sensor]["terms"]["n"]
        if n["resolved"]:
            assert 1 / 1.5 <= n["value"] / truth <= 1.5, (sensor, n, truth)
        else:
            assert n["bound"] >= truth, (sensor, n, truth)
    # no false warning on a correct site and a parked vehicle
    warnings = " ".join(default["recording"]["warnings"])
    assert "latitude" not in warnings and "never" not in warnings, warnings
    assert default["recording"]["recording_kind"]["kind"].startswith("at rest")
    # heading and position error within 1.5× of the true noise's on the same window
    h_def, e_def = _errors(default)
    h_true, e_true = _errors(true)
    assert e_def <= 1.5 * e_true, (e_def, e_true)
    assert e_def < 0.1
    assert abs(h_def) <= 1.5 * abs(h_true) + 30.0, (h_def, h_true)


def test_a_fog_like_unit_is_no_worse_than_with_its_true_noise(
    realistic_fog: Realistic, tmp_path: Path
) -> None:
    """Rate output, white rate noise: the estimate is the random walk itself."""
    default, true, _ = _pair(realistic_fog, tmp_path)
    n = default["recording"]["noise"]["gyro_arw_deg_per_rth"]
    assert 1 / 1.5 <= n / realistic_fog.gyro_arw_deg_rth <= 1.5
    (h_def, e_def), (h_true, e_true) = _errors(default), _errors(true)
    assert e_def <= 1.5 * e_true + 0.002, (e_def, e_true)
    assert abs(h_def) <= 1.5 * abs(h_true) + 30.0, (h_def, h_true)


def _over_seeds(variant: str, tmp_path: Path) -> tuple[dict[str, list[float]], ...]:
    """Heading [arcsec] and maximum horizontal error [nmi] per seed 35-40, with default
    options and with the true noise told on the window the default found."""
    heads: dict[str, list[float]] = {"default": [], "true": []}
    errs: dict[str, list[float]] = {"default": [], "true": []}
    for seed in range(35, 41):
        (tmp_path / f"s{seed}").mkdir()
        rec = write_realistic(tmp_path / f"s{seed}", variant, seed=seed)
        default, true, _ = _pair(rec, tmp_path / f"n{seed}")
        for name, s in (("default", default), ("true", true)):
            h, e = _errors(s)
            heads[name].append(h)
            errs[name].append(e)
    return heads, errs


def _rms(x: list[float]) -> float:
    return math.sqrt(sum(v * v for v in x) / len(x))


@pytest.mark.slow
def test_over_seeds_the_default_matches_the_true_noise(tmp_path: Path) -> None:
    """rms over six cold starts: heading and maximum horizontal error with default options
    within 1.5× of the same windows' with the true noise told (about 3 min). Measured:
    heading 487″ against 476″ (1.02), maximum error 0.096 against 0.098 nmi (0.98)."""
    heads, errs = _over_seeds("ring_laser", tmp_path)
    assert _rms(heads["default"]) <= 1.5 * _rms(heads["true"]), heads
    assert _rms(errs["default"]) <= 1.5 * _rms(errs["true"]), errs


@pytest.mark.slow
@pytest.mark.xfail(
    strict=True,
    raises=AssertionError,
    reason=(
        "the limit of a 10 min window: where the Allan curve's bend is a correlated angle "
        "noise (6″, τc 100 s) over a random walk of 0.0075 °/√h, the window cannot tell it "
        "from a random walk of 0.014 °/√h, the filter is told the fit's N (0.014-0.017 °/√h) "
        "and weights its oldest data less: rms heading 697″ against 405″ with the true noise "
        "(1.7×) on seeds 35-40, maximum horizontal error 0.095 against 0.091 nmi. Choosing "
        "the least random walk the curve allows fixes it (1.2×) but tells a unit of pure "
        "random walk half its noise: the two are the same curve on 10 min. Give the noise "
        "(metadata, --imu) of such a unit."
    ),
)
def test_a_correlated_angle_noise_is_beyond_a_window(tmp_path: Path) -> None:
    """The same comparison on ``ring_laser_correlated`` (about 3 min)."""
    heads, errs = _over_seeds("ring_laser_correlated", tmp_path)
    assert _rms(heads["default"]) <= 1.5 * _rms(heads["true"]), heads
    assert _rms(errs["default"]) <= 1.5 * _rms(errs["true"]), errs
