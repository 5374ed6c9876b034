"""A ring-laser recording's random walk is not taken for its correlated angle noise.

The recordings "made like the real one" (``tests/nav/_realistic.py``) hold a dithered laser
gyro's white angle noise (2.3″), a Gauss-Markov angle noise (6″ over τc = 100 s) and the
true angle random walk (0.0075 °/√h). For τ ≪ τc the correlated angle looks exactly like a
random walk of 0.014 °/√h, and a 10 min window reaches τ ≈ 130 s with enough clusters: the
window cannot tell the two apart. Before the correlated term was in the fit, the window
560-1160 s reported ``N 0.016 °/√h ±6 % (resolved)``, twice the truth; now the random walk is
reported as a bound the truth lies under, the filter gets the fit's N (at most its bound),
and the console says what was found and what the filter used. A FOG-like unit (white rate
noise) gets its random walk within 1.5×.
"""

from __future__ import annotations

import json

from typer.testing import CliRunner

from rinscal.cli import app
from tests.nav._realistic import Realistic

runner = CliRunner()


def navigate(rec: Realistic, out, *extra: str) -> tuple[dict, str]:  # type: ignore[no-untyped-def]
    res = runner.invoke(app, ["navigate", "--log", str(rec.path), "--out", str(out), *extra])
    assert res.exit_code == 0, res.output
    return json.loads((out / "summary.json").read_text()), res.output


def test_the_rlg_random_walk_is_within_1_5_or_a_bound_above_the_truth(
    realistic_rlg: Realistic, tmp_path
) -> None:  # type: ignore[no-untyped-def]
    truth = realistic_rlg.gyro_arw_deg_rth
    for start in ("560", None):  # the window of the measurement, and the found one
        extra = ("--align-start-s", start, "--align-s", "600") if start else ()
        summary, out = navigate(realistic_rlg, tmp_path / f"w{start}", *extra)
        noise = summary["recording"]["noise"]
        n = noise["allan"]["gyro"]["terms"]["n"]
        if n["resolved"]:
            assert 1 / 1.5 <= n["value"] / truth <= 1.5
        else:
            assert n["bound"] >= truth
            told = noise["gyro_arw_deg_per_rth"]
            assert 0 < told <= n["bound"] * (1 + 1e-9)
            assert "N ≤ " in out and "not told from a correlated angle noise" in out
            assert noise["allan"]["filter"]["gyro_n"] in ("the fit's N, unresolved",) or (
                noise["allan"]["filter"]["gyro_n"].startswith("bound at τ")
            )
        # the velocity measurement holds the angle noise that does not accumulate
        f = noise["allan"]["filter"]
        q = noise["allan"]["gyro"]["terms"]["q"]["value"]
        assert f["gyro_angle_noise_arcsec"] >= q * (1 - 1e-9)
        assert "filter: ARW" in out and "angle noise" in out
        assert "correlated" in noise["allan"]["gyro"]


def test_a_fog_like_unit_gets_its_random_walk(realistic_fog: Realistic, tmp_path) -> None:  # type: ignore[no-untyped-def]
    summary, _ = navigate(realistic_fog, tmp_path / "fog", "--align-start-s", "560")
    noise = summary["recording"]["noise"]
    truth = realistic_fog.gyro_arw_deg_rth
    assert 1 / 1.5 <= noise["gyro_arw_deg_per_rth"] / truth <= 1.5
    n = noise["allan"]["gyro"]["terms"]["n"]
    assert n["resolved"] or n["bound"] >= truth
    assert not noise["allan"]["gyro"]["correlated"]["kept"]
