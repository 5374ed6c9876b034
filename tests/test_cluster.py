"""The Dask cluster's choices (``rinscal.cluster``) that need no cluster: workers, and when
certificates are asked for, used or refused."""

from __future__ import annotations

import os

import pytest

from rinscal.cluster import TLSFiles, cluster_security, local_workers
from rinscal.errors import ConfigError


def test_local_workers_default_to_the_cores_this_process_may_use() -> None:
    assert local_workers(3) == 3
    assert local_workers() == len(os.sched_getaffinity(0))


def test_only_the_files_given_are_passed_to_dask() -> None:
    assert TLSFiles().given() == {}
    assert TLSFiles(ca_file="ca.pem", key="k.pem").given() == {
        "tls_ca_file": "ca.pem",
        "tls_client_key": "k.pem",
    }


def test_a_plain_scheduler_needs_no_security_and_refuses_certificates() -> None:
    assert cluster_security(None) is None
    assert cluster_security("tcp://host:8786") is None
    with pytest.raises(ConfigError, match="not scheduler=tcp://host:8786"):
        cluster_security("tcp://host:8786", TLSFiles(ca_file="ca.pem"))
    with pytest.raises(ConfigError, match="not a local cluster"):
        cluster_security(None, TLSFiles(cert="c.pem"))


def test_a_tls_scheduler_without_certificates_is_refused_naming_the_options() -> None:
    dask = pytest.importorskip("dask")
    pytest.importorskip("distributed")
    with dask.config.set({"distributed.comm.tls.ca-file": None}):
        with pytest.raises(ConfigError, match="tls://h:8786: a tls:// scheduler needs"):
            cluster_security("tls://h:8786")
