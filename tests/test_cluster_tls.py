"""A secured cluster: ``--scheduler tls://...`` with certificate files or Dask's configuration.

A scheduler and a worker started here with ``Security(require_encryption=True)`` on
``tls://127.0.0.1`` (a throwaway self-signed authority made by Dask's own
``Security.temporary``, which needs the ``cryptography`` package of the test extra); a tiny
fleet fitted on it through the CLI; clients without the cluster's certificates refused with a
message naming the address and the options.
"""

from __future__ import annotations

import logging
from collections.abc import Iterator
from pathlib import Path

import dask
import pytest
from typer.testing import CliRunner, Result

from rinscal.cli import app
from rinscal.io.metadata import write_meta
from rinscal.io.tables import write_log
from rinscal.sim.protocols import simulate_protocol

pytest.importorskip(
    "cryptography", reason="certificates are made with cryptography (pip install '.[test]')"
)

BAD_LOG = "time_s,run,gyro_x\n0,a,1\n0,a,2\n"


def _pem_files(folder: Path) -> dict[str, Path]:
    """A new throwaway authority's certificate, key and CA file (one self-signed pair)."""
    from distributed import Security

    sec = Security.temporary()
    folder.mkdir(parents=True)
    files = {"ca": folder / "ca.pem", "cert": folder / "cert.pem", "key": folder / "key.pem"}
    files["ca"].write_text(sec.tls_ca_file, encoding="utf-8")
    files["cert"].write_text(sec.tls_client_cert, encoding="utf-8")
    files["key"].write_text(sec.tls_client_key, encoding="utf-8")
    return files


@pytest.fixture(scope="module")
def pems(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    return _pem_files(tmp_path_factory.mktemp("tls") / "cluster")


@pytest.fixture(scope="module")
def tls_address(pems: dict[str, Path]) -> Iterator[str]:
    """A scheduler and one worker that accept TLS connections with the cluster's certificates
    only."""
    from distributed import LocalCluster, Security

    cert, key = str(pems["cert"]), str(pems["key"])
    sec = Security(
        require_encryption=True,
        tls_ca_file=str(pems["ca"]),
        tls_scheduler_cert=cert,
        tls_scheduler_key=key,
        tls_worker_cert=cert,
        tls_worker_key=key,
        tls_client_cert=cert,
        tls_client_key=key,
    )
    with LocalCluster(
        protocol="tls",
        host="127.0.0.1",
        security=sec,
        n_workers=1,
        threads_per_worker=1,
        processes=False,
        dashboard_address=":0",
        silence_logs=logging.ERROR,
    ) as cluster:
        assert cluster.scheduler_address.startswith("tls://127.0.0.1:")
        yield cluster.scheduler_address


@pytest.fixture(scope="module")
def unit_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    log, _, meta = simulate_protocol("soak", hours=0.5, rate_hz=0.5, seed=3, imu="navigation_grade")
    path = tmp_path_factory.mktemp("unit") / "SN7.csv"
    write_log(log, path)
    write_meta(meta, path)
    return path


def _run(*args: str) -> Result:
    return CliRunner().invoke(app, list(args))


def _fleet(log: Path, out: Path, address: str, pems: dict[str, Path] | None = None) -> Result:
    tls = []
    if pems is not None:
        tls = ["--tls-ca-file", str(pems["ca"]), "--tls-cert", str(pems["cert"])]
        tls += ["--tls-key", str(pems["key"])]
    return _run("fleet", "fit", str(log), "--out", str(out), "--scheduler", address, *tls)


def _one_line(res: Result) -> str:
    return " ".join(res.output.split())


def test_fleet_fits_on_a_tls_cluster_with_certificate_files(
    tls_address: str, pems: dict[str, Path], unit_log: Path, tmp_path: Path
) -> None:
    out = tmp_path / "fleet"
    # no certificate anywhere (neither options nor Dask's configuration): refused at once
    res = _fleet(unit_log, out, tls_address)
    assert res.exit_code == 2, res.output
    text = _one_line(res)
    assert f"--scheduler {tls_address}: a tls:// scheduler needs the cluster's CA" in text
    assert "--tls-ca-file, --tls-cert and --tls-key" in text
    assert "distributed.comm.tls.ca-file" in text and "Traceback" not in res.output
    assert not out.exists()
    # the cluster's certificate files: the unit is fitted on the cluster's worker
    res = _fleet(unit_log, out, tls_address, pems)
    assert res.exit_code == 0, res.output
    text = _one_line(res)
    assert "1 fitted, 0 failed, 0 already done" in text and "on 1 worker(s)" in text
    assert (out / "units" / "SN7.json").is_file() and (out / "exports" / "SN7.h").is_file()


def test_dask_configuration_gives_the_certificates(
    tls_address: str, pems: dict[str, Path], tmp_path: Path
) -> None:
    log = tmp_path / "SN8.csv"
    log.write_text(BAD_LOG, encoding="utf-8")  # fails fast, on the worker
    config = {
        "distributed.comm.tls.ca-file": str(pems["ca"]),
        "distributed.comm.tls.client.cert": str(pems["cert"]),
        "distributed.comm.tls.client.key": str(pems["key"]),
    }
    with dask.config.set(config):
        res = _fleet(log, tmp_path / "fleet", tls_address)
    assert res.exit_code == 0, res.output
    assert "0 fitted, 1 failed" in _one_line(res) and "on 1 worker(s)" in _one_line(res)


def test_a_client_with_other_certificates_is_refused(
    tls_address: str, unit_log: Path, tmp_path: Path
) -> None:
    other = _pem_files(tmp_path / "other")  # signed by another authority
    for cmd in (
        ["fleet", "fit", str(unit_log), "--out", str(tmp_path / "fleet")],
        ["study", "paper", "--quick", "--units", "1", "--out", str(tmp_path / "study")],
    ):
        res = _run(
            *cmd,
            "--scheduler",
            tls_address,
            "--tls-ca-file",
            str(other["ca"]),
            "--tls-cert",
            str(other["cert"]),
            "--tls-key",
            str(other["key"]),
        )
        assert res.exit_code == 2, res.output
        text = _one_line(res)
        assert f"--scheduler {tls_address}: cannot connect" in text, cmd
        assert "TLS certificate does not match" in text
        assert "check --tls-ca-file, --tls-cert and --tls-key" in text
        assert "Traceback" not in res.output


def test_certificates_need_a_tls_scheduler(pems: dict[str, Path], unit_log: Path, tmp_path):
    nope = tmp_path / "nope.pem"
    cases = {  # options: what the refusal says
        ("--tls-cert", str(pems["cert"])): "secure a tls:// scheduler, not a local cluster",
        ("--scheduler", "tcp://127.0.0.1:8786", "--tls-ca-file", str(pems["ca"])): (
            "not --scheduler tcp://127.0.0.1:8786: give the secured scheduler's address"
        ),
        ("--scheduler", "tls://127.0.0.1:8786", "--tls-ca-file", str(nope)): (
            f"--tls-ca-file {nope}: no such file"
        ),
        ("--scheduler", "tcp://127.0.0.1:8786", "--workers", "2"): "exclude each other",
    }
    out = str(tmp_path / "out")
    for cmd in (["fleet", "fit", str(unit_log)], ["study", "paper", "--quick"]):
        for options, says in cases.items():
            res = _run(*cmd, "--out", out, *options)
            assert res.exit_code == 2, res.output
            assert says in _one_line(res), (cmd, options)
            assert "Traceback" not in res.output
    assert not (tmp_path / "out").exists()
