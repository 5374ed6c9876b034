r"""What a set of runs determines of a thermal model: per channel and term, with its sd.

A thermal model ``b(T, Ṫ, ΔT)`` is fitted on pooled runs with one constant, so each run's
turn-on offset is noise to it; what the runs can determine of each term depends on how the
inputs vary *between* and *within* runs. Parked cold starts (:mod:`rinscal.nav.fieldcal`)
make it a real question: every start warms the unit the same way, so the rate ``Ṫ`` and the
gradient ``ΔT`` follow much the same curve in every run, and only the ambient moves ``T``
from one start to the next. This module measures it on the data, per channel, for the
terms of a quadratic regression in centred inputs::

    y = c + a₁ (T − T̄) + a₂ ((T − T̄)² − mean) + b₁ (Ṫ − mean) + d₁ (ΔT − mean) + e

Two standard deviations of each coefficient are computed; the jackknife's is used when
there are three runs or more, least squares' otherwise:

* ``sd_model``: least squares with the residual variance inflated for correlated residuals
  (each run's effective sample size ``n (1 − ρ)/(1 + ρ)``, ``ρ`` its lag-one
  autocorrelation);
* ``sd_runs``: the jackknife over runs (each run left out in turn,
  ``√((k − 1)/k · Σ (θ₍ᵢ₎ − θ̄)²)``), which sees what the runs disagree on — turn-on offsets
  loading on the level of ``T`` across ambients, a warm-up shape that differs from run to
  run — and which the least-squares figure does not; and a smoothed bias series is so
  autocorrelated (lag-one correlation near 1 at 10 s rows) that its effective sample size,
  and with it the least-squares sd, is ill determined.

A term's **effect sd** is that sd times the term's reach: for ``T`` the half-width of the
temperature range the model must cover (``span_c``, default the data's own), for ``T²`` its
square, for ``Ṫ`` and ``ΔT`` twice their sd in the data. A term is **determined** when its
effect sd is at most :data:`EFFECT_FRACTION` of the channel's thermal swing (half the
5-95 % range of the output over the runs) and its variance inflation factor is at most
:data:`MAX_VIF` (beyond it the term cannot be told from the others). A term that is not
determined is left out of the fit (:mod:`rinscal.nav.fieldcal`): the ``ΔT`` terms by
fitting without the gradient, the ``Ṫ`` terms by fitting polynomials in ``T`` alone. The
level and the curvature in ``T`` are reported only: a model needs ``T``, and outside the
temperatures seen it is held at its edge (policy ``clamp``); the held-out choice of ``fit``
decides the degree.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from rinscal.calibration.regression import least_squares
from rinscal.calibration.thermal.features import Features

__all__ = [
    "EFFECT_FRACTION",
    "MAX_VIF",
    "TERMS",
    "TermObservability",
    "observability",
    "observability_table",
    "undetermined",
]

#: The terms examined, in column order (``T2`` the curvature in ``T``).
TERMS: tuple[str, ...] = ("T", "T2", "Tdot", "dT")
#: Units of each term's coefficient per log unit of the channel.
TERM_UNITS: dict[str, str] = {"T": "/degC", "T2": "/degC^2", "Tdot": "/(degC/min)", "dT": "/degC"}
#: Largest effect sd of a determined term, as a fraction of the channel's thermal swing.
EFFECT_FRACTION = 0.1
#: Largest variance inflation factor of a determined term.
MAX_VIF = 30.0


@dataclass(frozen=True)
class TermObservability:
    """What the runs determine of one term of one channel's model.

    Attributes
    ----------
    channel, term : str
        The channel and the term (:data:`TERMS`).
    coef : float [log units per the term's unit]
        The coefficient fitted on all runs (centred inputs).
    sd_model, sd_runs : float [same unit]
        Its standard deviation from least squares (correlated residuals allowed for) and
        from the jackknife over runs (NaN with fewer than three runs).
    reach : float [the term's unit]
        How far the term's input reaches (see the module docstring).
    effect_sd : float [log units]
        ``sd_runs · reach`` (``sd_model · reach`` with fewer than three runs).
    swing : float [log units]
        The channel's thermal swing: half the 5-95 % range of the output.
    vif : float
        Variance inflation factor of the term among the others.
    determined : bool
        ``effect_sd ≤ EFFECT_FRACTION · swing`` and ``vif ≤ MAX_VIF``.
    why : str
        Why not, in words ("" when determined).
    """

    channel: str
    term: str
    coef: float
    sd_model: float
    sd_runs: float
    reach: float
    effect_sd: float
    swing: float
    vif: float
    determined: bool
    why: str


def _design(temp: np.ndarray, rate: np.ndarray, grad: np.ndarray | None) -> np.ndarray:
    """Columns: 1, T − T̄, (T − T̄)² − mean, Ṫ − mean[, ΔT − mean]."""
    tc = temp - temp.mean()
    cols = [np.ones_like(temp), tc, tc**2 - np.mean(tc**2), rate - rate.mean()]
    if grad is not None:
        cols.append(grad - grad.mean())
    return np.column_stack(cols)


def _effective_n(resid: np.ndarray, codes: np.ndarray) -> float:
    """Sum over runs of ``n (1 − ρ)/(1 + ρ)``, ρ ≥ 0 the lag-one autocorrelation."""
    total = 0.0
    for r in np.unique(codes):
        e = resid[codes == r]
        if e.size < 3 or not np.any(e != e[0]):
            total += e.size
            continue
        rho = float(np.corrcoef(e[:-1], e[1:])[0, 1])
        rho = min(max(rho if math.isfinite(rho) else 0.0, 0.0), 0.999)
        total += e.size * (1.0 - rho) / (1.0 + rho)
    return max(total, 1.0)


def _vif(x: np.ndarray) -> np.ndarray:
    """Variance inflation factor of each column of ``x`` (no constant) among the others."""
    out = np.empty(x.shape[1])
    for k in range(x.shape[1]):
        others = np.column_stack([np.ones(x.shape[0]), np.delete(x, k, axis=1)])
        beta = least_squares(others, x[:, k])
        resid = x[:, k] - others @ beta
        v = float(np.var(x[:, k]))
        out[k] = math.inf if v == 0 else v / max(float(np.var(resid)), 1e-300)
    return out


def observability(
    features: Features,
    *,
    span_c: tuple[float, float] | None = None,
    channels: Sequence[str] | None = None,
) -> list[TermObservability]:
    """Per channel and term, what the runs of ``features`` determine (module docstring).

    Parameters
    ----------
    features : Features
        The model inputs of the runs (:func:`rinscal.calibration.thermal.features.build_features`);
        the gradient terms are examined when it has ``ΔT``.
    span_c : (float, float), optional [°C]
        The inner temperatures the model must cover; default the data's own range.
    channels : sequence of str, optional
        Default every channel of ``features``.

    Returns
    -------
    list of TermObservability
        One per channel and term, in :data:`TERMS` order.
    """
    out: list[TermObservability] = []
    for c in channels or features.channels:
        x = features.matrix(c)
        ok = features.usable(c, x)
        y = features.output[ok, features.channels.index(c)]
        temp, rate = x[ok, 0], x[ok, 1]
        grad = x[ok, 2] if x.shape[1] > 2 else None
        codes = features.run_codes[ok]
        X = _design(temp, rate, grad)
        terms = TERMS[: X.shape[1] - 1]
        beta = least_squares(X, y)
        resid = y - X @ beta
        n_eff = _effective_n(resid, codes)
        s2 = float(resid @ resid) / max(n_eff - X.shape[1], 1.0)
        cov = s2 * np.linalg.pinv(X.T @ X) * (y.size / n_eff)
        sd_model = np.sqrt(np.clip(np.diag(cov)[1:], 0.0, None))
        runs = np.unique(codes)
        sd_runs = np.full(len(terms), math.nan)
        if runs.size >= 3:
            est = []
            for r in runs:
                keep = codes != r
                b = least_squares(X[keep], y[keep])
                est.append(b[1:])
            e = np.asarray(est)
            sd_runs = np.sqrt((runs.size - 1) / runs.size * np.sum((e - e.mean(0)) ** 2, axis=0))
        lo, hi = (float(temp.min()), float(temp.max())) if span_c is None else span_c
        half = 0.5 * (hi - lo)
        reach = {"T": half, "T2": half**2, "Tdot": 2.0 * float(np.std(rate))}
        if grad is not None:
            reach["dT"] = 2.0 * float(np.std(grad))
        q5, q95 = np.quantile(y, [0.05, 0.95])
        swing = 0.5 * float(q95 - q5)
        vif = _vif(X[:, 1:])
        for k, term in enumerate(terms):
            # the jackknife over runs when there are three or more: the series are smooth and
            # strongly autocorrelated, so least squares' own sd is a poor guide to them
            sd = float(sd_runs[k] if np.isfinite(sd_runs[k]) else sd_model[k])
            effect = sd * reach[term]
            why = []
            if vif[k] > MAX_VIF:
                why.append(f"collinear with the other inputs (VIF {vif[k]:.0f} > {MAX_VIF:g})")
            if not effect <= EFFECT_FRACTION * swing:
                why.append(
                    f"its effect sd {effect:.3g} exceeds {EFFECT_FRACTION:g} of the thermal "
                    f"swing {swing:.3g}"
                )
            out.append(
                TermObservability(
                    channel=c,
                    term=term,
                    coef=float(beta[k + 1]),
                    sd_model=float(sd_model[k]),
                    sd_runs=float(sd_runs[k]),
                    reach=float(reach[term]),
                    effect_sd=effect,
                    swing=swing,
                    vif=float(vif[k]),
                    determined=not why,
                    why="; ".join(why),
                )
            )
    return out


def observability_table(report: Sequence[TermObservability]) -> pd.DataFrame:
    """The report as a table, one row per channel and term."""
    cols = list(TermObservability.__dataclass_fields__)
    return pd.DataFrame([[getattr(r, k) for k in cols] for r in report], columns=cols)


def undetermined(report: Sequence[TermObservability]) -> dict[str, tuple[str, ...]]:
    """Per term, the channels whose runs do not determine it (terms with none left out)."""
    out: dict[str, list[str]] = {}
    for r in report:
        if not r.determined:
            out.setdefault(r.term, []).append(r.channel)
    return {k: tuple(v) for k, v in out.items()}
