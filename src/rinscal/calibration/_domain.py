"""Where the training data lie in (T, Ṫ, ΔT) jointly: an occupancy grid.

A range check on each input alone misses combinations a model never saw: on the real MEMS
thermal cycle, trained on a cooling leg from 52 °C and a heating leg to 74 °C, half of the
last leg is hot *and* cooling, inside every input's range and outside the data. The joint
domain is stored in the model file as an occupancy grid over the inputs a channel's model
uses:

* each input's training range ``[lo, hi]`` is cut into ``bins`` equal cells (default 24, so a
  cell is 1/24 of the range: e.g. 3.8 °C of a 91 °C cycle);
* a cell is occupied if a training sample falls in it, or within an eighth of a cell-width
  of it: the data are summarised, a run at a time, by the boxes of a grid eight times finer
  over each run's own range that hold a sample (:func:`occupied_boxes`), and a cell is
  occupied when such a box touches it (:func:`domain_from_boxes`), so a log read run by run
  and the same log read whole give the same grid; the occupied set is dilated by one cell in
  every direction (a sample next to the data is in), and stored run-length encoded as
  ``[[first_flat_index, length], ...]`` (C order);
* a sample is *inside* when every input lies within ``[lo − w, hi + w]`` (``w`` one cell)
  and its cell is in the dilated set.

Dictionary form (in a channel's ``domain`` entry)::

    {"lo": [..k], "hi": [..k], "bins": [..k], "runs": [[start, length], ...]}
"""

from __future__ import annotations

import sys
from collections.abc import Mapping, Sequence
from types import ModuleType
from typing import Any

import numpy as np

__all__ = [
    "DEFAULT_BINS",
    "FINE",
    "column_range",
    "domain_from_boxes",
    "fit_domain",
    "inside_domain",
    "occupied_boxes",
    "validate_domain",
]

#: Cells per input.
DEFAULT_BINS = 24
_KEYS = ("lo", "hi", "bins", "runs")


def column_range(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Least and greatest value of each column of ``x`` (n, k), one column at a time.

    (``x.min(axis=0)`` on a row-major (n, 3) array runs several times slower.)
    """
    lo = np.array([x[:, v].min() for v in range(x.shape[1])], dtype=np.float64)
    hi = np.array([x[:, v].max() for v in range(x.shape[1])], dtype=np.float64)
    return lo, hi


def _flat_cells(
    cols: np.ndarray | Sequence[np.ndarray], lo: np.ndarray, hi: np.ndarray, bins: np.ndarray
) -> np.ndarray:
    """Row-major flat cell number of each sample, shape (n,).

    ``cols`` holds one input per row, shape (k, n), or is a sequence of the k inputs (each
    contiguous: the columns of a column-major block, no copy). Each input's cell is
    ``floor((x − lo) / width)`` clipped into ``0 .. bins − 1`` (a value just outside the
    range falls in the edge cell; the box test catches the rest). Where the process has
    loaded numba already (a model with a temperature rate, a navigation), one pass of
    :func:`rinscal._kernels.flat_cells`, the same numbers; else numpy, a few passes an input
    (a model of T alone does not load numba: its start costs more than this saves).
    """
    kernels = _loaded_kernels()
    if kernels is None:
        return _flat_cells_numpy(cols, lo, hi, bins)
    flat = np.empty(len(cols[0]), dtype=np.int64)
    kernels.flat_cells(*_three(cols, lo.size), lo.size, lo, hi, np.asarray(bins), flat)
    return flat


def _loaded_kernels() -> ModuleType | None:
    """:mod:`rinscal._kernels` where the process has numba loaded already (a model with a
    temperature rate, a navigation), else None: a model of T alone does not load numba for
    the domain (its start, about 0.5 s, costs more than one pass saves)."""
    if "numba" not in sys.modules:
        return None
    # deferred: the kernels load numba, and only a process that has it already takes them
    from rinscal import _kernels

    return _kernels


def _three(cols: np.ndarray | Sequence[np.ndarray], k: int) -> list[np.ndarray]:
    """The kernels' three input arguments from the ``k`` inputs (the last repeated: unread)."""
    return [np.asarray(cols[min(v, k - 1)], dtype=np.float64) for v in range(3)]


def _flat_cells_numpy(
    cols: np.ndarray | Sequence[np.ndarray], lo: np.ndarray, hi: np.ndarray, bins: np.ndarray
) -> np.ndarray:
    """:func:`_flat_cells` in numpy passes (without numba)."""
    n = len(cols[0])
    flat = np.zeros(n, dtype=np.int64)
    z = np.empty(n)  # floor((x − lo) / width), one buffer for every input
    idx = np.empty(n, dtype=np.int64)
    for v in range(lo.size):
        width = (hi[v] - lo[v]) / bins[v] if hi[v] > lo[v] else 1.0
        np.subtract(cols[v], lo[v], out=z)
        z /= width
        np.floor(z, out=z)
        idx[:] = z  # as astype(int64): truncation of whole numbers
        np.clip(idx, 0, bins[v] - 1, out=idx)
        flat *= bins[v]
        flat += idx
    return flat


#: Fine cells per domain cell of the boxes a piece of data is summarised by.
FINE = 8


def occupied_boxes(
    x: np.ndarray, cells: int, bounds: tuple[np.ndarray, np.ndarray] | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """The boxes of a fine grid over ``x``'s own range that hold a sample.

    The summary of one piece of training data (a run) from which :func:`domain_from_boxes`
    builds the joint domain of all pieces without seeing their samples again.

    Parameters
    ----------
    x : ndarray, shape (n, k), 1 ≤ k ≤ 3
        Inputs, finite.
    cells : int
        Fine cells per input over ``[min, max]`` of that input in ``x``.
    bounds : (ndarray, ndarray), optional
        :func:`column_range` of ``x``, when the caller has it already.

    Returns
    -------
    lo, hi : ndarray, shape (b, k) [input units]
        Corners of the occupied boxes (equal where an input is constant).
    """
    x = np.asarray(x, dtype=np.float64)
    k = x.shape[1]
    lo, hi = column_range(x) if bounds is None else bounds
    nb = np.full(k, int(cells), dtype=np.int64)
    nb[hi <= lo] = 1
    size = int(np.prod(nb))
    blocks = [
        _flat_cells([x[s : s + (1 << 16), v] for v in range(k)], lo, hi, nb)
        for s in range(0, x.shape[0], 1 << 16)
    ]
    if x.shape[0] < size // 16:  # few samples: sort their cells, no dense grid
        flat = np.unique(np.concatenate(blocks))
    else:
        occ = np.zeros(size, dtype=bool)
        for b in blocks:
            occ[b] = True
        flat = np.flatnonzero(occ)
    idx = np.column_stack(np.unravel_index(flat, tuple(nb)))
    width = np.where(hi > lo, (hi - lo) / nb, 0.0)
    return lo + idx * width, lo + (idx + 1) * width


def domain_from_boxes(
    boxes: list[tuple[np.ndarray, np.ndarray]],
    lo: np.ndarray,
    hi: np.ndarray,
    bins: int = DEFAULT_BINS,
) -> dict[str, Any]:
    """Occupancy grid over ``[lo, hi]`` of the cells that any box touches, dilated by one.

    Parameters
    ----------
    boxes : list of (ndarray, ndarray), each shape (b, k)
        Corners from :func:`occupied_boxes` (first ``k`` inputs used).
    lo, hi : ndarray, shape (k,) [input units]
        Training range of each input over all pieces.
    bins : int
        Cells per input.

    Returns
    -------
    dict
        ``lo``, ``hi``, ``bins``, ``runs`` (see the module docstring).
    """
    lo = np.asarray(lo, dtype=np.float64)
    hi = np.asarray(hi, dtype=np.float64)
    k = lo.size
    nb = np.full(k, int(bins), dtype=np.int64)
    nb[hi <= lo] = 1  # a constant input: one cell
    occ = np.zeros(tuple(nb), dtype=bool)
    width = np.where(hi > lo, (hi - lo) / nb, 1.0)
    for b_lo, b_hi in boxes:
        first = np.clip(np.floor((b_lo[:, :k] - lo) / width).astype(np.int64), 0, nb - 1)
        last = np.clip(np.floor((b_hi[:, :k] - lo) / width).astype(np.int64), 0, nb - 1)
        # a box is far smaller than a cell: it touches at most two cells per input
        for shift in np.ndindex(*([2] * k)):
            cell = first + np.asarray(shift)
            keep = np.all(cell <= last, axis=1)
            occ[tuple(cell[keep].T)] = True
    for axis in range(k):  # dilate by one cell: a separable 3×3(×3) box
        grown = occ.copy()
        lead = [slice(None)] * k
        trail = [slice(None)] * k
        lead[axis], trail[axis] = slice(1, None), slice(None, -1)
        grown[tuple(lead)] |= occ[tuple(trail)]
        grown[tuple(trail)] |= occ[tuple(lead)]
        occ = grown
    flat = np.flatnonzero(occ.ravel())
    breaks = np.flatnonzero(np.diff(flat) != 1) + 1
    starts = np.concatenate([[0], breaks])
    ends = np.concatenate([breaks, [flat.size]])
    runs = np.column_stack([flat[starts], ends - starts]).astype(np.int64).tolist()
    return {"lo": lo.tolist(), "hi": hi.tolist(), "bins": nb.tolist(), "runs": runs}


def fit_domain(x: np.ndarray, bins: int = DEFAULT_BINS) -> dict[str, Any]:
    """Occupancy grid of training samples.

    The cells touched by the occupied boxes of a grid :data:`FINE` times finer
    (:func:`occupied_boxes`), dilated by one cell: the same construction as for data seen a
    run at a time (a box straddling a cell edge, a tenth of a cell at most, marks both).

    Parameters
    ----------
    x : ndarray, shape (n, k), 1 ≤ k ≤ 3
        Training inputs ``T`` [°C], ``Ṫ`` [°C/min], ``ΔT`` [°C] (the first k), finite.
    bins : int
        Cells per input.

    Returns
    -------
    dict
        ``lo``, ``hi`` [input units], ``bins``, ``runs`` (see the module docstring).
    """
    x = np.asarray(x, dtype=np.float64)
    if x.ndim != 2 or x.shape[0] == 0 or not 1 <= x.shape[1] <= 3:
        raise ValueError(f"need a non-empty (n, 1..3) input matrix, got shape {x.shape}")
    lo, hi = column_range(x)
    return domain_from_boxes([occupied_boxes(x, bins * FINE)], lo, hi, bins)


def _grid(domain: Mapping[str, Any]) -> np.ndarray:
    nb = [int(b) for b in domain["bins"]]
    occ = np.zeros(int(np.prod(nb)), dtype=bool)
    for start, length in domain["runs"]:
        occ[start : start + length] = True
    return occ.reshape(nb)


def inside_domain(domain: Mapping[str, Any], x: np.ndarray) -> np.ndarray:
    """Whether each sample lies in the training data's joint domain.

    Parameters
    ----------
    domain : mapping
        From :func:`fit_domain`.
    x : ndarray, shape (n, ≥k)
        Inputs in the same order (columns beyond ``k`` ignored).

    Returns
    -------
    ndarray of bool, shape (n,)
    """
    lo = np.asarray(domain["lo"], dtype=np.float64)
    hi = np.asarray(domain["hi"], dtype=np.float64)
    nb = np.asarray(domain["bins"], dtype=np.int64)
    k = lo.size
    xs = np.asarray(x, dtype=np.float64)[:, :k]
    grid = _grid(domain).ravel()
    out = np.empty(xs.shape[0], dtype=bool)
    kernels = _loaded_kernels()  # one pass of a kernel where numba is loaded (_flat_cells)
    if kernels is None:
        return _inside_numpy(xs, lo, hi, nb, grid, out)
    kernels.inside_cells(*_three([xs[:, v] for v in range(k)], k), k, lo, hi, nb, grid, out)
    return out


def _inside_numpy(
    xs: np.ndarray,
    lo: np.ndarray,
    hi: np.ndarray,
    nb: np.ndarray,
    grid: np.ndarray,
    out: np.ndarray,
) -> np.ndarray:
    """:func:`inside_domain` in numpy passes (without numba), into ``out``."""
    k = lo.size
    width = np.where(hi > lo, (hi - lo) / nb, 0.0)
    for s in range(0, xs.shape[0], 1 << 16):  # a block of rows at a time, one input per row
        block = xs[s : s + (1 << 16)]
        if block.strides[0] == block.itemsize:  # column-major: each input contiguous as is
            cols: np.ndarray | list[np.ndarray] = [block[:, v] for v in range(k)]
        else:
            cols = np.ascontiguousarray(block.T)  # transposed once, for cells and box alike
        ok = grid[_flat_cells_numpy(cols, lo, hi, nb)]
        for v in range(k):
            ok &= (cols[v] >= lo[v] - width[v]) & (cols[v] <= hi[v] + width[v])
        out[s : s + block.shape[0]] = ok
    return out


def validate_domain(d: Any, k: int) -> None:
    """Check a stored domain (keys, shapes, finite numbers, runs within the grid).

    Parameters
    ----------
    d : object
        Parsed JSON.
    k : int
        Number of inputs the channel's model uses.

    Raises
    ------
    ValueError
        Naming the problem.
    """
    if not isinstance(d, Mapping) or set(d) != set(_KEYS):
        raise ValueError(f"domain must be an object with keys {list(_KEYS)}")
    try:
        lo = np.asarray(d["lo"], dtype=np.float64)
        hi = np.asarray(d["hi"], dtype=np.float64)
        nb = np.asarray(d["bins"])
    except (TypeError, ValueError):
        raise ValueError("domain lo/hi/bins must be lists of numbers") from None
    if lo.shape != (k,) or hi.shape != (k,) or nb.shape != (k,):
        raise ValueError(f"domain lo, hi and bins must hold {k} entries")
    if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)) and np.all(lo <= hi)):
        raise ValueError("domain lo/hi must be finite with lo <= hi")
    if nb.dtype.kind not in "iu" or np.any(nb < 1) or np.any(nb > 256):
        raise ValueError("domain bins must be integers in 1..256")
    size = int(np.prod(nb))
    runs = d["runs"]
    if not isinstance(runs, list):
        raise ValueError("domain runs must be a list of [start, length] pairs")
    for pair in runs:
        if (
            not isinstance(pair, list)
            or len(pair) != 2
            or not all(isinstance(v, int) and not isinstance(v, bool) for v in pair)
            or pair[0] < 0
            or pair[1] < 1
            or pair[0] + pair[1] > size
        ):
            raise ValueError(f"domain runs: bad entry {pair!r} for a grid of {size} cells")
