"""The reproduction's calibration tasks, run side by side on a Dask cluster or one after the
other in this process (:func:`run_tasks`): the same results either way, each task seeded and
on one BLAS thread wherever it runs.

A task (:class:`Task`) names the results it needs (:class:`Needs`: an earlier task's, or
data scattered once); Dask holds it back on the workers until they are in, so tasks are
submitted at once in the order they are to be handed out.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from threadpoolctl import threadpool_limits

__all__ = ["Needs", "Task", "quiet", "run_tasks"]


@dataclass(frozen=True)
class Task:
    """One task of the reproduction: ``key`` (what its result is found by), ``words``
    (the progress line), ``fn(*args, **kw)``; an argument that is a :class:`Needs` is the
    result of that key (an earlier task's, or the stage's data: ``soak``, ``soak_truth``)."""

    key: str
    words: str
    fn: Callable[..., Any]
    args: tuple[Any, ...]
    kw: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class Needs:
    """An argument of a :class:`Task`: the result of another key."""

    key: str


def run_tasks(
    tasks: Sequence[Task], data: Mapping[str, Any], client: Any, note: Callable[[str], None]
) -> Callable[[str], Any]:
    """Run ``tasks``: here one after the other (``note`` before each), or submitted to the
    Dask ``client`` in their order (the data scattered once; a task waits on the workers for
    those it needs). Returns ``get(key)``, the result of a key (waiting for it)."""
    results = dict(data)
    if client is not None:  # on every worker: a task runs wherever a core is free
        results = {k: client.scatter(v, broadcast=True, hash=False) for k, v in data.items()}
    for i, t in enumerate(tasks):
        args = tuple(results[a.key] if isinstance(a, Needs) else a for a in t.args)
        if client is None:
            note(t.words)
            results[t.key] = quiet(t.fn, *args, **t.kw)
        else:  # handed out in the order given (Dask runs a higher priority first)
            results[t.key] = client.submit(
                quiet, t.fn, *args, **t.kw, key=f"cal-{t.key}", pure=False,
                priority=len(tasks) - i,
            )  # fmt: skip
    words = {t.key: t.words for t in tasks}
    fetched: dict[str, Any] = {}

    def get(key: str) -> Any:
        if client is None:
            return results[key]
        if key not in fetched:
            fetched[key] = results[key].result()
            note(words[key])
        return fetched[key]

    return get


def quiet(fn: Callable[..., Any], *args: Any, **kw: Any) -> Any:
    """``fn(*args, **kw)`` with one BLAS thread and without the fits' RuntimeWarnings (on a
    worker as here: the result must not depend on where it ran)."""
    with warnings.catch_warnings(), threadpool_limits(limits=1):
        warnings.simplefilter("ignore", RuntimeWarning)
        return fn(*args, **kw)
