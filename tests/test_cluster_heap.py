"""A local cluster's workers start with the heap settings of ``rinscal.cluster.WORKER_HEAP``
(not Dask's 64 KiB trim threshold, under which every array of 128 KiB or more is mapped and
unmapped anew and its pages faulted in each time), Dask's one-thread BLAS kept."""

import os
import resource

import numpy as np

from rinscal.cluster import WORKER_HEAP, dask_client


def _heap_env() -> dict[str, str | None]:
    keys = (*WORKER_HEAP, "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS")
    return {k: os.environ.get(k) for k in keys}


def _faults_per_array(n: int = 50, size: int = 1 << 20) -> float:
    """Minor page faults per 1 MiB array made, filled and freed (256 if mapped anew)."""
    np.ones(size // 8).sum()  # the heap grown once
    before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
    for _ in range(n):
        a = np.ones(size // 8)
        del a
    return (resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before) / n


def test_local_workers_start_with_the_heap_settings_and_one_blas_thread() -> None:
    with dask_client(workers=1) as client:
        (env,) = client.run(_heap_env).values()
        (faults,) = client.run(_faults_per_array).values()
    assert env["MALLOC_TRIM_THRESHOLD_"] == str(64 << 20)
    assert env["MALLOC_MMAP_THRESHOLD_"] == str(32 << 20)
    assert env["OMP_NUM_THREADS"] == env["OPENBLAS_NUM_THREADS"] == "1"
    # read by glibc at the start: a freed 1 MiB array's pages are reused, not faulted anew
    assert faults < 16, faults
