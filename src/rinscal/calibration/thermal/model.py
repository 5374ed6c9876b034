"""Fit one thermal model per sensor channel on a calibration log.

:class:`ThermalFitter` holds one estimator (:mod:`rinscal.calibration.thermal.estimators`) per
channel, with the paper's defaults by sensor type:

=============  ==============================  ==============================
method         gyroscopes                      accelerometers
=============  ==============================  ==============================
``poly-t``     cubic in T                      cubic in T
``sectional``  G0, T, Ṫ per segment (3)        A0, T, T², T³, Ṫ, Ṫ², Ṫ³ (7)
``regression`` p = q = s = 1                   p = q = s = 3
``neural``     n = 2 hidden neurons            n = 6 hidden neurons
=============  ==============================  ==============================

It builds the features run by run, masks outliers, fits each channel on its inlier samples,
and produces a :class:`~rinscal.calibration.modelfile.FittedModel` (units, static
reference, training ranges and metrics included) with :meth:`ThermalFitter.to_file`.

Why one module: about 800 lines, one idea: fitting a log into a model file.
``ThermalFitter`` (the settings and the public ``fit``/``fit_runs``) and ``_Fitting`` (what
each channel keeps of each run and the final fit of each channel) are two halves of one
procedure that share their state; the unit and static-reference helpers at the top are the
model file's side of that fit.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from functools import partial
from typing import Any

import numpy as np
import pandas as pd

from rinscal import _check
from rinscal._version import __version__
from rinscal.calibration.inference import METHODS, n_inputs, predict_params
from rinscal.calibration.modelfile import AUTO, ChannelModel, FittedModel
from rinscal.calibration.selection import auto
from rinscal.calibration.selection.auto import DEFAULT_TOLERANCE, Selection, select_thinned
from rinscal.calibration.selection.candidates import (
    DEFAULT_FAMILIES,
    MAX_ORDERS,
    Candidate,
    candidates,
    fit_candidate,
    used_inputs,
)
from rinscal.calibration.thermal.dispatch import fit_params
from rinscal.calibration.thermal.features import (
    DerivativeConfig,
    Features,
    LogColumns,
    OutlierConfig,
    build_features,
    distinct_points,
    features_from_columns,
    gradient_choice,
    log_columns,
    run_features,
    run_index,
    run_slices,
)
from rinscal.calibration.thermal.fitting import (
    NEURAL_MAX_SAMPLES,
    one_blas_thread,
    rms_about_run_mean,
)
from rinscal.calibration.thermal.guards import (
    MIN_TEMP_SPAN_C,
    PLAUSIBLE_TEMP_C,
    DesignError,
    check_temperature_span,
    check_temperatures,
    warn_resolution,
)
from rinscal.calibration.thermal.runs import FACTOR_METHODS, FALLBACK_DEGREE, RowSample, RunFits
from rinscal.earth import static_outputs_r
from rinscal.errors import ConfigError, LogError
from rinscal.parallel import jobs_within, map_jobs, read_ahead, resolve_jobs
from rinscal.schema import (
    CHAMBER,
    CHANNELS,
    RUN,
    TEMP_OUT,
    TIME,
    sensor_type,
    temperature_column,
    unit_factors,
)
from rinscal.units import DEG_TO_RAD

__all__ = ["DEFAULTS", "FIT_METHODS", "ThermalFitter", "ThermalModel", "site_reference"]

#: Methods ``ThermalFitter`` fits: the paper's and the baseline, the field's own fits, and
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


def site_reference(
    meta: Mapping[str, Any] | None,
    factors: Mapping[str, float | None],
    channels: Sequence[str] = CHANNELS,
) -> dict[str, float | None]:
    """Static output (Earth rate, gravity) of a level IMU on the calibration table, log units.

    Uses :func:`rinscal.earth.static_outputs_r` with the metadata's ``latitude_deg``,
    ``heading_deg`` and optional ``altitude_m``.

    Returns
    -------
    dict of str to float or None
        None for a channel whose unit, or the site, is unknown.
    """
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


#: Memory one channel's features and factors of a run hold while they are built [bytes a
#: row] (measured: about 100 at 100 Hz, ``auto`` and ``regression`` alike).
_CHANNEL_BYTES_PER_ROW = 100


def _edges_from(points: np.ndarray | None) -> np.ndarray | None:
    if points is None or points.size < 2:
        return None
    return 0.5 * (points[1:] + points[:-1])


class ThermalFitter:
    """One thermal estimator per channel, fitted on a calibration log.

    Parameters
    ----------
    method : {"auto", "poly-t", "sectional", "regression", "neural", "px4", "ardupilot"}
        Model form; ``auto`` chooses each channel's by held-out error
        (:mod:`rinscal.calibration.selection.auto`).
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
        ``auto``: candidate families (see
        :data:`rinscal.calibration.selection.candidates.FAMILIES`).
    tolerance : float [dimensionless]
        ``auto``: relative excess of the held-out RMS over the best's within which the
        simpler model is taken, on top of the paired test
        (:mod:`rinscal.calibration.selection.rule`).
    temp_range : (float, float) [°C]
        Plausible temperature readings; a training log outside it is refused.
    n_jobs : int, optional
        Threads for the channels' features and run factors (the runs', in :meth:`fit`) and
        ``auto``'s choices; None or 0: every core; default 1 (a fitter in a study's or a
        fleet's fan-out adds none). The model does not depend on it, to the last bit.

    Attributes
    ----------
    params_ : dict of str to dict
        Fitted parameters per channel (see :mod:`rinscal.calibration.inference`).
    features_ : Features or None
        Training features of :meth:`fit` (kept for diagnostics; not written to the model
        file); None after :meth:`fit_runs`, which never holds the whole log.
    runs_ : tuple of str
        Training runs, in order.
    has_gradient_ : bool
        Whether the models use ``ΔT``.
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
        n_jobs: int | None = 1,
    ) -> None:
        if method not in FIT_METHODS:
            raise ConfigError(f"method must be one of {', '.join(FIT_METHODS)}, got {method!r}")
        # the types at the boundary (a public class): "1,1,0" is not three orders
        _check.numbers_of("orders", orders, optional=True, integer=True)
        _check.number("hidden", hidden, optional=True, integer=True, min=1)
        _check.numbers_of("edges", edges, optional=True)
        _check.strings("channels", channels)
        _check.strings("candidates", candidates)
        _check.number("tolerance", tolerance, min=0.0)
        _check.numbers_of("temp_range", temp_range, length=2)
        _check.number("random_state", random_state, min=0, integer=True)
        _check.mapping("estimator_params", estimator_params, optional=True)
        _check.flag("use_gradient", use_gradient, optional=True)
        self.n_jobs = resolve_jobs(
            _check.number("n_jobs", n_jobs, optional=True, integer=True, min=0)
        )
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
        # deferred: estimators imports scikit-learn (about 1 s); only this accessor needs it,
        # the fits themselves run on numpy (dispatch.fit_params)
        from rinscal.calibration.thermal.estimators import ALL_ESTIMATORS

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

    def _run_fits(self, channel: str, n_inputs: int) -> RunFits:
        """What this model keeps of each run for one channel (see :mod:`._runs`)."""
        if self.method == AUTO:
            # polynomial candidates are refitted from run factors; the held-out choice
            # scores every k-th row; a network (on request) keeps what `neural` keeps
            tools = [f for f in ("px4", "ardupilot") if f in self.candidates]
            return RunFits(
                AUTO,
                list(MAX_ORDERS[:n_inputs]),
                "neural" in self.candidates,
                NEURAL_MAX_SAMPLES,
                RowSample(auto.SCREEN_SAMPLES, tools),
            )
        hyper = self.hyper_for(channel)
        t_powers = FALLBACK_DEGREE
        powers = [0] * n_inputs
        if self.method == "regression":
            orders = [hyper["t_order"], hyper["rate_order"], hyper["grad_order"]][:n_inputs]
            powers = list(orders) + [0] * (n_inputs - len(orders))
        elif self.method == "poly-t":
            t_powers = max(t_powers, int(hyper["degree"]))
        powers[0] = max(powers[0], t_powers)
        step = None
        if self.method == "neural":  # the network decimates to max_samples rows anyway
            most = hyper.get("max_samples", NEURAL_MAX_SAMPLES)
            step = None if most is None else int(most)
        return RunFits(self.method, powers, self.method not in FACTOR_METHODS, step)

    def fit(
        self,
        log: pd.DataFrame,
        meta: Mapping[str, Any] | None = None,
        *,
        features: Features | None = None,
        on_channel: Callable[[str], None] | None = None,
        source: str | None = None,
    ) -> ThermalFitter:
        """Fit every channel.

        The log is taken run by run, as :meth:`fit_runs` takes a log read in pieces: the
        same model, to the last bit.

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
        ThermalFitter

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
        log = _check.log_table("log", log, validate=False)  # rows checked, not re-validated
        missing = [c for c in (RUN, TIME, *self.channels) if c not in log.columns]
        if missing:
            raise LogError(
                f"log has no column {', '.join(missing)}; give a calibration log "
                "(rinscal.read_log or rinscal.simulate)"
            )
        _check.mapping("meta", meta, optional=True)
        _check.callback("on_channel", on_channel)
        where = f"{source}: " if source else ""
        _, _, rows = run_slices(log[RUN])
        res = self._check_temperatures(log, rows, 0, where)  # before any feature is built
        with one_blas_thread():
            feats = features or build_features(
                log,
                self.derivative,
                self.outliers,
                self.channels,
                use_gradient=self.use_gradient,
                with_rate=self.needs_rate,
                n_jobs=self.n_jobs,
            )
            self.features_ = feats
            fitting = _Fitting(self, feats.has_gradient, where)
            fitting.add_features(fitting.add_runs(log, feats.runs, rows, res), feats, rows)
            return fitting.finish(meta, on_channel)

    def fit_runs(
        self,
        runs: Iterable[tuple[pd.DataFrame, int]],
        meta: Mapping[str, Any] | None = None,
        *,
        on_channel: Callable[[str], None] | None = None,
        source: str | None = None,
        on_run: Callable[[int], None] | None = None,
    ) -> ThermalFitter:
        """Fit every channel on a log given a run at a time, never holding it whole.

        Parameters
        ----------
        runs : iterable of (DataFrame, int)
            The log's runs in file order, validated, each whole (as
            :func:`rinscal.io.streaming.iter_log_source` yields them; a frame may hold several), and
            the data rows of the file before each (for messages).
        meta, on_channel, source
            As for :meth:`fit`.
        on_run : callable, optional
            Called with the number of runs taken so far, as each is (on the caller's thread;
            with ``n_jobs`` above 1 the next run is read on another).

        Returns
        -------
        ThermalFitter
            The model :meth:`fit` gives for the whole log.
        """
        where = f"{source}: " if source else ""
        fitting: _Fitting | None = None
        items = self._checked(runs, where)
        if self.n_jobs > 1:  # the next run read and checked on a thread while one is fitted
            items = read_ahead(items, 2)
        if self.needs_rate:  # meanwhile (the first run is read)
            # deferred: rate loads numba's kernels (as building the features does)
            from rinscal.calibration.thermal.rate import load_kernel

            load_kernel(self.derivative.kind)
        with one_blas_thread():
            taken = 0
            for log, (run_codes, names, rows), res, cols in items:  # no enumerate: its tuple
                taken += 1  # would hold this run while the next is taken
                if on_run is not None:
                    on_run(taken)
                # the missing-gradient warning once, not once per run
                grad = gradient_choice(log, self.use_gradient, warn=fitting is None)
                if fitting is None:
                    fitting = _Fitting(self, grad, where)
                elif grad != fitting.has_gradient:
                    raise ConfigError(f"{where}{TEMP_OUT!r} is in some runs and not in others")
                codes = fitting.add_runs(log, names, rows, res)
                del log  # its columns are in cols
                # the channels on threads, each building its features alone (as many as
                # 400 MB of their features hold)
                jobs = jobs_within(self.n_jobs, _CHANNEL_BYTES_PER_ROW * cols.time_s.size)
                map_jobs(partial(fitting.add_columns, codes, cols), self.channels, jobs)
                del cols, rows, run_codes  # not held while the next run is taken
            if fitting is None:
                raise ConfigError(f"{where}no runs to fit")
            self.features_ = None
            return fitting.finish(meta, on_channel)

    def _checked(self, runs: Iterable[tuple[pd.DataFrame, int]], where: str) -> Iterator[Any]:
        """Each run with its slices (:func:`run_slices`), its temperatures checked (their
        resolutions) and its columns (:func:`log_columns`): what a run needs before its
        channels, made where it is read."""
        for log, first_row in runs:
            slices = run_slices(log[RUN])  # once for every channel
            res = self._check_temperatures(log, slices[2], first_row, where)
            yield log, slices, res, log_columns(log, self.channels, slices=slices)
            del log

    def _check_temperatures(
        self, log: pd.DataFrame, rows: list[np.ndarray], first_row: int, where: str
    ) -> list[dict[str, float]]:
        """Plausible range of each run's temperatures (an error); their resolutions."""
        cols = list(dict.fromkeys(temperature_column(log, c) for c in self.channels))
        cols += [TEMP_OUT] if TEMP_OUT in log.columns else []
        temps = {c: log[c].to_numpy(dtype=np.float64) for c in cols}
        out = []
        for idx in rows:
            r = run_index(idx)
            try:
                out.append(
                    check_temperatures(
                        {c: v[r] for c, v in temps.items()},
                        self.temp_range,
                        rows=first_row + idx + 1,
                        warn=False,
                    )
                )
            except ValueError as exc:
                raise ConfigError(f"{where}{exc}") from None
        return out

    def to_file(self, source: Mapping[str, Any] | None = None) -> FittedModel:
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
        src: dict[str, Any] = {"runs": list(self.runs_)}
        for key in (
            "latitude_deg",
            "heading_deg",
            "altitude_m",
            "protocol",
            "imu",
            "seed",
            "device_ids",
            "autopilot",
            "instance",
            "autopilot_correction",
            "static_reference",
        ):
            if key in self.meta_:
                src[key] = self.meta_[key]
        src.update(source or {})
        return FittedModel(
            method=self.method,
            channels=self.channels,
            models=models,
            derivative_kind=self.derivative.kind,
            derivative_window_s=self.derivative.window_s,
            use_gradient=self.has_gradient_,
            source=src,
            created_by=f"rinscal {__version__}",
        )


class _Fitting:
    """A :class:`ThermalFitter`'s fit in progress: what it keeps of each run, then the models.

    Both :meth:`ThermalFitter.fit` (a whole log) and :meth:`ThermalFitter.fit_runs` (a log
    read a run at a time) hand it the same runs' features, so both give the same model.
    """

    def __init__(self, model: ThermalFitter, has_gradient: bool, where: str) -> None:
        self.model = model
        self.has_gradient = has_gradient
        self.where = where
        d = 3 if has_gradient else 2
        self.fits = {c: model._run_fits(c, d) for c in model.channels}
        self.runs: list[str] = []
        self.chamber: list[float] = []  # each run's median chamber temperature
        self.median_temp: list[np.ndarray] = []  # each run's median T of each channel
        self.outliers = np.zeros(len(model.channels), dtype=np.int64)
        self.resolution: dict[str, float] = {}
        self.tcol: dict[str, str] = {}

    def add_runs(
        self, log: pd.DataFrame, runs: Sequence[str], rows: list[np.ndarray], resolution: list
    ) -> list[int]:
        """Take in the runs of a log (or of a piece of one): names, chamber set points and
        temperature resolutions; the runs' codes, for :meth:`add_features`."""
        self.tcol = self.tcol or {c: temperature_column(log, c) for c in self.model.channels}
        chamber = log[CHAMBER].to_numpy(dtype=np.float64) if CHAMBER in log.columns else None
        codes = []
        for name, idx, res in zip(runs, rows, resolution, strict=True):
            if name in self.runs:
                raise ConfigError(f"{self.where}run {name!r} given twice")
            self.runs.append(name)
            codes.append(len(self.runs) - 1)
            if chamber is not None:
                self.chamber.append(float(np.median(chamber[idx])))
            self.median_temp.append(np.full(len(self.model.channels), np.nan))
            for c, v in res.items():
                self.resolution[c] = min(v, self.resolution.get(c, np.inf))
        return codes

    def add_columns(self, codes: list[int], cols: LogColumns, channel: str) -> None:
        """Take in one channel of runs ``codes``, its features built from their columns
        (reads nothing else: one thread per channel)."""
        m = self.model
        feats = features_from_columns(
            cols,
            m.derivative,
            m.outliers,
            (channel,),
            use_gradient=self.has_gradient,
            with_rate=m.needs_rate,
        )
        self.add_features(codes, feats, cols.rows)

    def add_features(self, codes: list[int], feats: Features, rows: list[np.ndarray]) -> None:
        """Take in the features of some channels (``feats.channels``) of runs ``codes``.

        The channels go to threads (``n_jobs`` of the model); each keeps its own fits, runs
        in order.
        """
        parts = [run_features(feats, k, idx) for k, idx in enumerate(rows)]

        def channel(jj: int) -> None:
            c = feats.channels[jj]
            j = self.model.channels.index(c)
            for code, f in zip(codes, parts, strict=True):
                if not self.chamber:  # set points from the runs' temperatures instead
                    self.median_temp[code][j] = np.median(f.temp[:, jj])
                self.outliers[j] += f.report.removed[0, jj]
                x = f.matrix(jj)
                ok = f.usable(jj, x)
                if ok.all():  # the usual case: no copies
                    self.fits[c].add(code, x, f.output[:, jj], f.time_s)
                else:
                    self.fits[c].add(code, x[ok], f.output[ok, jj], f.time_s[ok])

        map_jobs(channel, range(len(feats.channels)), self.model.n_jobs)

    def set_points(self, j: int) -> np.ndarray | None:
        """Soak set points: the runs' chamber medians, else their median ``T`` of channel j."""
        if self.chamber:
            sp = distinct_points(np.asarray(self.chamber))
            if sp.size >= 2:
                return sp
        pts = distinct_points(np.asarray([m[j] for m in self.median_temp]))
        return pts if pts.size >= 2 else None

    def finish(
        self, meta: Mapping[str, Any] | None, on_channel: Callable[[str], None] | None
    ) -> ThermalFitter:
        """Fit every channel from what the runs left; the fitted model."""
        m = self.model
        warn_resolution(self.resolution)
        m.meta_ = dict(meta or {})
        m.runs_ = tuple(self.runs)
        m.has_gradient_ = self.has_gradient
        m.params_ = {}
        m.set_points_ = {}
        m.train_range_ = {}
        m.metrics_ = {}
        m.domains_ = {}
        m.fallbacks_ = {}
        m.selections_ = {}
        m.train_mean_ = {}
        chosen = self._selections() if m.method == AUTO else {}
        for j, c in enumerate(m.channels):
            fits = self.fits[c]
            if fits.n < 2:
                raise ConfigError(f"{self.where}{c}: fewer than 2 usable samples to fit")
            sp = self.set_points(j)
            m.set_points_[c] = sp
            what = f"{self.where}{c} (T from column {self.tcol[c]!r}"
            what += f", ΔT = T − {TEMP_OUT})" if self.has_gradient else ")"
            try:
                check_temperature_span(*fits.range(1)[0], what)
            except ValueError as exc:
                raise ConfigError(str(exc)) from None
            try:
                params, fb, selection = self._fit_channel(c, fits, sp, chosen.get(c))
            except (DesignError, ValueError, TypeError) as exc:
                raise ConfigError(f"{what}: {m.method} fit failed: {exc}") from None
            m.params_[c] = params
            m.fallbacks_[c] = fb
            m.selections_[c] = selection
            k = n_inputs(params)
            m.train_range_[c] = fits.range(k)
            constant = params["method"] == "poly-t" and len(params["coef"]) == 1
            m.domains_[c] = None if constant else fits.domain(k)
            m.train_mean_[c] = fits.sum_y / fits.n
            m.metrics_[c] = self._metrics(params, fits) | {
                "n_train": float(fits.n),
                "n_outliers": float(self.outliers[j]),
                "n_runs": float(len(fits.counts)),
            }
            if on_channel is not None:
                on_channel(c)
        return m

    def _selections(self) -> dict[str, Selection | Exception | None]:
        """``auto``: each channel's held-out choice (most of the time of :meth:`finish`), the
        channels on threads (``n_jobs``).

        None for a channel that :meth:`finish` refuses before choosing (too few samples, too
        little temperature range); the error of a choice that failed, which :meth:`finish`
        raises in channel order.
        """
        m = self.model

        def one(c: str) -> Selection | Exception | None:
            fits = self.fits[c]
            if fits.n < 2 or not np.ptp(fits.range(1)[0]) >= MIN_TEMP_SPAN_C:
                return None
            assert fits.screen is not None
            x, y, codes, rows, t, tools = fits.screen.arrays()
            cands = candidates(sensor_type(c), x.shape[1], m.candidates)
            try:
                return select_thinned(
                    x, y, codes, rows, t, fits.screen.spans, tuple(self.runs), tools, cands,
                    m.tolerance, m.random_state,
                )  # fmt: skip
            except (DesignError, ValueError, TypeError) as exc:
                return exc

        # a choice holds about 200 bytes a kept row (945 000 rows at most): 2 at once in 400 MB
        kept = max((self.fits[c].screen.seen for c in m.channels), default=0)  # type: ignore[union-attr]
        jobs = jobs_within(m.n_jobs, 200 * min(kept, auto.SCREEN_SAMPLES))
        # the choice silences the fits it screens; catch_warnings is not thread-safe: one
        # here (the choice warns of nothing; the chosen fits' warnings come below, in order)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            done = map_jobs(one, m.channels, jobs)
        return dict(zip(m.channels, done, strict=True))

    def _fit_channel(
        self,
        c: str,
        fits: RunFits,
        sp: np.ndarray | None,
        sel: Selection | Exception | None = None,
    ) -> tuple[dict[str, Any], dict[str, Any] | None, dict[str, Any] | None]:
        """A channel's parameters, its T-only fallback and ``auto``'s selection record
        (``sel``: its held-out choice, :meth:`_selections`)."""
        m = self.model
        if m.method == AUTO:
            if isinstance(sel, Exception):
                raise sel
            assert isinstance(sel, Selection) and fits.screen is not None
            cands = candidates(sensor_type(c), len(fits.powers), m.candidates)
            params = self._fit_chosen(fits, sel, sel.chosen)
            # a chosen model of T alone is its own fallback: fit it once
            fb = params if sel.fallback == sel.chosen else self._fit_chosen(fits, sel, sel.fallback)
            record = sel.to_dict()
            record["flight"] = self._flight_fits(fits, sel, cands, {sel.chosen.name: params})
            return params, fb, record
        hyper = m.hyper_for(c, sp)
        if m.method == "regression":
            params = fits.regression(
                [hyper.get("t_order", 3), hyper.get("rate_order", 3), hyper.get("grad_order", 3)]
            )
        elif m.method == "poly-t":
            params = fits.poly_t(hyper.get("degree", 3), hyper.get("t_ref"))
        else:
            xo, yo, codes, to = fits.data()
            params = fit_params(m.method, hyper, xo, yo, codes, to)
        return params, _cubic_fallback(fits), None

    def _fit_chosen(self, fits: RunFits, sel: Selection, cand: Candidate) -> dict[str, Any]:
        """``auto``: the parameters of a chosen candidate on all the data.

        Polynomial candidates from the run factors (the fit of every row); the field's fits
        as the selection made them (on the rows it kept); a network on the rows kept for it.
        """
        if cand.name in sel.fitted:
            return sel.fitted[cand.name]
        if cand.method == "poly-t":
            return fits.poly_t(int(cand.params["degree"]))
        if cand.method == "regression":
            assert cand.orders is not None
            used = used_inputs(cand, len(fits.powers))
            return fits.regression(list(cand.orders[:used]))
        xo, yo, codes, to = fits.data()
        return fit_candidate(cand, xo, yo, codes, to, self.model.random_state)

    def _flight_fits(
        self,
        fits: RunFits,
        sel: Selection,
        cands: Sequence[Candidate],
        done: dict[str, dict[str, Any]],
    ) -> dict[str, dict[str, Any]]:
        """``auto``: every candidate PX4 and ArduPilot can hold that scored, fitted on all the
        data as :meth:`_fit_chosen` fits a chosen one (``done``: those already fitted).

        ``rinscal export --format px4|ardupilot`` exports a channel whose choice they cannot
        hold with the best of these by held-out RMS; each is what ``fit --method
        poly-t|px4|ardupilot`` gives the channel with the same settings.
        """
        scored = {r["name"] for r in sel.table if r["heldout_rms"] is not None}
        out: dict[str, dict[str, Any]] = {}
        for cand in cands:
            if not cand.flight or cand.name not in scored:
                continue
            if cand.name in done:
                out[cand.name] = done[cand.name]
                continue
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    out[cand.name] = self._fit_chosen(fits, sel, cand)
            except (DesignError, ValueError):
                continue
        return out

    @staticmethod
    def _metrics(params: dict[str, Any], fits: RunFits) -> dict[str, float]:
        """RMS of the training residual, and about each run's mean (Eq. 16)."""
        if params["method"] in FACTOR_METHODS and fits.factors:
            total, about, _ = fits.residual_ss(params)
            n = fits.n
            return {
                "rms_train": float(np.sqrt(total / n)),
                "rms_train_about_run_mean": float(np.sqrt(about / n)),
            }
        xo, yo, codes, _ = fits.data()
        resid = predict_params(params, xo) - yo
        return {
            "rms_train": float(np.sqrt(np.mean(resid**2))),
            "rms_train_about_run_mean": rms_about_run_mean(resid, codes),
        }


def _cubic_fallback(fits: RunFits) -> dict[str, Any] | None:
    """The T-only fallback of a fixed method: a cubic in T (None if T cannot carry one)."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return fits.poly_t(FALLBACK_DEGREE)
    except (DesignError, ValueError):
        return None


#: Old name of :class:`ThermalFitter` (the fitter, not the fitted model: that is
#: :class:`~rinscal.calibration.modelfile.FittedModel`), kept for one release.
ThermalModel = ThermalFitter
