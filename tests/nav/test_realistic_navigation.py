"""A recording made like the real one, navigated as a user would: default options (issue 35).

The recordings of ``tests/nav/_realistic.py`` hold what the real ring-laser recording of the
issue held and our simulator used not to make: integer counts of 0.1″ and 125 µg·s at
100 Hz, a dithered laser gyro's angle noise (σ ≈ 4 °/h at τ = 1 s, slope about −0.8 out to
100 s) over a true random walk of 0.0075 °/√h, and a parked vehicle with people about it for
the first 9 minutes. Each test navigates such a recording with default options (the noise,
the window, the checks all from the data) and again with the true noise written into its
metadata on the same window, and compares.

What a single run can show and what it cannot. The heading a 10 min gyrocompass hands over
scatters by about 400″ (rms) on this unit whatever the filter is told (the correlated angle
noise moves the east gyro's mean by ~0.016 °/h over the window), and two filters tuned
differently on the same data land at different points of that scatter: on seed 35 the
default gives −528″ where the true noise gives −277″. So the per-run test asks the position
error (which the whole run decides) to be within 1.5× of the true-noise run's, and the
heading to be within the scatter; the slow test compares the rms over seeds, which is what
"as well as its data allow" means.
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

#: Heading scatter of a 10 min alignment on the ring-laser unit [arcsec]: the rms over 30
#: windows and seeds with the true noise told was 393″ (docs/navigation.md); a run beyond
#: 3 × that is not scatter.
HEADING_SCATTER_ARCSEC = 400.0


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
    # the position error within 1.5× of the true noise's on the same window; the heading
    # within the alignment's own scatter
    h_def, e_def = _errors(default)
    h_true, e_true = _errors(true)
    assert e_def <= 1.5 * e_true, (e_def, e_true)
    assert e_def < 0.1
    assert abs(h_def) <= 3 * HEADING_SCATTER_ARCSEC and abs(h_true) <= 3 * HEADING_SCATTER_ARCSEC


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


@pytest.mark.slow
@pytest.mark.xfail(
    strict=True,
    reason=(
        "issue 35 open: on the windows found after the disturbance (seeds 35-40) the rms "
        "heading error with default options is 697″ against 405″ with the true noise (1.7×; "
        "maximum horizontal error 0.095 against 0.091 nmi rms). A 10 min window cannot tell the "
        "gyro's correlated angle noise (6″, τc 100 s) from a random walk, so the filter is "
        "told the fit's N (0.014-0.017 °/√h, truth 0.0075) and weights its oldest data "
        "less; the heading grows monotonically with the N told (0.0075: 405″ rms). "
        "Choosing the least random walk the curve allows fixes it (1.2×) but tells a unit "
        "of pure random walk half its noise: the two are the same curve on 10 min."
    ),
)
def test_over_seeds_the_default_matches_the_true_noise(tmp_path: Path) -> None:
    """rms over six cold starts: heading and maximum horizontal error with default options
    within 1.5× of the same windows' with the true noise told (about 3 min)."""
    heads: dict[str, list[float]] = {"default": [], "true": []}
    errs: dict[str, list[float]] = {"default": [], "true": []}
    for seed in range(35, 41):
        (tmp_path / f"s{seed}").mkdir()
        rec = write_realistic(tmp_path / f"s{seed}", "ring_laser", seed=seed)
        default, true, _ = _pair(rec, tmp_path / f"n{seed}")
        for name, s in (("default", default), ("true", true)):
            h, e = _errors(s)
            heads[name].append(h)
            errs[name].append(e)

    def rms(x: list[float]) -> float:
        return math.sqrt(sum(v * v for v in x) / len(x))

    assert rms(heads["default"]) <= 1.5 * rms(heads["true"]), heads
    assert rms(errs["default"]) <= 1.5 * rms(errs["true"]), errs
