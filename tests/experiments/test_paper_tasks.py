"""The reproduction's calibration tasks (issue 39): run here one after the other, or on a
Dask cluster side by side, the same results; a task gets what it needs (data, an earlier
task's result) on the workers; the progress line of each, once."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from distributed import Client, LocalCluster

from rinscal.experiments.paper.tasks import Needs, Task, quiet, run_tasks


def _lstsq(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.linalg.lstsq(a, b, rcond=None)[0]


def _residual(a: np.ndarray, b: np.ndarray, x: np.ndarray, scale: float = 1.0) -> float:
    warnings.warn("a fit's RuntimeWarning", RuntimeWarning, stacklevel=1)  # silenced
    return scale * float(np.linalg.norm(a @ x - b))


def _tasks() -> list[Task]:
    return [
        Task("x", "solving", _lstsq, (Needs("a"), Needs("b"))),
        Task("r", "residual", _residual, (Needs("a"), Needs("b"), Needs("x")), {"scale": 2.0}),
        Task("n", "norm", np.linalg.norm, (Needs("b"),)),
    ]


@pytest.fixture(scope="module")
def data() -> dict[str, np.ndarray]:
    rng = np.random.default_rng(4)
    return {"a": rng.standard_normal((400, 5)), "b": rng.standard_normal(400)}


def test_tasks_here_run_in_order_each_said_before_it_runs(data) -> None:  # type: ignore[no-untyped-def]
    said: list[str] = []
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)  # quiet() keeps the fits' own
        get = run_tasks(_tasks(), data, None, said.append)
    assert said == ["solving", "residual", "norm"]
    x = np.linalg.lstsq(data["a"], data["b"], rcond=None)[0]
    assert np.array_equal(get("x"), x)
    assert get("r") == 2.0 * float(np.linalg.norm(data["a"] @ x - data["b"]))
    assert get("a") is data["a"]


def test_tasks_on_a_cluster_give_the_same_results_bit_for_bit(data) -> None:  # type: ignore[no-untyped-def]
    here = run_tasks(_tasks(), data, None, lambda _w: None)
    said: list[str] = []
    with (
        LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                     dashboard_address=":0") as cluster,
        Client(cluster) as client,
    ):  # fmt: skip
        get = run_tasks(_tasks(), data, client, said.append)
        # fetched in the order asked for, each said once, when it is in
        assert get("r") == here("r")
        assert np.array_equal(get("x"), here("x")) and get("n") == here("n")
        get("r")
    assert said == ["residual", "solving", "norm"]


def test_quiet_runs_with_one_blas_thread_and_no_runtime_warnings() -> None:
    from threadpoolctl import threadpool_info

    def blas_threads() -> list[int]:
        warnings.warn("noise", RuntimeWarning, stacklevel=1)
        return [p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"]

    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        threads = quiet(blas_threads)
    assert threads and set(threads) == {1}
