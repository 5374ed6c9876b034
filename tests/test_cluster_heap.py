"""A local cluster's workers run with the heap settings of ``rinscal.cluster.WORKER_HEAP``
(not Dask's 64 KiB trim threshold, under which every array of 128 KiB or more is mapped and
unmapped anew), the one-thread BLAS of Dask's defaults kept."""

import os

from rinscal.cluster import WORKER_HEAP, dask_client


def _heap_env() -> dict[str, str | None]:
    keys = (*WORKER_HEAP, "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS")
    return {k: os.environ.get(k) for k in keys}


def test_local_workers_get_the_heap_settings_and_one_blas_thread() -> None:
    with dask_client(workers=1) as client:
        (env,) = client.run(_heap_env).values()
    assert env["MALLOC_TRIM_THRESHOLD_"] == str(64 << 20)
    assert env["MALLOC_MMAP_THRESHOLD_"] == str(32 << 20)
    assert env["OMP_NUM_THREADS"] == env["OPENBLAS_NUM_THREADS"] == "1"
