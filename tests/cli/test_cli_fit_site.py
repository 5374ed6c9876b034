"""``fit`` of a foreign log without a site warns at fit time, not first at ``compensate`` after
1 g was taken off accel_z (issue 34, item 8)."""

from __future__ import annotations

from pathlib import Path

from typer.testing import CliRunner

import rinscal
from rinscal.cli import app

ROOT = Path(__file__).resolve().parents[2]
LOG = ROOT / "tests" / "data" / "real" / "tofupilot_imu_thermal_cycle.tsv"
MAP = ROOT / "examples" / "tofupilot_mapping.toml"


def _fit(tmp_path: Path, *extra: str) -> str:
    out = tmp_path / "m.json"
    args = ["fit", str(LOG), "--map", str(MAP), "--method", "poly-t", "--out", str(out), *extra]
    res = CliRunner().invoke(app, args)
    assert res.exit_code == 0, res.output
    return " ".join(res.output.split())


def test_fit_without_a_site_says_what_compensate_will_remove(tmp_path) -> None:
    text = _fit(tmp_path)
    assert "warning:" in text and "no site and no static reference" in text
    assert "accel_z" in text and "1 g" in text
    assert "--latitude and --heading" in text and "--static-ref" in text
    # the warning is the model's: compensate then removes accel_z's 1 g, as it said
    mf = rinscal.load_model(tmp_path / "m.json")
    assert mf.models["accel_z"].static_reference is None


def test_fit_with_a_site_or_a_static_reference_does_not_warn(tmp_path) -> None:
    for extra in (["--latitude", "45", "--heading", "0"], ["--static-ref", "mean"]):
        text = _fit(tmp_path, *extra)
        assert "no static reference" not in text, text


def test_the_api_result_carries_the_warning() -> None:
    from rinscal.io.mapping import read_mapping

    result = rinscal.fit(LOG, "poly-t", mapping=read_mapping(MAP))
    assert any("no site and no static reference" in w for w in result.warnings)
