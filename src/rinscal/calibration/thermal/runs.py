"""Fitting a channel from what each run leaves behind: polynomial models never see the data twice.

A log is read one run at a time (:func:`rinscal.io.streaming.iter_log_source`); of each run, a
channel's fit keeps only

* for ``poly-t`` and ``regression`` (and every method's cubic fallback): the triangular factor
  ``R`` of ``[A | y]`` (:func:`rinscal.calibration.thermal.fitting.tsqr`) in a power basis
  scaled to the run's own range of each input, its sample count and its sum of ``y``;
* the boxes of a fine grid its samples occupy (:func:`rinscal.calibration._domain.occupied_boxes`)
  and its range of each input, for the joint domain;
* a thinned sample of its rows (at most :data:`SAMPLE_ROWS`), for the collinearity check and
  the diagnosis of a singular design;
* for the other methods, its rows (``neural``: every ``k``-th, enough for the network's own
  decimation);
* for ``auto``'s held-out choice (:class:`RowSample`): every ``k``-th usable row of the log
  (``k`` a power of two, doubled whenever more than
  :data:`rinscal.calibration.selection.auto.SCREEN_SAMPLES` rows would be kept), with the
  value of the field's filters (PX4's running median, ArduPilot's moving average, both
  computed on the whole run) at each kept row, and the run's legs and temperature ranges
  (:class:`rinscal.calibration.selection.folds.RunSpan`).

At the end, each run's factor is re-expressed in the basis scaled to the range of all runs:
with ``z_g = a z_l + b`` (``a = s_l / s_g``, ``b = (c_l − c_g) / s_g``), every power
``z_g^j = Σ_i C(j, i) a^i b^(j−i) z_l^i`` is a combination of the run's own powers, so
``A_g = A_l M`` and ``R_l M`` is a factor of the run's design in the global basis
(``(R_l M)ᵀ(R_l M) = A_gᵀ A_g``). Stacking those factors and reducing them again gives the
fit of all runs; each run's residual sum of squares, about its own mean too, follows from its
factor (:func:`rinscal.calibration.thermal.fitting.factor_ss_about_mean`). Numpy only.
"""

from __future__ import annotations

from collections.abc import Sequence
from math import comb
from typing import Any

import numpy as np

from rinscal.calibration._domain import (
    DEFAULT_BINS,
    FINE,
    column_range,
    domain_from_boxes,
    occupied_boxes,
)
from rinscal.calibration.selection.folds import MIN_RUNS, RunSpan, run_span
from rinscal.calibration.thermal.baselines import (
    ARDUPILOT_WINDOW_S,
    ardupilot_window,
)
from rinscal.calibration.thermal.fitting import (
    _split_coef,
    center_scale,
    factor_ss_about_mean,
    power_basis,
    solve_r,
    tsqr,
)
from rinscal.calibration.thermal.guards import check_design

__all__ = ["FACTOR_METHODS", "SAMPLE_ROWS", "RowSample", "RunFits"]

#: Methods fitted from per-run factors alone.
FACTOR_METHODS: tuple[str, ...] = ("poly-t", "regression")
#: Rows of each run kept for the collinearity check and diagnosis messages.
SAMPLE_ROWS = 30_000
#: Degree of the cubic in ``T`` that fixed methods fall back to outside their joint domain.
FALLBACK_DEGREE = 3


def _n_terms(powers: Sequence[int]) -> int:
    return 1 + int(sum(powers))


def _offsets(powers: Sequence[int]) -> list[int]:
    """Column of each input's first power in a basis ``[1, z_0 .. z_0^p0, z_1 ..]``."""
    out, col = [], 1
    for p in powers:
        out.append(col)
        col += int(p)
    return out


def change_basis(
    r: np.ndarray,
    local: Sequence[tuple[float, float]],
    powers: Sequence[int],
    target: Sequence[tuple[float, float]],
    keep: Sequence[int],
) -> np.ndarray:
    """A factor of ``[A | y]`` in another centre and scale of each input, fewer powers kept.

    Parameters
    ----------
    r : ndarray, shape (m, n_terms + 1)
        Factor in the basis with ``local`` centre and half-range of each input, ``powers``
        powers of each input.
    local, target : sequence of (float, float)
        ``(centre, half-range)`` of each input, of ``r``'s basis and of the new one.
    powers : sequence of int
        Powers of each input in ``r``'s basis.
    keep : sequence of int
        Powers of each input in the new basis (each ``≤ powers``; 0 drops the input).

    Returns
    -------
    ndarray, shape (m, 1 + sum(keep) + 1)
        ``r @ M``: columns intercept, the kept powers, ``y`` last.
    """
    old_off, new_off = _offsets(powers), _offsets(keep)
    n_old, n_new = _n_terms(powers), _n_terms(keep)
    m = np.zeros((n_old + 1, n_new + 1))
    m[0, 0] = 1.0
    m[n_old, n_new] = 1.0  # y
    for v, q in enumerate(keep):
        if q > powers[v]:
            raise ValueError(f"input {v}: {q} powers asked, the factor has {powers[v]}")
        (c_l, s_l), (c_g, s_g) = local[v], target[v]
        a, b = s_l / s_g, (c_l - c_g) / s_g
        for j in range(1, q + 1):
            col = new_off[v] + j - 1
            m[0, col] = b**j
            for i in range(1, j + 1):
                m[old_off[v] + i - 1, col] = comb(j, i) * a**i * b ** (j - i)
    return r @ m


class RowSample:
    """Every ``k``-th usable row of a channel's log, read a run at a time (``auto``'s choice).

    The rows kept are those whose index among all usable rows so far is a multiple of ``k``;
    ``k`` starts at 1 and doubles (every other kept row dropped) whenever more than ``most``
    rows would be kept. At the end ``k`` is the smallest power of two that keeps at most
    ``most`` rows, and the rows are those of ``rows[::k]`` of the whole log.

    Parameters
    ----------
    most : int
        Rows kept at most.
    tools : sequence of str
        Field's filters to evaluate at the kept rows, on each whole run: ``"px4"`` (the
        31-sample running median of the output,
        :func:`rinscal.calibration.thermal.baselines.px4_median_filter`) and ``"ardupilot"`` (the
        2 s moving average of ``T`` and the output whose window is centred on the row,
        :func:`rinscal.calibration.thermal.baselines.ardupilot_smoothed`; NaN where none is).
    """

    def __init__(self, most: int, tools: Sequence[str] = ()) -> None:
        self.most = int(most)
        self.tools = tuple(tools)
        self.step = 1
        self.seen = 0
        self.parts: list[dict[str, np.ndarray]] = []
        self.offsets: list[int] = []  # index of each run's first row among all rows
        self.codes: list[int] = []
        self.spans: list[RunSpan] = []

    def add(
        self,
        code: int,
        x: np.ndarray,
        y: np.ndarray,
        t: np.ndarray,
        t_range: tuple[float, float] | None = None,
    ) -> None:
        """Take in one whole run's usable rows (as :meth:`RunFits.add`); ``t_range``: the
        least and greatest ``T`` of the run [°C] where the caller has them."""
        n = x.shape[0]
        step = self.step
        while -(-(self.seen + n) // step) > self.most:  # rows kept: the multiples of step
            step *= 2
        if step != self.step:  # drop the kept rows that are not multiples of the new step
            for off, p in zip(self.offsets, self.parts, strict=True):
                first = (-off) % self.step
                i0 = ((-off - first) % step) // self.step
                for key in p:  # copies: a view would keep every dropped row alive
                    p[key] = p[key][i0 :: step // self.step].copy()
            self.step = step
        first = (-self.seen) % step
        keep = np.arange(first, n, step)
        # strided copies (no gather by index): not views, which would keep the run alive
        part = {k: np.array(v[first::step]) for k, v in (("x", x), ("y", y), ("t", t))}
        if "px4" in self.tools:
            part["px4"] = _median_at(y, keep)
        if "ardupilot" in self.tools:
            part["ap_t"], part["ap_y"] = _moving_average_at(x[:, 0], y, t, keep)
        # legs only matter when the log has fewer than MIN_RUNS runs: its first runs
        cut = len(self.spans) < MIN_RUNS - 1
        self.spans.append(run_span(code, x[:, 0], cut=cut, whole=t_range))
        self.parts.append(part)
        self.offsets.append(self.seen)
        self.codes.append(int(code))
        self.seen += n

    def arrays(
        self,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """The kept rows: inputs, outputs, run codes, positions in their runs, times, and the
        filters' values (``{"px4": yf, "ardupilot": (T_s, y_s)}``)."""
        cat = {k: np.concatenate([p[k] for p in self.parts]) for k in self.parts[0]}
        sizes = [p["y"].size for p in self.parts]
        codes = np.repeat(self.codes, sizes)
        firsts = [(-off) % self.step for off in self.offsets]
        rows = np.concatenate(
            [f + self.step * np.arange(m) for f, m in zip(firsts, sizes, strict=True)]
        )
        tools: dict[str, Any] = {}
        if "px4" in cat:
            tools["px4"] = cat["px4"]
        if "ap_t" in cat:
            tools["ardupilot"] = (cat["ap_t"], cat["ap_y"])
        return cat["x"], cat["y"], codes, rows, cat["t"], tools


def _median_at(y: np.ndarray, keep: np.ndarray) -> np.ndarray:
    """PX4's running median of one run's output (:func:`rinscal.calibration.thermal.baselines.
    px4_median_filter`: 31 samples, zeros beyond the ends) at rows ``keep``, the same numbers
    (:func:`rinscal.calibration.thermal._running_median.medians_at`: their windows alone, a
    third of the time of the whole run's filter even at every row)."""
    # deferred: numba's kernel loads only when the field's fits are candidates (``auto``)
    from rinscal.calibration.thermal._running_median import medians_at

    return medians_at(y, keep)


def _moving_average_at(
    temp: np.ndarray, y: np.ndarray, t: np.ndarray, keep: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """ArduPilot's smoothed ``T`` and output at rows ``keep`` of one run (window centred on
    the row, as :func:`rinscal.calibration.thermal.baselines.ardupilot_smoothed` places it);
    NaN where no complete window is centred there. The same numbers as its
    :func:`rinscal.calibration.thermal.baselines.moving_average`, without the means of every
    other window."""
    # deferred: numba's kernel loads only when the field's fits are candidates (``auto``)
    from rinscal.calibration.thermal._moving_average import window_means_at

    ts, ys = np.full(keep.size, np.nan), np.full(keep.size, np.nan)
    if temp.size < 2:
        return ts, ys
    try:
        w = ardupilot_window(t, ARDUPILOT_WINDOW_S)
    except ValueError:  # no time span: no smoothed sample
        return ts, ys
    if w <= 1:  # the tool does not smooth
        return temp[keep], y[keep]
    i = keep - w // 2
    ok = (i >= 0) & (i <= temp.size - w)
    ts[ok], ys[ok] = window_means_at(temp, y, w, i[ok])
    return ts, ys


class RunFits:
    """What one channel's fit keeps of each run (see the module docstring).

    Parameters
    ----------
    method : str
        The model's method (``poly-t`` and ``regression`` are fitted from factors).
    powers : sequence of int or None
        Powers of each input the run factors hold (``T`` at least :data:`FALLBACK_DEGREE`);
        None: no factors (``auto``, whose fallback comes from its selection).
    keep_rows : bool
        Keep each run's rows (methods fitted from the data).
    row_step_target : int or None
        With ``keep_rows``: keep every ``k``-th row of a run, ``k = ⌊n / row_step_target⌋``
        (None: every row).
    screen : RowSample, optional
        ``auto``: the rows its held-out choice scores, fed with every run.
    """

    def __init__(
        self,
        method: str,
        powers: Sequence[int] | None,
        keep_rows: bool,
        row_step_target: int | None = None,
        screen: RowSample | None = None,
    ) -> None:
        self.method = method
        self.powers = [] if powers is None else [int(p) for p in powers]
        self.keep_rows = keep_rows
        self.row_step_target = row_step_target
        self.factors: list[np.ndarray] = []
        self.local: list[list[tuple[float, float]]] = []
        self.codes: list[int] = []
        self.counts: list[int] = []
        self.sum_y = 0.0
        self.lo: np.ndarray | None = None
        self.hi: np.ndarray | None = None
        self.boxes: list[tuple[np.ndarray, np.ndarray]] = []
        self.sample: list[np.ndarray] = []
        self.rows: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]] = []
        self.screen = screen

    @property
    def n(self) -> int:
        """Rows seen."""
        return int(sum(self.counts))

    def add(self, code: int, x: np.ndarray, y: np.ndarray, t: np.ndarray) -> None:
        """Take in one run's usable rows.

        Parameters
        ----------
        code : int
            Index of the run.
        x : ndarray, shape (n, k)
            ``T`` [°C], ``Ṫ`` [°C/min] (, ``ΔT`` [°C]), finite.
        y : ndarray, shape (n,) [log units]
        t : ndarray, shape (n,) [s]
            Time since the run's power-on.
        """
        n = x.shape[0]
        if n == 0:
            return
        lo, hi = column_range(x)
        self.lo = lo if self.lo is None else np.minimum(self.lo, lo)
        self.hi = hi if self.hi is None else np.maximum(self.hi, hi)
        self.boxes.append(occupied_boxes(x, DEFAULT_BINS * FINE, (lo, hi)))
        self.sample.append(x[:: max(1, n // SAMPLE_ROWS)].copy())  # not a view of the run
        self.codes.append(int(code))
        self.counts.append(n)
        self.sum_y += float(np.sum(y))
        if self.powers:
            k = len(self.powers)
            # from the range found above: the same centre and scale, no second pass
            cs = [center_scale(np.array([lo[v], hi[v]])) for v in range(k)]
            n_terms = _n_terms(self.powers)
            basis = power_basis([c for c, _ in cs], [s for _, s in cs], self.powers)
            r = tsqr(basis, x[:, :k], y, n_terms)
            pad = np.zeros((n_terms + 1, n_terms + 1))
            pad[: r.shape[0]] = r
            self.factors.append(pad)
            self.local.append(cs)
        if self.keep_rows:
            step = 1
            if self.row_step_target is not None:
                step = max(1, n // int(self.row_step_target))
            sel = slice(None, None, step)
            keep = [np.array(a[sel]) if step > 1 else a for a in (x, y, t)]  # no view of the run
            self.rows.append((keep[0], keep[1], np.full(len(keep[1]), code), keep[2]))
        if self.screen is not None:
            self.screen.add(code, x, y, t, (float(lo[0]), float(hi[0])))

    def data(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The kept rows of every run (without: the screen's): inputs, outputs, run codes,
        times."""
        if not self.rows and self.screen is not None:
            x, y, codes, _, t, _ = self.screen.arrays()
            return x, y, codes, t
        parts = list(zip(*self.rows, strict=True))
        return tuple(np.concatenate(p) for p in parts)  # type: ignore[return-value]

    def range(self, k: int) -> np.ndarray:
        """Training range of the first ``k`` inputs, shape (k, 2)."""
        assert self.lo is not None and self.hi is not None
        return np.column_stack([self.lo[:k], self.hi[:k]])

    def domain(self, k: int) -> dict[str, Any]:
        """Joint domain of the first ``k`` inputs over every run."""
        assert self.lo is not None and self.hi is not None
        return domain_from_boxes(self.boxes, self.lo[:k], self.hi[:k])

    def sample_x(self) -> np.ndarray:
        """The thinned rows of every run (collinearity, diagnosis)."""
        return np.concatenate(self.sample)

    def scaling(self) -> list[tuple[float, float]]:
        """Centre and half-range of each input over every run (the global basis)."""
        assert self.lo is not None and self.hi is not None
        return [center_scale(np.array(v)) for v in zip(self.lo, self.hi, strict=True)]

    def global_factors(
        self, keep: Sequence[int], target: Sequence[tuple[float, float]]
    ) -> list[np.ndarray]:
        """Each run's factor in the ``target`` scaling with ``keep`` powers of each input."""
        return [
            change_basis(r, cs, self.powers, target, keep)
            for r, cs in zip(self.factors, self.local, strict=True)
        ]

    def _solve(
        self, keep: Sequence[int], target: Sequence[tuple[float, float]], what: str
    ) -> tuple[np.ndarray, list[np.ndarray]]:
        runs = self.global_factors(keep, target)
        n_terms = _n_terms(keep)
        r = np.linalg.qr(np.vstack(runs), mode="r")
        if self.n > n_terms:  # fewer rows are refused by the caller
            check_design(r[:, :n_terms], self.sample_x(), keep, what)
        return solve_r(r, n_terms)[0], runs

    def poly_t(self, degree: int, t_ref: float | None = None) -> dict[str, Any]:
        """``poly-t`` parameters (as :func:`rinscal.calibration.thermal.fitting.fit_poly_t`)."""
        deg = int(degree)
        if deg < 0 or deg > min(7, self.powers[0]):
            raise ValueError(f"degree must be 0..{min(7, self.powers[0])}, got {degree!r}")
        assert self.lo is not None and self.hi is not None
        lo, hi = float(self.lo[0]), float(self.hi[0])
        ref = 0.5 * (lo + hi) if t_ref is None else float(t_ref)
        s = max(abs(hi - ref), abs(lo - ref))
        s = s if s > 0 else 1.0
        keep = [deg] + [0] * (len(self.powers) - 1)
        target = [(ref, s)] + [(0.0, 1.0)] * (len(self.powers) - 1)
        beta, _ = self._solve(keep, target, f"degree-{deg} poly-t")
        coef = beta / s ** np.arange(deg + 1)
        return {"method": "poly-t", "t_ref": float(ref), "coef": coef.tolist()}

    def regression(self, orders: Sequence[int]) -> dict[str, Any]:
        """``regression`` parameters (as
        :func:`rinscal.calibration.thermal.fitting.fit_regression`)."""
        orders = [int(o) for o in orders]
        if any(o < 0 or o > 8 for o in orders):
            raise ValueError(f"orders must be 0..8, got {orders}")
        assert self.lo is not None and self.hi is not None
        k = len(self.powers)
        orders = orders[:k]
        cs = self.scaling()[: len(orders)]
        keep = orders + [0] * (k - len(orders))
        target = cs + [(0.0, 1.0)] * (k - len(orders))
        beta, _ = self._solve(keep, target, f"regression {tuple(orders)}")
        intercept, coef = _split_coef(beta, orders)
        return {
            "method": "regression",
            "orders": orders,
            "center": [c for c, _ in cs],
            "scale": [s for _, s in cs],
            "intercept": intercept,
            "coef": coef,
        }

    def residual_ss(self, params: dict[str, Any]) -> tuple[float, float, int]:
        """Residual sum of squares of a ``poly-t`` or ``regression`` fit over every run, the
        same about each run's mean, and the runs with rows (from the factors alone)."""
        k = len(self.powers)
        if params["method"] == "poly-t":
            assert self.lo is not None and self.hi is not None
            coef = np.asarray(params["coef"], dtype=np.float64)
            deg, ref = coef.size - 1, float(params["t_ref"])
            s = max(abs(float(self.hi[0]) - ref), abs(float(self.lo[0]) - ref)) or 1.0
            keep = [deg] + [0] * (k - 1)
            target = [(ref, s)] + [(0.0, 1.0)] * (k - 1)
            beta = coef * s ** np.arange(deg + 1)  # in the scaled basis: no cancellation
        else:
            orders = list(params["orders"])
            keep = orders + [0] * (k - len(orders))
            target = list(zip(params["center"], params["scale"], strict=True))
            target += [(0.0, 1.0)] * (k - len(orders))
            beta = np.concatenate([[params["intercept"]], *map(np.asarray, params["coef"])])
        coef_y = np.append(beta, -1.0)
        total = about = 0.0
        for r, cnt in zip(self.global_factors(keep, target), self.counts, strict=True):
            total += float(np.sum((r @ coef_y) ** 2))
            about += factor_ss_about_mean(r, coef_y, cnt)
        return total, about, len(self.counts)
