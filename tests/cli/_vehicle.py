"""The vehicle scenario recorded at 5 Hz for the `navigate --log` tests of a drive: 60 s
parked, then driving (turns and speed changes), the paper's IMU on its turntable."""

from __future__ import annotations

from pathlib import Path

from typer.testing import CliRunner

from rinscal.cli import app


def record_vehicle(folder: Path, hours: float) -> Path:
    """Record ``hours`` [h] of the vehicle scenario at 5 Hz into ``folder``; return the log."""
    rec = folder / "veh.parquet"
    args = ["navigate", "--scenario", "vehicle", "--hours", hours, "--rate", "5",
            "--align-s", "60", "--no-oracle", "--out", folder / "sim", "--record", rec]  # fmt: skip
    res = CliRunner().invoke(app, [str(a) for a in args])
    assert res.exit_code == 0, res.output
    return rec
