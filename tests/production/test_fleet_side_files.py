"""``fleet fit runs/*.parquet`` over simulated logs: the truth and metadata written beside each
log are skipped (and named), not counted as units that failed (issue 34, item 6)."""

from __future__ import annotations

from pathlib import Path

from typer.testing import CliRunner

from rinscal.cli import app
from rinscal.production.fleet import split_side_files


def _simulate(path: Path, seed: int) -> None:
    res = CliRunner().invoke(
        app,
        [
            "simulate",
            "soak",
            "--hours",
            "0.05",
            "--rate",
            "2",
            "--seed",
            str(seed),
            "--out",
            str(path),
        ],
    )
    assert res.exit_code == 0, res.output


def test_fleet_over_a_simulated_folder_skips_the_truth_files(tmp_path) -> None:
    runs = tmp_path / "runs"
    runs.mkdir()  # a file goes into a folder that exists
    for k in (1, 2):
        _simulate(runs / f"SN{k}.parquet", k)
    given = sorted(runs.glob("*.parquet"))  # what the shell gives for runs/*.parquet
    assert [p.name for p in given] == [
        "SN1.parquet",
        "SN1.truth.parquet",
        "SN2.parquet",
        "SN2.truth.parquet",
    ]
    out = tmp_path / "fleet"
    res = CliRunner().invoke(
        app, ["fleet", "fit", *map(str, given), "--out", str(out), "--workers", "1"]
    )
    assert res.exit_code == 0, res.output
    text = " ".join(res.output.split())
    assert "skipped 2 side file(s)" in text and "SN1.truth.parquet, SN2.truth.parquet" in text
    assert "2 unit(s): 2 fitted, 0 failed" in text
    assert not (out / "failed").exists() or not any((out / "failed").iterdir())


def test_side_files_are_those_the_writers_name(tmp_path) -> None:
    from rinscal.io.metadata import meta_path, truth_path
    from rinscal.io.params import TRUTH_SUFFIX, params_path

    log = tmp_path / "cal.csv"
    files = [log, truth_path(log), params_path(log, TRUTH_SUFFIX), meta_path(log)]
    for f in files:
        f.write_text("x")
    lone = tmp_path / "other.truth.csv"  # looks like a truth, but no log of it is there
    lone.write_text("x")
    logs, side = split_side_files([*map(str, files), str(lone)])
    assert logs == [str(log), str(lone)]
    assert side == [str(f) for f in files[1:]]
