"""``fleet fit`` (``rinscal.cli.fleet``) and ``study`` (``rinscal.cli.study``) refuse what
they cannot run before any work, naming it, and leave no folder behind. The commands are
called as the functions they are (every option given, as Typer passes them)."""

from __future__ import annotations

from pathlib import Path

import pytest
import typer

from rinscal.cli.fleet import fleet_fit
from rinscal.cli.study import study

CLUSTER = {"scheduler": None, "tls_ca_file": None, "tls_cert": None, "tls_key": None}


def _refused(capsys: pytest.CaptureFixture, call) -> str:  # type: ignore[no-untyped-def]
    with pytest.raises(typer.Exit) as exit_:
        call()
    assert exit_.value.exit_code == 2
    return " ".join(capsys.readouterr().err.split())


def test_fleet_fit_refuses_side_files_alone_and_unknown_choices(
    tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    (tmp_path / "SN1.csv").write_text("time_s\n")  # the log, beside its metadata, not given
    side = tmp_path / "SN1.csv.meta.json"
    side.write_text("{}")
    out = tmp_path / "fleet"
    opts = {"limits": None, "workers": 1, "retry_failed": False, **CLUSTER}
    msg = _refused(capsys, lambda: fleet_fit([side], out, method="auto", export="c", **opts))
    assert "no log among the 1 file(s) given: only side files" in msg
    msg = _refused(capsys, lambda: fleet_fit([side], out, method="auto", export="hex", **opts))
    assert "--export must be one of" in msg and "'hex'" in msg
    assert not out.exists()


def test_study_refuses_no_workers_and_an_unknown_spec(
    tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    out = tmp_path / "study"
    opts = {"units": None, "quick": True, "imu": None, "retry_failed": False, **CLUSTER}
    msg = _refused(capsys, lambda: study("sensitivity", out, workers=0, **opts))
    assert "--workers must be >= 1, got 0" in msg
    msg = _refused(capsys, lambda: study("no-such-study", out, workers=1, **opts))
    assert "no-such-study" in msg
    assert not out.exists()
