"""The CLI's output rule before any work (``rinscal.cli._options``): an input is never
overwritten, folder outputs are created with their parents, a file's folder must exist."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
import typer

from rinscal.cli._app import created_folders
from rinscal.cli._options import is_same_file, prepare_outputs, refuse_inputs


def test_is_same_file_sees_through_links_and_relative_paths(tmp_path: Path) -> None:
    a = tmp_path / "log.csv"
    a.write_text("x")
    link = tmp_path / "link.csv"
    link.symlink_to(a)
    rel = Path(os.path.relpath(a))
    assert is_same_file(a, link) and is_same_file(rel, a)
    assert not is_same_file(a, tmp_path / "other.csv")


def test_an_input_is_never_an_output(tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    log = tmp_path / "log.csv"
    log.write_text("x")
    with pytest.raises(typer.Exit) as exit_:
        refuse_inputs(log, [log])
    assert exit_.value.exit_code == 2
    assert "refusing to overwrite the input" in capsys.readouterr().err
    with pytest.raises(typer.Exit):  # its sidecar metadata is an input too
        refuse_inputs(tmp_path / "log.csv.meta.json", [log])
    assert log.read_text() == "x"


def test_folder_outputs_are_created_and_a_file_needs_its_folder(tmp_path: Path) -> None:
    out = tmp_path / "runs" / "a"
    prepare_outputs(files=[("--log", out / "errors.csv")], folders=[("--out", out)])
    assert out.is_dir() and created_folders[-2:] == [tmp_path / "runs", out]
    with pytest.raises(typer.Exit):
        prepare_outputs(files=[("--log", tmp_path / "missing" / "x.csv")])
    assert not (tmp_path / "missing").exists()
