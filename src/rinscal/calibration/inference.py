"""Evaluation of fitted thermal models from their plain parameters: numpy only.

This module is what a navigation computer needs: it imports numpy and nothing else, and
evaluates every method from the JSON-able parameter dictionaries that the estimators
export and the model files store. The estimators' own ``predict`` calls these functions,
so a model and its file give identical predictions.

Feature matrices have columns ``T`` [°C], ``Ṫ`` [°C/min], ``ΔT`` [°C] in that order;
columns a model does not use are ignored.

Parameter dictionaries (every number a float, every array a nested list)
-------------------------------------------------------------------------
``poly-t``
    ``t_ref``, ``coef`` (d+1): ``f = Σ_k coef[k] (T − t_ref)^k``.
``regression`` (Eq. 11)
    ``orders`` (one per input used), ``center``, ``scale``, ``intercept``, ``coef`` (a list
    per input of ``orders[v]`` numbers): with ``z_v = (x_v − center[v]) / scale[v]``,
    ``f = intercept + Σ_v Σ_{k=1..orders[v]} coef[v][k−1] z_v^k``.
``sectional`` (Eq. 15)
    ``orders`` (for ``T`` and ``Ṫ``), ``edges`` (K−1 increasing temperatures), and per
    segment ``center`` (K × 2), ``scale`` (K × 2), ``intercept`` (K), ``coef`` (K lists as in
    ``regression``). Segment ``k`` holds ``edges[k−1] < T ≤ edges[k]``.
``neural`` (Eqs. 12-14)
    ``x_mean``, ``x_scale`` (d), ``W`` (n × d), ``b`` (n), ``v`` (n), ``b_out``, ``y_mean``,
    ``y_scale``: ``f = y_mean + y_scale · (v · σ(W z + b) + b_out)`` with
    ``z = (x − x_mean) / x_scale`` and ``σ(a) = 1 / (1 + e^{−a})``.
``px4``, ``ardupilot`` (the field's own fits, :mod:`rinscal.calibration.thermal.baselines`)
    ``t_ref``, ``t_min``, ``t_max`` [°C] and ``coef`` (4 numbers):
    ``f = Σ_{k=0..3} coef[k] (clip(T, t_min, t_max) − t_ref)^k``, the temperature clamped to
    the calibrated range as both firmwares do (``t_min ≤ t_max``). ``px4``: ``coef`` are
    ``TC_*_X0 .. X3``, ``t_ref``/``t_min``/``t_max`` are ``TC_*_TREF/TMIN/TMAX``. ``ardupilot``:
    ``t_ref`` is always 35.0 (the firmware's fixed ``TEMP_REFERENCE``), ``coef[1:]`` are
    ``INS_TCALn_*1..3`` (without the × 1e6 scaling) and ``coef[0]``, which ArduPilot does not
    store, is the training mean of ``y`` minus the cubic.
"""

from __future__ import annotations

from collections.abc import Container, Mapping, Sequence
from math import comb
from typing import Any

import numpy as np

from rinscal import units

__all__ = [
    "METHODS",
    "coefficient_unit",
    "n_inputs",
    "physical_coefficients",
    "poly_shift",
    "predict_params",
    "raw_polynomial",
    "segment_params",
    "validate_params",
]

#: Method names, as written in model files and on the command line.
METHODS: tuple[str, ...] = ("poly-t", "sectional", "regression", "neural", "px4", "ardupilot")

_CHUNK = 1 << 15

#: The keys of each method's parameter dictionary (exactly these).
PARAM_KEYS: dict[str, tuple[str, ...]] = {
    "poly-t": ("method", "t_ref", "coef"),
    "regression": ("method", "orders", "center", "scale", "intercept", "coef"),
    "sectional": ("method", "orders", "edges", "center", "scale", "intercept", "coef"),
    "neural": ("method", "x_mean", "x_scale", "W", "b", "v", "b_out", "y_mean", "y_scale"),
    "px4": ("method", "t_ref", "t_min", "t_max", "coef"),
    "ardupilot": ("method", "t_ref", "t_min", "t_max", "coef"),
}

#: ArduPilot's fixed reference temperature [°C] (``TEMP_REFERENCE``).
ARDUPILOT_T_REF = 35.0


def _horner(z: np.ndarray, coef: Sequence[float]) -> np.ndarray:
    """``Σ_{k=1..K} coef[k−1] z^k`` (no constant term)."""
    acc = np.full_like(z, coef[-1])
    for c in coef[-2::-1]:
        acc *= z
        acc += c
    acc *= z
    return acc


def _sigmoid(a: np.ndarray) -> np.ndarray:
    """Logistic function, overflow-free: σ(a) = (1 + tanh(a/2)) / 2."""
    a *= 0.5
    np.tanh(a, out=a)
    a += 1.0
    a *= 0.5
    return a


def n_inputs(params: Mapping[str, Any]) -> int:
    """Number of feature columns a model uses (1 to 3)."""
    method = params["method"]
    if method in ("poly-t", "px4", "ardupilot"):
        return 1
    if method == "sectional":
        return 2
    if method == "regression":
        return len(params["orders"])
    return len(params["x_mean"])


def _eval_poly_t(p: Mapping[str, Any], x: np.ndarray) -> np.ndarray:
    coef = [float(c) for c in p["coef"]]
    d = x[:, 0] - float(p["t_ref"])
    if len(coef) == 1:
        return np.full(d.shape, coef[0])
    return _horner(d, coef[1:]) + coef[0]


def _eval_clamped_cubic(p: Mapping[str, Any], x: np.ndarray) -> np.ndarray:
    """``Σ_k coef[k] (clip(T, t_min, t_max) − t_ref)^k`` (``px4``, ``ardupilot``)."""
    coef = [float(c) for c in p["coef"]]
    d = np.clip(x[:, 0], float(p["t_min"]), float(p["t_max"])) - float(p["t_ref"])
    return _horner(d, coef[1:]) + coef[0]


def _eval_regression(p: Mapping[str, Any], x: np.ndarray) -> np.ndarray:
    out = np.full(x.shape[0], float(p["intercept"]))
    for v, order in enumerate(p["orders"]):
        if order == 0:
            continue
        z = (x[:, v] - float(p["center"][v])) * (1.0 / float(p["scale"][v]))
        out += _horner(z, [float(c) for c in p["coef"][v]])
    return out


def segment_params(params: Mapping[str, Any], k: int) -> dict[str, Any]:
    """Segment ``k`` of a ``sectional`` model as the parameters of a ``regression`` model."""
    return {
        "method": "regression",
        "orders": params["orders"],
        "center": params["center"][k],
        "scale": params["scale"][k],
        "intercept": params["intercept"][k],
        "coef": params["coef"][k],
    }


def _eval_sectional(p: Mapping[str, Any], x: np.ndarray) -> np.ndarray:
    edges = np.asarray(p["edges"], dtype=np.float64)
    seg = np.searchsorted(edges, x[:, 0], side="left")
    out = np.empty(x.shape[0])
    for k in range(edges.size + 1):
        sel = seg == k
        if not sel.any():
            continue
        out[sel] = _eval_regression(segment_params(p, k), x[sel])
    return out


def _eval_neural(p: Mapping[str, Any], x: np.ndarray) -> np.ndarray:
    d = len(p["x_mean"])
    mean = np.asarray(p["x_mean"], dtype=np.float64)
    inv = 1.0 / np.asarray(p["x_scale"], dtype=np.float64)
    w = np.asarray(p["W"], dtype=np.float64)  # (n, d)
    b = np.asarray(p["b"], dtype=np.float64)
    v = np.asarray(p["v"], dtype=np.float64)
    # fold the input standardisation into the first layer: W z + b = (W/s) x + (b − W m/s)
    wf = w * inv[None, :]
    bf = b - wf @ mean
    ys, ym, bo = float(p["y_scale"]), float(p["y_mean"]), float(p["b_out"])
    out = np.empty(x.shape[0])
    for s in range(0, x.shape[0], _CHUNK):
        xs = x[s : s + _CHUNK, :d]
        a = xs @ wf.T
        a += bf
        h = _sigmoid(a)
        out[s : s + _CHUNK] = h @ v
    out += bo
    out *= ys
    out += ym
    return out


_EVAL = {
    "poly-t": _eval_poly_t,
    "regression": _eval_regression,
    "sectional": _eval_sectional,
    "neural": _eval_neural,
    "px4": _eval_clamped_cubic,
    "ardupilot": _eval_clamped_cubic,
}


def predict_params(params: Mapping[str, Any], x: np.ndarray) -> np.ndarray:
    """Evaluate a thermal model from its parameters.

    Parameters
    ----------
    params : mapping
        Parameters of one channel (see the module docstring); ``params["method"]`` picks
        the form.
    x : ndarray, shape (n, k)
        Features ``T`` [°C], ``Ṫ`` [°C/min], ``ΔT`` [°C]; ``k`` at least :func:`n_inputs`.

    Returns
    -------
    ndarray, shape (n,) [output units]
        The modelled output ``f(T, Ṫ, ΔT)``.
    """
    x = np.asarray(x, dtype=np.float64)
    if x.ndim == 1:
        x = x[:, None]
    need = n_inputs(params)
    if x.shape[1] < need:
        raise ValueError(
            f"{params['method']} model needs {need} feature column(s), got {x.shape[1]}"
        )
    if x.shape[0] == 0:
        return np.zeros(0)
    if params["method"] in ("regression", "poly-t") and x.shape[0] > _CHUNK:
        out = np.empty(x.shape[0])
        f = _EVAL[params["method"]]
        for s in range(0, x.shape[0], _CHUNK):
            out[s : s + _CHUNK] = f(params, x[s : s + _CHUNK])
        return out
    return _EVAL[params["method"]](params, x)


# ----------------------------------------------------------------------------- raw forms


def poly_shift(coef: Sequence[float], center: float, scale: float) -> np.ndarray:
    """Coefficients in powers of ``x`` of ``Σ_k coef[k] ((x − center)/scale)^k``.

    Parameters
    ----------
    coef : sequence of float, length K+1
        Coefficients of ``z^0 .. z^K``.
    center, scale : float
        The map ``z = (x − center) / scale``.

    Returns
    -------
    ndarray, shape (K+1,)
        Coefficients of ``x^0 .. x^K``.
    """
    c = np.asarray(coef, dtype=np.float64)
    out = np.zeros_like(c)
    for j in range(c.size):
        cj = c[j] / scale**j
        for i in range(j + 1):
            out[i] += cj * comb(j, i) * (-center) ** (j - i)
    return out


def raw_polynomial(params: Mapping[str, Any]) -> dict[str, Any]:
    """The paper's raw polynomial form of a ``regression`` or ``sectional`` model.

    Returns the constant ``a0`` and, per input, the coefficients of ``x^1 .. x^order`` in
    the raw inputs (``T`` [°C], ``Ṫ`` [°C/min], ``ΔT`` [°C]), as in Table 6 (Eq. 11) or,
    per segment, Table 4. A ``poly-t`` model gives the coefficients of ``T^0 .. T^d``.

    Parameters
    ----------
    params : mapping
        Parameters of one channel.

    Returns
    -------
    dict
        ``{"a0": float, "coef": [[...], ...]}``; for ``sectional`` a dict with ``edges`` and
        ``segments`` (a list of such dicts); for ``poly-t`` ``{"coef": [...]}``.
    """
    method = params["method"]
    if method == "poly-t":
        return {"coef": poly_shift(params["coef"], float(params["t_ref"]), 1.0).tolist()}
    if method == "sectional":
        segs = []
        for k in range(len(params["intercept"])):
            segs.append(raw_polynomial(segment_params(params, k)))
        return {"edges": list(params["edges"]), "segments": segs}
    if method != "regression":
        raise ValueError(f"{method} models have no polynomial form")
    a0 = float(params["intercept"])
    coefs = []
    for v, order in enumerate(params["orders"]):
        full = [0.0, *(float(c) for c in params["coef"][v])]
        raw = poly_shift(full, float(params["center"][v]), float(params["scale"][v]))
        a0 += raw[0]
        coefs.append(raw[1 : order + 1].tolist())
    return {"a0": a0, "coef": coefs}


# ----------------------------------------------------------------------------- validation


def _arr(params: Mapping[str, Any], key: str, shape: tuple[int | None, ...]) -> np.ndarray:
    if key not in params:
        raise ValueError(f"missing key {key!r}")
    try:
        a = np.asarray(params[key], dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"{key!r} is not a numeric array of shape {shape}") from None
    if (
        isinstance(params[key], bool)
        or a.ndim != len(shape)
        or any(s is not None and a.shape[i] != s for i, s in enumerate(shape))
    ):
        raise ValueError(f"{key!r} has shape {a.shape}, expected {shape}")
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{key!r} holds a non-finite number")
    return a


def _num(params: Mapping[str, Any], key: str) -> float:
    v = params.get(key, None)
    if key not in params:
        raise ValueError(f"missing key {key!r}")
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v):
        raise ValueError(f"{key!r} must be a finite number, got {v!r}")
    return float(v)


def _orders(params: Mapping[str, Any], length: int | None) -> list[int]:
    o = params.get("orders")
    if not isinstance(o, list) or not all(
        isinstance(k, int) and not isinstance(k, bool) and 0 <= k <= 12 for k in o
    ):
        raise ValueError(f"'orders' must be a list of integers 0..12, got {o!r}")
    if (length is not None and len(o) != length) or not 1 <= len(o) <= 3:
        raise ValueError(f"'orders' has {len(o)} entries, expected {length or '1 to 3'}")
    return o


def _ragged(value: Any, orders: Sequence[int], key: str) -> None:
    if not isinstance(value, list) or len(value) != len(orders):
        raise ValueError(f"{key!r} must be a list of {len(orders)} coefficient lists")
    for v, (row, k) in enumerate(zip(value, orders, strict=True)):
        a = _arr({"c": row}, "c", (k,)) if isinstance(row, list) else None
        if a is None:
            raise ValueError(f"{key!r}[{v}] must be a list of {k} numbers")


def validate_params(params: Any) -> None:
    """Check the parameters of one channel: keys, shapes, finite numbers.

    Raises
    ------
    ValueError
        Naming the first problem.
    """
    if not isinstance(params, Mapping):
        raise ValueError("model parameters must be a JSON object")
    method = params.get("method")
    if method not in METHODS:
        raise ValueError(f"unknown method {method!r}; expected one of {', '.join(METHODS)}")
    keys = set(PARAM_KEYS[method])
    missing = sorted(keys - set(params))
    if missing:
        raise ValueError(f"missing key(s) {missing} of a {method} model")
    extra = sorted(set(params) - keys)
    if extra:
        raise ValueError(f"unexpected key(s) {extra} in a {method} model")
    if method == "poly-t":
        _num(params, "t_ref")
        c = _arr(params, "coef", (None,))
        if not 1 <= c.size <= 8:
            raise ValueError(f"'coef' has {c.size} entries, expected 1 to 8")
    elif method in ("px4", "ardupilot"):
        t_ref = _num(params, "t_ref")
        t_min = _num(params, "t_min")
        t_max = _num(params, "t_max")
        if t_min > t_max:
            raise ValueError(f"'t_min' ({t_min}) is above 't_max' ({t_max})")
        if method == "ardupilot" and t_ref != ARDUPILOT_T_REF:
            raise ValueError(
                f"'t_ref' of an ardupilot model must be {ARDUPILOT_T_REF} (the firmware's fixed "
                f"TEMP_REFERENCE), got {t_ref}"
            )
        _arr(params, "coef", (4,))
    elif method == "regression":
        o = _orders(params, None)
        d = len(o)
        _arr(params, "center", (d,))
        s = _arr(params, "scale", (d,))
        if np.any(s <= 0):
            raise ValueError("'scale' entries must be positive")
        _num(params, "intercept")
        _ragged(params.get("coef"), o, "coef")
    elif method == "sectional":
        o = _orders(params, 2)
        e = _arr(params, "edges", (None,))
        if np.any(np.diff(e) <= 0):
            raise ValueError("'edges' must be strictly increasing")
        k = e.size + 1
        _arr(params, "center", (k, 2))
        s = _arr(params, "scale", (k, 2))
        if np.any(s <= 0):
            raise ValueError("'scale' entries must be positive")
        _arr(params, "intercept", (k,))
        coef = params.get("coef")
        if not isinstance(coef, list) or len(coef) != k:
            raise ValueError(f"'coef' must hold one entry per segment ({k})")
        for seg in coef:
            _ragged(seg, o, "coef")
    else:  # neural
        m = _arr(params, "x_mean", (None,))
        d = m.size
        if not 1 <= d <= 3:
            raise ValueError(f"'x_mean' has {d} entries, expected 1 to 3")
        s = _arr(params, "x_scale", (d,))
        if np.any(s <= 0):
            raise ValueError("'x_scale' entries must be positive")
        w = _arr(params, "W", (None, d))
        n = w.shape[0]
        if n < 1:
            raise ValueError("'W' has no hidden neuron")
        _arr(params, "b", (n,))
        _arr(params, "v", (n,))
        for key in ("b_out", "y_mean", "y_scale"):
            _num(params, key)
        if params["y_scale"] <= 0:
            raise ValueError("'y_scale' must be positive")


#: The inputs of a regression model, in its ``orders``' order, and each one's unit.
_INPUTS = (("T", "°C"), ("Ṫ", "°C/min"), ("ΔT", "°C"))
_POWERS = {1: "¹", 2: "²", 3: "³", 4: "⁴", 5: "⁵"}


def physical_coefficients(params: Mapping[str, Any]) -> dict[str, float]:
    """A channel model's coefficients in physical units, named by their term.

    The raw polynomial (:func:`rinscal.calibration.inference.raw_polynomial`): a ``poly-t``
    model's ``T⁰ .. T³`` (coefficients of the powers of ``T`` [°C]); a ``regression``
    model's constant ``a₀`` and the coefficients of ``T``, ``Ṫ`` [°C/min] and ``ΔT`` [°C]
    and their powers. Each is in the channel's unit per its term's unit
    (:func:`coefficient_unit`). Other methods (sectional, neural) have no such form: empty.
    """
    method = params.get("method")
    if method == "poly-t":
        coef = raw_polynomial(params)["coef"]
        return {("T⁰" if k == 0 else f"T{_POWERS.get(k, f'^{k}')}"): float(c)
                for k, c in enumerate(coef)}  # fmt: skip
    if method != "regression":
        return {}
    raw = raw_polynomial(params)
    out = {"a₀": float(raw["a0"])}
    for (name, _), coefs in zip(_INPUTS, raw["coef"], strict=False):
        for k, c in enumerate(coefs, start=1):
            out[f"{name}{_POWERS.get(k, f'^{k}')}"] = float(c)
    return out


def coefficient_unit(term: str, unit: str, same: Container[str] = ()) -> str:
    """The unit of a :func:`physical_coefficients` term of a channel logged in ``unit``:
    ``T²`` of a gyro in deg/h is in °/h/°C², ``Ṫ¹`` in °/h/(°C/min), ``a₀`` and ``T⁰`` in
    °/h; a term in ``same`` (a figure in the log's unit) keeps ``unit`` as it is."""
    if term in same:
        return unit
    u = units.unit_words(unit) if unit else "unit"
    if term in ("a₀", "T⁰"):
        return u
    for name, per in _INPUTS:  # "T", "Ṫ" and "ΔT" start with different characters
        if term.startswith(name):
            base = f"({per})" if "/" in per else per
            return f"{u}/{base}{term[len(name) :].replace('¹', '')}"
    return u
