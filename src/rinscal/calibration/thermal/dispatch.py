"""Fitting one channel with any method: the dispatch behind ``ThermalFitter`` and ``auto``.

:func:`fit_params` fits ``poly-t``, ``regression`` and ``sectional`` with the numpy code of
:mod:`rinscal.calibration.thermal.fitting`, ``px4`` and ``ardupilot`` with the field's fits
(:mod:`rinscal.calibration.thermal.baselines`) and ``neural`` with the scikit-learn estimator
(:class:`rinscal.calibration.thermal.estimators.Neural`, imported only then). Kept apart from
``_fit`` so that the estimators, which build on ``_fit``, are not imported back by it.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from rinscal.calibration.thermal.baselines import ardupilot_fit, px4_fit
from rinscal.calibration.thermal.fitting import (
    fit_poly_t,
    fit_regression,
    fit_sectional,
    sectional_edges,
)

__all__ = ["fit_params"]


def fit_params(
    method: str,
    hyper: Mapping[str, Any],
    X: np.ndarray,
    y: np.ndarray,
    groups: np.ndarray | None = None,
    t: np.ndarray | None = None,
) -> dict[str, Any]:
    """Fit one channel with any method; the parameters its model file stores.

    Parameters
    ----------
    method : str
        ``poly-t``, ``regression``, ``sectional``, ``px4``, ``ardupilot`` or ``neural``.
    hyper : mapping
        Hyper-parameters, as the estimator classes name them (``degree``, ``t_ref``;
        ``t_order``, ``rate_order``, ``grad_order``; ``edges``, ``set_points``,
        ``n_segments``; ``sensor``, ``resample``, ``window_s``; the network's).
    X : ndarray, shape (n, k)
        ``T`` [°C], ``Ṫ`` [°C/min] (, ``ΔT`` [°C]), finite.
    y : ndarray, shape (n,)
        Raw output [log units].
    groups : ndarray of int, optional
        Run of each row (the filters of ``px4``/``ardupilot``, the network's validation).
    t : ndarray, optional [s]
        Time since each run's power-on (``ardupilot``).

    Returns
    -------
    dict
        Parameters (see :mod:`rinscal.calibration.inference`).
    """
    h = dict(hyper)
    if method == "poly-t":
        return fit_poly_t(X, y, h.get("degree", 3), h.get("t_ref"))
    if method == "regression":
        return fit_regression(
            X, y, h.get("t_order", 3), h.get("rate_order", 3), h.get("grad_order", 3)
        )
    if method == "sectional":
        edges = sectional_edges(
            X[:, 0], h.get("edges"), h.get("set_points"), h.get("n_segments", 7)
        )
        return fit_sectional(X, y, edges, h.get("t_order", 3), h.get("rate_order", 3))
    if method == "px4":
        return px4_fit(X[:, 0], y, groups, **h)
    if method == "ardupilot":
        return ardupilot_fit(X[:, 0], y, t, groups, **h)
    if method == "neural":
        # deferred: estimators imports scikit-learn (about 1 s); only a network needs it
        from rinscal.calibration.thermal.estimators import Neural

        est = Neural()
        est.set_params(**h)
        return est.fit(X, y, groups=groups).params_
    raise ValueError(f"unknown method {method!r}")
