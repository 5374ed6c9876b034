"""The JSON files' checksum (``rinscal.io.checksum``) and atomic writing with the one output
rule (``rinscal.io.atomic``), each against answers worked out by hand."""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

import pytest

from rinscal.errors import OutputError
from rinscal.io.atomic import (
    check_output,
    make_folders,
    missing_folder_error,
    remove_empty_folders,
    write_atomic,
)
from rinscal.io.checksum import canonical_json, checksum_problem, payload_sha256


def test_canonical_json_ignores_key_order_and_spacing_only() -> None:
    a = {"b": [1.5, "x"], "a": 1}
    assert canonical_json(a) == b'{"a":1,"b":[1.5,"x"]}'
    assert canonical_json({"a": 1, "b": [1.5, "x"]}) == canonical_json(a)
    assert canonical_json({"a": 1, "b": [1.5, "y"]}) != canonical_json(a)
    assert canonical_json({"é": 1}) == b'{"\\u00e9":1}'  # ASCII text, every value counted


def test_payload_sha256_is_the_digest_of_the_canonical_text() -> None:
    want = hashlib.sha256(b'{"a":1,"b":[1.5,"x"]}').hexdigest()
    assert payload_sha256({"b": [1.5, "x"], "a": 1}) == want


def test_checksum_problem_names_each_fault() -> None:
    payload = {"a": 1}
    good = payload_sha256(payload)
    assert checksum_problem(good, payload) is None
    assert "mismatch" in checksum_problem(good, {"a": 2})
    assert "64 lowercase hex" in checksum_problem(good.upper(), payload)
    assert "64 lowercase hex" in checksum_problem(None, payload)
    assert "cannot be checksummed" in checksum_problem(good, {"a": float("nan")})


def test_write_atomic_leaves_the_old_file_whole_when_the_writer_fails(tmp_path: Path) -> None:
    target = tmp_path / "out.csv"
    target.write_text("old")

    def broken(p: Path) -> None:
        p.write_text("half")
        raise RuntimeError("crash while writing")

    with pytest.raises(RuntimeError):
        write_atomic(target, broken)
    assert target.read_text() == "old"
    assert sorted(tmp_path.iterdir()) == [target]  # no temporary file left behind
    write_atomic(target, lambda p: p.write_text("new"))
    assert target.read_text() == "new"
    umask = os.umask(0)
    os.umask(umask)
    assert target.stat().st_mode & 0o777 == 0o666 & ~umask  # a normal file, not mkstemp's 0600


def test_a_missing_folder_is_an_output_error_naming_the_file(tmp_path: Path) -> None:
    with pytest.raises(OutputError, match=r"out\.csv"):
        write_atomic(tmp_path / "no" / "out.csv", lambda p: p.write_text("x"))


def test_check_output_lists_missing_folders_outermost_first_and_creates_none(
    tmp_path: Path,
) -> None:
    out = tmp_path / "a" / "b" / "report"
    missing = check_output(out, folder=True)
    assert missing == [tmp_path / "a", tmp_path / "a" / "b", out]
    assert not (tmp_path / "a").exists()
    assert check_output(tmp_path / "a" / "f.csv") == [tmp_path / "a"]
    err = missing_folder_error(tmp_path / "a" / "f.csv", [tmp_path / "a"], what="--log")
    assert "--log" in str(err) and f"mkdir -p {tmp_path / 'a'}" in str(err)
    created = make_folders(missing)
    assert created == missing and out.is_dir()
    remove_empty_folders(created)
    assert not (tmp_path / "a").exists()


def test_check_output_refuses_a_file_in_the_way(tmp_path: Path) -> None:
    blocker = tmp_path / "f"
    blocker.write_text("x")
    with pytest.raises(OutputError, match="is a file, not a folder"):
        check_output(blocker / "sub" / "out.csv")
    with pytest.raises(OutputError, match="not a folder"):
        check_output(blocker, folder=True)
    with pytest.raises(OutputError, match="a folder is in the way"):
        check_output(tmp_path)
