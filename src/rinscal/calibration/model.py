"""Fit one thermal model per sensor channel on a calibration log.

:class:`ThermalModel` holds one estimator (:mod:`rinscal.calibration.estimators`) per channel,
with the paper's defaults by sensor type:

=============  ==============================  ==============================
method         gyroscopes                      accelerometers
=============  ==============================  ==============================
``poly-t``     cubic in T                      cubic in T
``sectional``  G0, T, Ṫ per segment (3)        A0, T, T², T³, Ṫ, Ṫ², Ṫ³ (7)
``regression`` p = q = s = 1                   p = q = s = 3
``neural``     n = 2 hidden neurons            n = 6 hidden neurons
=============  ==============================  ==============================

It builds the features run by run, masks outliers, fits each channel on its inlier samples,
and produces a :class:`~rinscal.calibration.modelfile.ThermalModelFile` (units, static
reference, training ranges and metrics included) with :meth:`ThermalModel.to_file`.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np
import pandas as pd

from rinscal._version import __version__
from rinscal.calibration._domain import column_range, fit_domain
from rinscal.calibration._fit import fit_params, fit_poly_t
from rinscal.calibration._inference import METHODS, n_inputs, predict_params
from rinscal.calibration.auto import (
    DEFAULT_FAMILIES,
    DEFAULT_TOLERANCE,
    candidates,
    fit_candidate,
    select_channel,
)
from rinscal.calibration.features import (
    DerivativeConfig,
    Features,
    OutlierConfig,
    build_features,
    set_points,
)
from rinscal.calibration.guards import PLAUSIBLE_TEMP_C, DesignError, check_temperatures
from rinscal.calibration.modelfile import AUTO, ChannelModel, ThermalModelFile
from rinscal.errors import ConfigError
from rinscal.schema import CHANNELS, GYRO_CHANNELS, TEMP_OUT, temperature_column
from rinscal.units import DEG_TO_RAD, SENSOR_UNITS

__all__ = ["DEFAULTS", "FIT_METHODS", "ThermalModel", "site_reference", "unit_factors"]

#: Methods ``ThermalModel`` fits: the paper's and the baseline, the field's own fits, and
#: ``auto`` (each channel's model chosen by held-out error).
FIT_METHODS: tuple[str, ...] = (AUTO, *METHODS)
#: Methods whose model uses the temperature alone.
T_ONLY_METHODS: tuple[str, ...] = ("poly-t", "px4", "ardupilot")

#: Hyper-parameters of each method by sensor type (``"gyro"``, ``"accel"``).
DEFAULTS: dict[str, dict[str, dict[str, Any]]] = {
    "poly-t": {"gyro": {"degree": 3}, "accel": {"degree": 3}},
    "sectional": {
        "gyro": {"t_order": 1, "rate_order": 1},
        "accel": {"t_order": 3, "rate_order": 3},
    },
    "regression": {
        "gyro": {"t_order": 1, "rate_order": 1, "grad_order": 1},
        "accel": {"t_order": 3, "rate_order": 3, "grad_order": 3},
    },
    "neural": {"gyro": {"hidden": 2}, "accel": {"hidden": 6}},
    "px4": {"gyro": {"sensor": "gyro"}, "accel": {"sensor": "accel"}},
    "ardupilot": {"gyro": {"sensor": "gyro"}, "accel": {"sensor": "accel"}},
}


def sensor_type(channel: str) -> str:
    """``"gyro"`` or ``"accel"``."""
    return "gyro" if channel in GYRO_CHANNELS else "accel"


def unit_factors(
    meta: Mapping[str, Any] | None, channels: Sequence[str] = CHANNELS
) -> tuple[dict[str, str | None], dict[str, float | None]]:
    """Units of the channels and their SI value, from a log's metadata.

    ``meta["unit_to_si"][channel]`` wins; else ``meta["units"][channel]`` through
    :data:`rinscal.units.SENSOR_UNITS`, or ``meta["pulse_scale"][channel]`` for ``"pulse"``.

    Returns
    -------
    units : dict of str to str or None
    unit_to_si : dict of str to float or None [SI per log unit]
    """
    meta = meta or {}
    units_m = meta.get("units") or {}
    to_si = meta.get("unit_to_si") or {}
    pulse = meta.get("pulse_scale") or {}
    units: dict[str, str | None] = {}
    factors: dict[str, float | None] = {}
    for c in channels:
        u = units_m.get(c, units_m.get(sensor_type(c)))
        units[c] = str(u) if u is not None else None
        k = to_si.get(c)
        if k is None and u is not None:
            k = pulse.get(c) if u == "pulse" else SENSOR_UNITS.get(str(u))
        ok = isinstance(k, (int, float)) and not isinstance(k, bool) and np.isfinite(k) and k > 0
        factors[c] = float(k) if ok else None
    return units, factors


def site_reference(
    meta: Mapping[str, Any] | None,
    factors: Mapping[str, float | None],
    channels: Sequence[str] = CHANNELS,
) -> dict[str, float | None]:
    """Static output (Earth rate, gravity) of a level IMU on the calibration table, log units.

    Uses :func:`rinscal.nav.earth.static_outputs_r` with the metadata's ``latitude_deg``,
    ``heading_deg`` and optional ``altitude_m``.

    Returns
    -------
    dict of str to float or None
        None for a channel whose unit, or the site, is unknown.
    """
    from rinscal.nav.earth import static_outputs_r

    meta = meta or {}
    lat, head = meta.get("latitude_deg"), meta.get("heading_deg")
    if not all(isinstance(v, (int, float)) and np.isfinite(v) for v in (lat, head)):
        return dict.fromkeys(channels)
    alt = meta.get("altitude_m", 0.0)
    alt = float(alt) if isinstance(alt, (int, float)) and np.isfinite(alt) else 0.0
    omega, f = static_outputs_r(float(lat) * DEG_TO_RAD, float(head) * DEG_TO_RAD, alt)
    si = dict(zip(CHANNELS, [*omega.tolist(), *f.tolist()], strict=True))
    out: dict[str, float | None] = {}
    for c in channels:
        k = factors.get(c)
        out[c] = None if k is None else si[c] / k
    return out


def _edges_from(points: np.ndarray | None) -> np.ndarray | None:
    if points is None or points.size < 2:
        return None
    return 0.5 * (points[1:] + points[:-1])


class ThermalModel:
    """One thermal estimator per channel, fitted on a calibration log.

    Parameters
    ----------
    method : {"auto", "poly-t", "sectional", "regression", "neural", "px4", "ardupilot"}
        Model form; ``auto`` chooses each channel's by held-out error
        (:mod:`rinscal.calibration.auto`).
    orders : tuple of int, optional
        ``(p, q, s)`` for ``regression`` or ``(p, q)`` for ``sectional``, for every channel;
        default by sensor type (see :data:`DEFAULTS`).
    hidden : int, optional
        Hidden neurons for ``neural``, every channel; default 2 (gyros) and 6 (accels).
    edges : sequence of float, optional [°C]
        Segment edges for ``sectional`` (default: midpoints between the chamber set points).
    derivative : DerivativeConfig, optional
        Temperature-rate estimator (default centred, 60 s).
    outliers : OutlierConfig, optional
        Outlier masking (default 10 s running median, 6 robust spreads).
    use_gradient : bool, optional
        None: use ``ΔT`` if the log has ``temp_out`` (warn if not).
    channels : sequence of str
        Channels to model.
    random_state : int
        Seed of the neural starts.
    estimator_params : mapping, optional
        Further hyper-parameters set on every channel's estimator (e.g.
        ``{"max_samples": 20000}`` for ``neural``, ``{"t_ref": 25.0}`` for ``poly-t``).
    candidates : sequence of str
        ``auto``: candidate families (see :data:`rinscal.calibration.auto.FAMILIES`).
    tolerance : float
        ``auto``: relative tolerance of the choice (simplest within it of the best).
    temp_range : (float, float) [°C]
        Plausible temperature readings; a training log outside it is refused.

    Attributes
    ----------
    params_ : dict of str to dict
        Fitted parameters per channel (see :mod:`rinscal.calibration._inference`).
    features_ : Features
        Training features (kept for diagnostics; not written to the model file).
    """

    def __init__(
        self,
        method: str,
        *,
        orders: Sequence[int] | None = None,
        hidden: int | None = None,
        edges: Sequence[float] | None = None,
        derivative: DerivativeConfig | None = None,
        outliers: OutlierConfig | None = None,
        use_gradient: bool | None = None,
        channels: Sequence[str] = CHANNELS,
        random_state: int = 0,
        estimator_params: Mapping[str, Any] | None = None,
        candidates: Sequence[str] = DEFAULT_FAMILIES,
        tolerance: float = DEFAULT_TOLERANCE,
        temp_range: tuple[float, float] = PLAUSIBLE_TEMP_C,
    ) -> None:
        if method not in FIT_METHODS:
            raise ConfigError(f"method must be one of {', '.join(FIT_METHODS)}, got {method!r}")
        self.candidates = tuple(candidates)
        self.tolerance = float(tolerance)
        self.temp_range = (float(temp_range[0]), float(temp_range[1]))
        if not self.temp_range[0] < self.temp_range[1]:
            raise ConfigError(f"temp_range must be (low, high) with low < high, got {temp_range}")
        self.method = method
        self.orders = None if orders is None else tuple(int(o) for o in orders)
        self.hidden = hidden
        self.edges = None if edges is None else tuple(float(e) for e in edges)
        self.derivative = derivative or DerivativeConfig()
        self.outliers = outliers or OutlierConfig()
        self.use_gradient = use_gradient
        self.channels = tuple(channels)
        unknown = [c for c in self.channels if c not in CHANNELS]
        if unknown or not self.channels:
            raise ConfigError(f"channels must be among {CHANNELS}, got {list(channels)}")
        self.random_state = int(random_state)
        self.estimator_params = dict(estimator_params or {})
        self._check_options()

    def _check_options(self) -> None:
        m = self.method
        if self.orders is not None:
            want = {"regression": 3, "sectional": 2, "poly-t": 1}.get(m)
            if want is None:
                raise ConfigError(f"orders apply to regression, sectional and poly-t, not {m}")
            if len(self.orders) != want or any(o < 0 or o > 8 for o in self.orders):
                raise ConfigError(
                    f"orders for {m} must be {want} integer(s) in 0..8, got {self.orders}"
                )
        if self.hidden is not None and (m != "neural" or not 1 <= int(self.hidden) <= 64):
            raise ConfigError(f"hidden applies to neural only and must be 1..64, got {self.hidden}")
        if self.edges is not None and m != "sectional":
            raise ConfigError(f"edges apply to sectional only, not {m}")
        if m == AUTO:
            try:
                candidates("gyro", 3, self.candidates)
            except ValueError as exc:
                raise ConfigError(f"candidates: {exc}") from None
            if not 0 <= self.tolerance < 1:
                raise ConfigError(f"tolerance must be in [0, 1), got {self.tolerance}")

    def estimator_for(self, channel: str, set_pts: np.ndarray | None = None) -> Any:
        """The unfitted scikit-learn estimator of one channel, with its hyper-parameters.

        Parameters
        ----------
        channel : str
            Channel.
        set_pts : ndarray, optional [°C]
            Soak set points (``sectional`` segment edges when ``edges`` is None).
        """
        from rinscal.calibration.estimators import ALL_ESTIMATORS

        est = ALL_ESTIMATORS[self.method]()
        try:
            est.set_params(**self.hyper_for(channel, set_pts))
        except ValueError as exc:
            raise ConfigError(f"{self.method} estimator: {exc}") from None
        return est

    @property
    def needs_rate(self) -> bool:
        """Whether the method uses ``Ṫ`` (models of ``T`` alone skip computing it)."""
        return self.method not in T_ONLY_METHODS

    def hyper_for(self, channel: str, set_pts: np.ndarray | None = None) -> dict[str, Any]:
        """Hyper-parameters of one channel's model (as the estimator classes name them).

        Parameters
        ----------
        channel : str
            Channel.
        set_pts : ndarray, optional [°C]
            Soak set points (``sectional`` segment edges when ``edges`` is None).
        """
        params = dict(DEFAULTS[self.method][sensor_type(channel)])
        if self.orders is not None:
            keys = {
                "regression": ("t_order", "rate_order", "grad_order"),
                "sectional": ("t_order", "rate_order"),
                "poly-t": ("degree",),
            }[self.method]
            params.update(zip(keys, self.orders, strict=True))
        if self.hidden is not None:
            params["hidden"] = int(self.hidden)
        if self.method == "neural":
            params["random_state"] = self.random_state
        if self.method == "sectional":
            if self.edges is not None:
                params["edges"] = list(self.edges)
            elif set_pts is not None and set_pts.size >= 2:
                params["set_points"] = set_pts.tolist()
        params.update(self.estimator_params)
        return params

    def _set_points(self, log: pd.DataFrame, feats: Features, j: int) -> np.ndarray | None:
        sp = set_points(log)
        if sp is not None and sp.size >= 2:
            return sp
        # no chamber column: the per-run median inner temperature of this channel
        med = [np.median(feats.temp[feats.run_codes == k, j]) for k in range(len(feats.runs))]
        pts = np.unique(np.round(np.asarray(med), 1))
        return pts if pts.size >= 2 else None

    def fit(
        self,
        log: pd.DataFrame,
        meta: Mapping[str, Any] | None = None,
        *,
        features: Features | None = None,
        on_channel: Callable[[str], None] | None = None,
        source: str | None = None,
    ) -> ThermalModel:
        """Fit every channel.

        Parameters
        ----------
        log : DataFrame
            Validated calibration log.
        meta : mapping, optional
            The log's sidecar metadata (units, latitude_deg, heading_deg), for units and the
            static reference in the model file.
        features : Features, optional
            Precomputed features of ``log`` (built here if omitted).
        on_channel : callable, optional
            Called with each channel name once it is fitted (progress bars).
        source : str, optional
            Name of the log file, for messages.

        Returns
        -------
        ThermalModel

        Raises
        ------
        ConfigError
            When the training data cannot determine a model (implausible temperatures, a
            rank-deficient design: the message says which column and why).

        Warns
        -----
        TrainingDataWarning
            When the model is only weakly determined (coarse temperature resolution, an
            ill-conditioned design).
        """
        where = f"{source}: " if source else ""
        tcols = list(dict.fromkeys(temperature_column(log, c) for c in self.channels))
        if TEMP_OUT in log.columns:
            tcols.append(TEMP_OUT)
        try:
            check_temperatures(
                {c: log[c].to_numpy(dtype=np.float64) for c in tcols},
                self.temp_range,
                rows=np.arange(1, len(log) + 1),
            )
        except ValueError as exc:
            raise ConfigError(f"{where}{exc}") from None
        feats = features or build_features(
            log,
            self.derivative,
            self.outliers,
            self.channels,
            use_gradient=self.use_gradient,
            with_rate=self.needs_rate,
        )
        self.features_ = feats
        self.meta_ = dict(meta or {})
        self.params_: dict[str, dict[str, Any]] = {}
        self.set_points_: dict[str, np.ndarray | None] = {}
        self.train_range_: dict[str, np.ndarray] = {}
        self.metrics_: dict[str, dict[str, float]] = {}
        self.domains_: dict[str, dict[str, Any] | None] = {}
        self.fallbacks_: dict[str, dict[str, Any] | None] = {}
        self.selections_: dict[str, dict[str, Any] | None] = {}
        self.train_mean_: dict[str, float] = {}
        for j, c in enumerate(self.channels):
            x = feats.matrix(j)
            ok = feats.usable(j, x)
            if ok.sum() < 2:
                raise ConfigError(f"{where}{c}: fewer than 2 usable samples to fit")
            sp = self._set_points(log, feats, j)
            self.set_points_[c] = sp
            xo, yo, codes = x[ok], feats.output[ok, j], feats.run_codes[ok]
            to = feats.time_s[ok]
            what = f"{where}{c} (T from column {temperature_column(log, c)!r}"
            what += f", ΔT = T − {TEMP_OUT})" if feats.has_gradient else ")"
            try:
                if self.method == AUTO:
                    cands = candidates(sensor_type(c), x.shape[1], self.candidates)
                    sel = select_channel(
                        xo, yo, codes, feats.runs, to, cands, self.tolerance, self.random_state
                    )
                    data = (xo, yo, codes, to, self.random_state)
                    params = sel.fitted.get(sel.chosen.name) or fit_candidate(sel.chosen, *data)
                    # a chosen model of T alone is its own fallback: fit it once
                    fb = (
                        params
                        if sel.fallback == sel.chosen
                        else sel.fitted.get(sel.fallback.name) or fit_candidate(sel.fallback, *data)
                    )
                    self.selections_[c] = sel.to_dict()
                else:
                    hyper = self.hyper_for(c, sp)
                    params = fit_params(self.method, hyper, xo, yo, codes, to)
                    fb = _cubic_fallback(xo, yo)
                    self.selections_[c] = None
            except (DesignError, ValueError, TypeError) as exc:
                raise ConfigError(f"{what}: {self.method} fit failed: {exc}") from None
            self.params_[c] = params
            self.fallbacks_[c] = fb
            k = n_inputs(params)
            self.train_range_[c] = np.column_stack(column_range(xo[:, :k]))
            constant = params["method"] == "poly-t" and len(params["coef"]) == 1
            self.domains_[c] = None if constant else fit_domain(xo[:, :k])
            resid = predict_params(params, xo) - yo
            sums = np.bincount(codes, weights=resid, minlength=len(feats.runs))
            cnts = np.bincount(codes, minlength=len(feats.runs))
            about = resid - (sums / np.maximum(cnts, 1))[codes]
            self.train_mean_[c] = float(np.mean(yo))
            self.metrics_[c] = {
                "rms_train": float(np.sqrt(np.mean(resid**2))),
                "rms_train_about_run_mean": float(np.sqrt(np.mean(about**2))),
                "n_train": float(ok.sum()),
                "n_outliers": float(feats.report.total(c)),
                "n_runs": float(np.count_nonzero(cnts)),
            }
            if on_channel is not None:
                on_channel(c)
        return self

    def to_file(self, source: Mapping[str, Any] | None = None) -> ThermalModelFile:
        """The fitted model as a model file object (save it with ``.save(path)``).

        Parameters
        ----------
        source : mapping, optional
            Extra provenance written under ``source`` (e.g. the log's file name).
        """
        if not hasattr(self, "params_"):
            raise ConfigError("the thermal model is not fitted yet")
        units, factors = unit_factors(self.meta_, self.channels)
        ref = site_reference(self.meta_, factors, self.channels)
        given = self.meta_.get("static_reference")
        if given == "mean":  # keep each channel's training mean level
            ref = {c: self.train_mean_[c] for c in self.channels}
        elif isinstance(given, Mapping):
            ref.update({c: float(v) for c, v in given.items() if c in ref})
        models = {}
        for c in self.channels:
            params = self.params_[c]
            edges = params.get("edges") if params["method"] == "sectional" else None
            if edges is None:
                edges = _edges_from(self.set_points_.get(c))
            models[c] = ChannelModel(
                params=params,
                train_range=self.train_range_[c],
                unit=units[c],
                unit_to_si=factors[c],
                static_reference=ref[c],
                segment_edges=None if edges is None else np.asarray(edges, dtype=np.float64),
                metrics=self.metrics_[c],
                domain=self.domains_[c],
                fallback=self.fallbacks_[c],
                selection=self.selections_[c],
            )
        src: dict[str, Any] = {"runs": list(self.features_.runs)}
        for key in (
            "latitude_deg",
            "heading_deg",
            "altitude_m",
            "protocol",
            "imu",
            "seed",
            "device_ids",
            "static_reference",
        ):
            if key in self.meta_:
                src[key] = self.meta_[key]
        src.update(source or {})
        return ThermalModelFile(
            method=self.method,
            channels=self.channels,
            models=models,
            derivative_kind=self.derivative.kind,
            derivative_window_s=self.derivative.window_s,
            use_gradient=self.features_.has_gradient,
            source=src,
            created_by=f"rinscal {__version__}",
        )


def _cubic_fallback(x: np.ndarray, y: np.ndarray) -> dict[str, Any] | None:
    """The T-only fallback of a fixed method: a cubic in T (None if T cannot carry one)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return fit_poly_t(x[:, :1], y, 3)
    except (DesignError, ValueError):
        return None
