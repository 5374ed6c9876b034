"""The Dask cluster every fan-out of rinscal runs on (studies, fleets, the reproduction's
navigation runs): a local cluster of single-threaded worker processes, or an existing cluster
by its scheduler address, ``tls://`` for a secured one (:class:`TLSFiles`).

A Dask cluster runs whatever its clients send it (pickled functions and data), and a client
unpickles what comes back: connect only to a cluster you trust, and secure one that others can
reach with TLS (every endpoint then proves itself with a certificate of the cluster's own
authority)."""

from __future__ import annotations

import logging
import os
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

from rinscal.errors import ConfigError

#: The argument of the certificate files (the command line says its --tls-* options), and the
#: Dask configuration keys that stand in for any not given (for messages).
TLS_OPTIONS = "tls="
TLS_CONFIG = (
    "distributed.comm.tls.ca-file, distributed.comm.tls.client.cert and "
    "distributed.comm.tls.client.key"
)


@dataclass(frozen=True)
class TLSFiles:
    """A client's certificate files (PEM) for a ``tls://`` scheduler.

    Attributes
    ----------
    ca_file : str, optional
        The certificate of the authority that signed the cluster's certificates.
    cert : str, optional
        This client's certificate (its key may be appended to it).
    key : str, optional
        This client's private key.

    Any left out is taken from Dask's configuration (:data:`TLS_CONFIG`).
    """

    ca_file: str | None = None
    cert: str | None = None
    key: str | None = None

    def given(self) -> dict[str, str]:
        """The files given, as :class:`distributed.Security` arguments."""
        pairs = {
            "tls_ca_file": self.ca_file,
            "tls_client_cert": self.cert,
            "tls_client_key": self.key,
        }
        return {k: v for k, v in pairs.items() if v is not None}


def cluster_security(scheduler: str | None, tls: TLSFiles | None = None) -> Any:
    """The :class:`distributed.Security` to reach ``scheduler`` with (None for ``tcp://``).

    A ``tls://`` address requires encryption, with the files of ``tls`` and Dask's own
    configuration for any not given (``Security`` reads it).

    Raises
    ------
    ConfigError
        Certificate files without a ``tls://`` scheduler; a ``tls://`` scheduler without a
        CA certificate or a client certificate (naming the options and configuration keys).
    """
    given = tls.given() if tls is not None else {}
    if not (scheduler or "").startswith("tls://"):
        if given:
            where = f"scheduler={scheduler}" if scheduler else "a local cluster"
            raise ConfigError(
                f"the certificate files ({TLS_OPTIONS}) secure a tls:// scheduler, not "
                f"{where}: give the secured scheduler's address, tls://host:port"
            )
        return None
    from distributed import Security  # deferred: Dask is heavy

    security = Security(require_encryption=True, **given)
    if not (security.tls_ca_file and security.tls_client_cert):
        raise ConfigError(
            f"scheduler={scheduler}: a tls:// scheduler needs the cluster's CA certificate and "
            f"this client's certificate and key: give {TLS_OPTIONS}, or set {TLS_CONFIG} in "
            "Dask's configuration"
        )
    return security


#: The C library's heap settings of a local cluster's worker processes (glibc reads them at
#: start). Dask sets ``MALLOC_TRIM_THRESHOLD_`` to 64 KiB so that a worker hands freed memory
#: back at once; set, it also fixes glibc's mmap threshold at 128 KiB, and every array of
#: that size or more is then mapped and unmapped anew, its pages faulted in each time: the
#: reproduction's neural fits spent 3.6 s in the kernel for 10 s of their own (0.1 s with
#: these). An allocation below 32 MiB comes from the heap and is reused; more than 64 MiB
#: free at its top goes back to the system.
WORKER_HEAP = {"MALLOC_MMAP_THRESHOLD_": str(32 << 20), "MALLOC_TRIM_THRESHOLD_": str(64 << 20)}


def local_workers(workers: int | None = None) -> int:
    """Worker processes of a local cluster: ``workers``, else one per core available to
    this process."""
    return workers or len(os.sched_getaffinity(0))


@contextmanager
def dask_client(
    workers: int | None = None, scheduler: str | None = None, tls: TLSFiles | None = None
) -> Iterator[Any]:
    """A Dask client: on the cluster at ``scheduler`` (``tcp://host:8786``, or ``tls://`` with
    :func:`cluster_security` of ``tls``), or on a new :class:`distributed.LocalCluster` of
    ``workers`` single-threaded worker processes (default: one per core available to this
    process; their heap settings :data:`WORKER_HEAP`), closed on exit."""
    import dask  # deferred: Dask is heavy
    from distributed import Client, LocalCluster

    security = cluster_security(scheduler, tls)
    if scheduler:
        try:
            client = Client(scheduler, timeout="30s", security=security)
        except (OSError, ValueError, TimeoutError) as e:
            hint = ""
            if security is not None:
                hint = f"; check {TLS_OPTIONS} (or {TLS_CONFIG} in Dask's configuration)"
            raise ConfigError(f"scheduler={scheduler}: cannot connect ({e}){hint}") from None
        try:
            yield client
        finally:
            client.close()
        return
    n = local_workers(workers)
    # set before each worker process starts (glibc reads them then): Dask's own pre-spawn
    # settings (one BLAS thread ...) with the heap's
    key = "distributed.nanny.pre-spawn-environ"
    heap = {**dask.config.get(key, default={}), **WORKER_HEAP}
    with (
        dask.config.set({key: heap}),
        LocalCluster(
            n_workers=n,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",
            silence_logs=logging.ERROR,
        ) as cluster,
        Client(cluster) as client,
    ):
        yield client


__all__ = [
    "TLS_CONFIG",
    "TLS_OPTIONS",
    "WORKER_HEAP",
    "TLSFiles",
    "cluster_security",
    "dask_client",
    "local_workers",
]
