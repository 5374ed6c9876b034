"""The candidate models of ``fit --method auto``: families, their members and their fits.

:func:`candidates` lists what a channel may get (``none``, the field's ``ardupilot`` and
``px4``, ``poly-t`` and ``regression`` of every order up to :data:`MAX_ORDERS`, and on
request ``neural``); :func:`fit_candidate` fits one (:mod:`rinscal.calibration.selection.auto`
scores them on held-out data and chooses).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from rinscal.calibration.thermal.dispatch import fit_params

__all__ = [
    "DEFAULT_FAMILIES",
    "FAMILIES",
    "FLIGHT_MAX_DEGREE",
    "HIDDEN",
    "MAX_ORDERS",
    "NEURAL_SCREEN",
    "Candidate",
    "candidates",
    "fit_candidate",
    "used_inputs",
]

#: Candidate families, in order of preference at equal complexity.
FAMILIES: tuple[str, ...] = ("none", "ardupilot", "px4", "poly-t", "regression", "neural")
#: Families tried by default.
DEFAULT_FAMILIES: tuple[str, ...] = ("none", "ardupilot", "px4", "poly-t", "regression")
#: Largest orders of the polynomial candidates (T, Ṫ, ΔT).
MAX_ORDERS: tuple[int, int, int] = (4, 3, 3)
#: Largest degree in T of a ``poly-t`` candidate that PX4 and ArduPilot can hold (a cubic).
FLIGHT_MAX_DEGREE = 3
#: Hidden-layer sizes screened when ``neural`` is a candidate.
HIDDEN: tuple[int, ...] = (2, 4, 6)
#: Screening budget of a neural candidate's held-out fits.
NEURAL_SCREEN: dict[str, int] = {"max_samples": 5000, "n_init": 1}


@dataclass(frozen=True)
class Candidate:
    """One model a channel may get.

    Attributes
    ----------
    name : str
        Label (``"none"``, ``"px4"``, ``"poly-t 3"``, ``"regression 3,1,0"``, ``"neural 4"``).
    family : str
        One of :data:`FAMILIES`.
    method : str
        Estimator method (``none`` is a ``poly-t`` of degree 0).
    params : dict
        Estimator hyper-parameters.
    n_params : int
        Thermal parameters (the constant not counted): the complexity of the choice.
    orders : tuple of int or None
        Orders in (T, Ṫ, ΔT) of a polynomial candidate (the fast path), else None.
    """

    name: str
    family: str
    method: str
    params: dict[str, Any] = field(default_factory=dict)
    n_params: int = 0
    orders: tuple[int, ...] | None = None

    @property
    def t_only(self) -> bool:
        """Whether the candidate uses the temperature alone (a fallback may be one)."""
        if self.family in ("none", "px4", "ardupilot", "poly-t"):
            return True
        return self.orders is not None and not any(self.orders[1:])

    @property
    def flight(self) -> bool:
        """Whether PX4 and ArduPilot can hold the candidate: a clamped cubic in T (``none``,
        ``ardupilot``, ``px4``, ``poly-t`` of degree ≤ :data:`FLIGHT_MAX_DEGREE`)."""
        if self.family in ("none", "px4", "ardupilot"):
            return True
        return self.family == "poly-t" and int(self.params["degree"]) <= FLIGHT_MAX_DEGREE


def candidates(
    sensor: str,
    n_inputs: int,
    families: Sequence[str] = DEFAULT_FAMILIES,
    hidden: Sequence[int] = HIDDEN,
) -> list[Candidate]:
    """The candidates of one channel.

    Parameters
    ----------
    sensor : {"gyro", "accel"}
        Sensor type (the PX4 fit removes an accelerometer's median).
    n_inputs : int
        Inputs available: 2 (T, Ṫ) or 3 (with ΔT).
    families : sequence of str
        Among :data:`FAMILIES`.
    hidden : sequence of int
        Hidden-layer sizes of the ``neural`` candidates.

    Returns
    -------
    list of Candidate
    """
    unknown = [f for f in families if f not in FAMILIES]
    if unknown or not families:
        raise ValueError(f"candidate families must be among {', '.join(FAMILIES)}, got {unknown}")
    out: list[Candidate] = []
    fams = [f for f in FAMILIES if f in families]
    for fam in fams:
        if fam == "none":
            out.append(Candidate("none", fam, "poly-t", {"degree": 0}, 0, (0, 0, 0)))
        elif fam in ("px4", "ardupilot"):
            out.append(Candidate(fam, fam, fam, {"sensor": sensor}, 3))
        elif fam == "poly-t":
            for d in range(1, MAX_ORDERS[0] + 1):
                out.append(Candidate(f"poly-t {d}", fam, "poly-t", {"degree": d}, d, (d, 0, 0)))
        elif fam == "regression":
            s_max = MAX_ORDERS[2] if n_inputs >= 3 else 0
            for p in range(1, MAX_ORDERS[0] + 1):
                for q in range(MAX_ORDERS[1] + 1):
                    for s in range(s_max + 1):
                        if q == s == 0:
                            continue
                        orders = (p, q, s) if n_inputs >= 3 else (p, q)
                        params = dict(
                            zip(("t_order", "rate_order", "grad_order"), orders, strict=False)
                        )
                        if n_inputs < 3:
                            params["grad_order"] = 0
                        out.append(
                            Candidate(
                                "regression " + ",".join(map(str, orders)),
                                fam,
                                "regression",
                                params,
                                p + q + s,
                                (p, q, s),
                            )
                        )
        else:  # neural
            for n in hidden:
                out.append(
                    Candidate(f"neural {n}", fam, "neural", {"hidden": int(n)}, n * (n_inputs + 2))
                )
    return out


def used_inputs(cand: Candidate, d: int) -> int:
    """Feature columns a candidate's fit should see (trailing unused inputs dropped)."""
    if cand.orders is None:
        return d
    used = [v + 1 for v, o in enumerate(cand.orders[:d]) if o > 0]
    return max(used, default=1)


def fit_candidate(
    cand: Candidate,
    x: np.ndarray,
    y: np.ndarray,
    groups: np.ndarray,
    t: np.ndarray,
    random_state: int = 0,
    screen: bool = False,
) -> dict[str, Any]:
    """Fit a candidate; its parameters (``screen``: a network's screening budget).

    Parameters
    ----------
    cand : Candidate
        The candidate.
    x : ndarray, shape (n, d)
        ``T`` [°C], ``Ṫ`` [°C/min] (, ``ΔT`` [°C]).
    y : ndarray, shape (n,)
        Output [log units].
    groups : ndarray of int, shape (n,)
        Run of each row.
    t : ndarray, shape (n,) [s]
        Time since each run's power-on.
    random_state : int
        Seed of a network.
    screen : bool
        Held-out screening (:data:`NEURAL_SCREEN`) rather than the final fit.

    Returns
    -------
    dict
        Parameters (see :mod:`rinscal.calibration.inference`).
    """
    hyper = dict(cand.params)
    if cand.method == "neural":
        hyper["random_state"] = random_state
        if screen:
            hyper.update(NEURAL_SCREEN)
    xs = x[:, : used_inputs(cand, x.shape[1])]
    return fit_params(cand.method, hyper, xs, y, groups, t)
