"""The thermal model file: JSON, checksummed, validated on load, evaluated with numpy alone.

Layout (``schema_version`` 4; version 3 files, without ``selection.flight``, version 2 files,
without ``imu_calibration`` too, and version 1 files, without ``domain``, ``fallback`` and
``selection`` too, are still read)::

    {
      "format": "rinscal-thermal-model",
      "schema_version": 4,
      "sha256": "<hex digest of the canonical JSON of payload>",
      "payload": {
        "method": "regression",                 # poly-t | sectional | regression | neural
                                                # | px4 | ardupilot | auto (per channel)
        "created_by": "rinscal 0.1.0",
        "channels": ["gyro_x", ..., "accel_z"],
        "features": {
          "names": ["T", "Tdot", "dT"], "units": ["degC", "degC/min", "degC"],
          "use_gradient": true,                 # ΔT = T_inner − temp_out is an input
          "derivative": {"kind": "centred", "window_s": 60.0,
                         "estimator": "windowed least-squares slope"}
        },
        "source": {"runs": [...], "latitude_deg": 45.0, "heading_deg": 0.0},
        "channel_models": {
          "gyro_x": {
            "params": {...},                    # see rinscal.calibration.inference
            "unit": "deg/h", "unit_to_si": 4.85e-06,
            "static_reference": 7.3,            # Earth rate/gravity in log units, or null
            "train_range": {"T": [lo, hi], "Tdot": [lo, hi], "dT": [lo, hi]},
            "segment_edges": [3.5, ...],        # reference edges (set-point midpoints) or null
            "metrics": {"rms_train": ..., "rms_train_about_run_mean": ..., "n_train": ...,
                        "n_outliers": ..., "n_runs": ...},
            "domain": {"lo": [...], "hi": [...], "bins": [...], "runs": [[start, len], ...]},
                                                # joint (T, Ṫ, ΔT) occupancy grid, or null
            "fallback": {...},                  # params of the T-only model used outside
                                                # the domain (policy "fallback"), or null
            "selection": {...}                  # method auto: held-out table and choice, and
                                                # "flight": {candidate: params} of the
                                                # cubics PX4/ArduPilot hold, fitted on all data
          }, ...
        },
        "imu_calibration": null                 # or the IMU calibration applied first:
        # {"order": [...],                      # the order of application, in words
        #  "input": {"units": {"gyro_x": "pulse", ...}, "unit_to_si": {"gyro_x": ..., ...}},
        #  "output_units": {"gyro": "deg/h", "accel": "ug"},   # the channel models' unit
        #  "calibration": {"schema": "rinscal.imu-calibration/1", ...},
        #  "unit": {"imu": ...}}                # optional: the unit it was made on
      }
    }

With an IMU calibration (``rinscal fit --imu-cal``) the file is applied in one order
(:data:`rinscal.calibration.imustage.IMU_ORDER`): raw output × ``unit_to_si`` → SI; the
inverse sensor model (scale factor, nonlinear terms, misalignment at each channel's inner
temperature; biases left in) → deg/h and µg; then the thermal bias model, fitted on that
output. :attr:`FittedModel.imu_stage` holds it.

The checksum is the SHA-256 of ``json.dumps(payload, sort_keys=True, separators=(",", ":"),
ensure_ascii=True, allow_nan=False)``; floats are written in Python's shortest round-trip
form, so a saved and reloaded model predicts bit for bit the same. Nothing is pickled.

Loading checks everything (format, schema version, checksum, required keys, types, array
shapes, finite numbers, consistency) and raises :class:`~rinscal.errors.ModelFileError`
naming the file and the problem. Only numpy is needed to load and predict: this module
never imports scikit-learn.

Using a model (navigation and reproduction)
-------------------------------------------
>>> model = FittedModel.load("model.json")                        # doctest: +SKIP
>>> bias = model.predict_bias_si(temp_c, rate_c_per_min, temp_out_c)   # doctest: +SKIP

``temp_c`` (n, 6) or (n,) inner temperatures [°C], ``rate_c_per_min`` their rates
[°C/min] (a simulator's °C/s times 60), ``temp_out_c`` (n,) the outer temperature [°C]
(ignored by a model fitted without it). The result (n, 6) is the thermal bias in SI
(rad/s for gyros, m/s² for accelerometers): ``(f(T, Ṫ, ΔT) − static_reference) ·
unit_to_si``, i.e. the modelled output minus the Earth rate and gravity the IMU read on
the calibration table. The intercept also holds the mean turn-on offset of the
calibration runs.

Why one module: about 800 lines, one idea: the model file as a validated value. Its
layout, its validation on load (every key, type, shape and consistency check names the file
and the problem; a channel's entry is checked in :mod:`rinscal.calibration._modelcheck`) and
its numpy-only evaluation (input policies, the joint domain, ``predict_bias_si``) are one
contract; the numerics of each method live in :mod:`rinscal.calibration.inference`, the IMU
calibration's step in :mod:`rinscal.calibration.imustage`.
"""

from __future__ import annotations

import dataclasses
import json
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np

from rinscal._check import array, path_like, wrong_type
from rinscal._version import __version__
from rinscal.calibration._domain import inside_domain
from rinscal.calibration._modelcheck import (
    AUTO,
    CHANNELS,
    INPUT_NAMES,
    INPUT_UNITS,
    PAYLOAD_KEYS,
    PAYLOAD_KEYS_V2,
    RATE_ESTIMATOR,
    channel_fields,
    exact,
)
from rinscal.calibration.imustage import IMU_ORDER, PHYSICAL_UNITS, ImuStage
from rinscal.calibration.inference import METHODS, n_inputs, predict_params
from rinscal.errors import ConfigError, ModelFileError, RangeError
from rinscal.io.checksum import (  # shared with imu.json; payload_sha256 kept importable here
    checksum_problem,
    payload_sha256,
)
from rinscal.sensormodel import ImuCalibration

__all__ = [
    "FORMAT",
    "IMU_ORDER",
    "PHYSICAL_UNITS",
    "POLICIES",
    "SCHEMA_VERSION",
    "ChannelModel",
    "FittedModel",
    "ImuStage",
    "ThermalModelFile",
    "check_policy",
    "payload_sha256",
]

#: Value of the ``format`` key.
FORMAT = "rinscal-thermal-model"
#: Schema version written and read by this rinscal.
SCHEMA_VERSION = 4
#: Schema versions this rinscal reads.
READABLE_VERSIONS: tuple[int, ...] = (1, 2, 3, 4)
#: What to do with inputs outside the training data: ``clamp`` each input to its range,
#: ``fallback`` to the channel's T-only model outside the joint domain, ``extrapolate``,
#: ``error``.
POLICIES: tuple[str, ...] = ("clamp", "fallback", "extrapolate", "error")


def check_policy(policy: str) -> None:
    """Refuse an out-of-range policy that is not one of :data:`POLICIES`.

    Raises
    ------
    ConfigError
        Naming the policies (a :class:`ValueError` too).
    """
    if not isinstance(policy, str):
        raise wrong_type("policy", policy, f"one of {', '.join(POLICIES)}")
    if policy not in POLICIES:
        raise ConfigError(f"policy must be one of {', '.join(POLICIES)}, got {policy!r}")


Policy = Literal["clamp", "fallback", "extrapolate", "error"]


@dataclass(frozen=True)
class ChannelModel:
    """The fitted model of one channel, as stored in a model file.

    Attributes
    ----------
    params : dict
        Plain parameters (see :mod:`rinscal.calibration.inference`).
    train_range : ndarray, shape (k, 2)
        ``[min, max]`` of each input used (``T`` [°C], ``Ṫ`` [°C/min], ``ΔT`` [°C]) over the
        training samples.
    unit : str or None
        Unit of the channel's output in the log (e.g. ``"deg/h"``, ``"ug"``, ``"pulse"``).
    unit_to_si : float or None
        SI value of one log unit [rad/s or m/s² per unit].
    static_reference : float or None [log units]
        Earth rate or gravity component this channel read at rest on the calibration table.
    segment_edges : ndarray or None [°C]
        Temperatures where a segment ends (the sectional model's edges; for the other
        methods the midpoints between the calibration set points), for step checks.
    metrics : dict
        Training metrics.
    domain : dict or None
        Joint domain of the training inputs (:mod:`rinscal.calibration._domain`).
    fallback : dict or None
        Parameters of a T-only model (``poly-t``, ``px4`` or ``ardupilot``) used, with ``T``
        clamped to its training range, outside the domain under policy ``fallback``.
    selection : dict or None
        How ``fit --method auto`` chose this channel's model: ``scheme`` and ``folds`` of
        the held-out check, ``tolerance`` [dimensionless: relative excess of the held-out
        RMS, :mod:`rinscal.calibration.selection.rule`; of the mean square error in files
        written before it, 0 by default in both], ``chosen`` and ``fallback`` (candidate names),
        ``table`` (one row per candidate: ``name``, ``method``, ``n_params``,
        ``heldout_rms``, ``fold_rms``, ``train_rms``) and, from schema version 4, ``flight``
        (candidate name → parameters on all the data of every scored candidate PX4 and
        ArduPilot can hold: ``none``, ``poly-t`` of degree ≤ 3, ``px4``, ``ardupilot``; what
        ``rinscal export`` writes for a channel whose choice they cannot hold).
    """

    params: dict[str, Any]
    train_range: np.ndarray
    unit: str | None = None
    unit_to_si: float | None = None
    static_reference: float | None = None
    segment_edges: np.ndarray | None = None
    metrics: dict[str, float] = field(default_factory=dict)
    domain: dict[str, Any] | None = None
    fallback: dict[str, Any] | None = None
    selection: dict[str, Any] | None = None

    @property
    def n_inputs(self) -> int:
        """Number of inputs the model uses (1: T; 2: T, Ṫ; 3: T, Ṫ, ΔT)."""
        return n_inputs(self.params)

    def to_dict(self) -> dict[str, Any]:
        """JSON-able form."""
        k = self.n_inputs
        return {
            "params": self.params,
            "unit": self.unit,
            "unit_to_si": self.unit_to_si,
            "static_reference": self.static_reference,
            "train_range": {
                INPUT_NAMES[i]: [float(self.train_range[i, 0]), float(self.train_range[i, 1])]
                for i in range(k)
            },
            "segment_edges": None
            if self.segment_edges is None
            else [float(e) for e in self.segment_edges],
            "metrics": {key: float(v) for key, v in self.metrics.items()},
            "domain": self.domain,
            "fallback": self.fallback,
            "selection": self.selection,
        }


@dataclass(frozen=True)
class FittedModel:
    """A fitted thermal model of several channels, as read from or written to a model file.

    Attributes
    ----------
    method : str
        ``poly-t``, ``sectional``, ``regression``, ``neural``, ``px4``, ``ardupilot``, or
        ``auto`` (each channel's own method is in its ``params``).
    channels : tuple of str
        Channels modelled, the column order of :meth:`predict`.
    models : dict of str to ChannelModel
        One model per channel.
    derivative_kind : {"centred", "causal"}
        Temperature-rate estimator used for training.
    derivative_window_s : float [s]
        Its window.
    use_gradient : bool
        Whether ``ΔT`` is an input.
    source : dict
        Training runs, latitude and heading of the calibration table, log name.
    created_by : str
        Producer.
    imu_stage : ImuStage or None
        The IMU calibration applied before the thermal model (:data:`IMU_ORDER`); the
        channel models are then in deg/h and µg.
    """

    method: str
    channels: tuple[str, ...]
    models: dict[str, ChannelModel]
    derivative_kind: str = "centred"
    derivative_window_s: float = 60.0
    use_gradient: bool = True
    source: dict[str, Any] = field(default_factory=dict)
    created_by: str = f"rinscal {__version__}"
    imu_stage: ImuStage | None = None

    def __post_init__(self) -> None:
        # a model built in code is checked as one read from a file is (_from_payload)
        if not isinstance(self.method, str) or self.method not in (*METHODS, AUTO):
            raise ConfigError(
                f"method: unknown method {self.method!r}; "
                f"expected one of {', '.join((*METHODS, AUTO))}"
            )
        chans = self.channels
        if (
            isinstance(chans, str)
            or not chans
            or not all(isinstance(c, str) and c in CHANNELS for c in chans)
            or len(set(chans)) != len(chans)
        ):
            raise ConfigError(f"channels must be distinct names among {CHANNELS}, got {chans!r}")
        missing = [c for c in chans if c not in self.models]
        if missing:
            raise ConfigError(f"models: no model for channel(s) {', '.join(missing)}")

    @property
    def imu_calibration(self) -> ImuCalibration | None:
        """The IMU calibration applied before the thermal bias model, or None."""
        return None if self.imu_stage is None else self.imu_stage.calibration

    def with_imu(self, stage: ImuStage | None) -> FittedModel:
        """A copy with ``stage`` as its IMU calibration (None: the thermal model alone).

        Raises
        ------
        ModelFileError
            A channel model not in deg/h or µg (the unit behind an IMU calibration).
        """
        if stage is not None:
            for c in self.channels:
                unit = self.models[c].unit
                if unit != PHYSICAL_UNITS[c.partition("_")[0]]:
                    raise ModelFileError(
                        f"the thermal model of {c} is in {unit!r}: behind an IMU calibration it "
                        f"must be fitted in {PHYSICAL_UNITS} (fit --imu-cal does so)"
                    )
        return dataclasses.replace(self, imu_stage=stage)

    # ------------------------------------------------------------------ serialisation

    def payload(self) -> dict[str, Any]:
        """The JSON-able payload (what the checksum covers)."""
        k = 3 if self.use_gradient else 2
        return {
            "method": self.method,
            "created_by": self.created_by,
            "channels": list(self.channels),
            "features": {
                "names": list(INPUT_NAMES[:k]),
                "units": list(INPUT_UNITS[:k]),
                "use_gradient": bool(self.use_gradient),
                "derivative": {
                    "kind": self.derivative_kind,
                    "window_s": float(self.derivative_window_s),
                    "estimator": RATE_ESTIMATOR,
                },
            },
            "source": self.source,
            "channel_models": {c: self.models[c].to_dict() for c in self.channels},
            "imu_calibration": None if self.imu_stage is None else self.imu_stage.to_dict(),
        }

    def to_dict(self) -> dict[str, Any]:
        """The whole document: format, schema version, checksum and payload."""
        payload = self.payload()
        try:
            digest = payload_sha256(payload)
        except ValueError as exc:  # NaN or inf somewhere
            raise ModelFileError(f"model cannot be written: {exc}") from None
        return {
            "format": FORMAT,
            "schema_version": SCHEMA_VERSION,
            "sha256": digest,
            "payload": payload,
        }

    def dumps(self) -> str:
        """The model file's text (indented JSON)."""
        return json.dumps(self.to_dict(), indent=1, allow_nan=False) + "\n"

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write the model file atomically (temporary file in the same folder, then rename).

        Parameters
        ----------
        path : path-like
            Destination ``.json`` file.

        Returns
        -------
        Path
        """
        # deferred: the io package's other modules are not needed to load a model
        from rinscal.io.atomic import write_atomic

        p = path_like("path", path)
        text = self.dumps()
        if not p.parent.is_dir():
            raise ModelFileError(f"{p}: folder {p.parent} does not exist")
        write_atomic(p, lambda tmp: tmp.write_text(text, encoding="utf-8"))
        return p

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> FittedModel:
        """Read and validate a model file.

        Raises
        ------
        ModelFileError
            Naming the file and the problem (missing, not JSON, truncated, tampered, wrong
            version, missing key, wrong shape, non-finite number, inconsistent content).
        """
        p = path_like("path", path)
        try:
            raw = p.read_bytes()
        except FileNotFoundError:
            raise ModelFileError(f"{p}: no such model file") from None
        except IsADirectoryError:
            raise ModelFileError(f"{p}: is a folder, not a model file") from None
        except OSError as exc:
            raise ModelFileError(f"{p}: cannot read model file: {exc}") from None
        return cls.loads(raw, source=str(p))

    @classmethod
    def loads(cls, text: str | bytes, source: str = "<model>") -> FittedModel:
        """Parse and validate the text of a model file (see :meth:`load`)."""
        if isinstance(text, bytes):
            try:
                text = text.decode("utf-8")
            except UnicodeDecodeError as exc:
                raise ModelFileError(
                    f"{source}: not a model file (not UTF-8 text: {exc})"
                ) from None

        def _no_constants(name: str) -> Any:
            raise ValueError(f"non-finite number {name}")

        try:
            doc = json.loads(text, parse_constant=_no_constants)
        except json.JSONDecodeError as exc:
            raise ModelFileError(
                f"{source}: not valid JSON ({exc.msg} at line {exc.lineno}, column "
                f"{exc.colno}); the file is truncated or not a model file"
            ) from None
        except (ValueError, RecursionError) as exc:
            raise ModelFileError(f"{source}: invalid JSON: {exc}") from None
        return cls.from_dict(doc, source=source)

    @classmethod
    def from_dict(cls, doc: Any, source: str = "<model>") -> FittedModel:
        """Validate a parsed model document and build the model (see :meth:`load`)."""

        def bad(msg: str) -> ModelFileError:
            return ModelFileError(f"{source}: {msg}")

        if not isinstance(doc, dict):
            raise bad(f"not a model file: top level is a JSON {type(doc).__name__}, not an object")
        if doc.get("format") != FORMAT:
            raise bad(f"not a rinscal thermal model file (format {doc.get('format')!r})")
        version = doc.get("schema_version")
        if isinstance(version, bool) or not isinstance(version, int):
            raise bad(f"schema_version must be an integer, got {version!r}")
        if version not in READABLE_VERSIONS:
            raise bad(
                f"unsupported schema_version {version} (this rinscal reads "
                f"{', '.join(map(str, READABLE_VERSIONS))}); refit the model or use a matching "
                "rinscal"
            )
        for key in ("sha256", "payload"):
            if key not in doc:
                raise bad(f"missing key {key!r}")
        extra = set(doc) - {"format", "schema_version", "sha256", "payload"}
        if extra:
            raise bad(f"unexpected top-level key(s) {sorted(extra)}")
        payload = doc["payload"]
        if not isinstance(payload, dict):
            raise bad("payload must be a JSON object")
        problem = checksum_problem(doc["sha256"], payload)
        if problem is not None:
            raise bad(problem)
        try:
            return cls._from_payload(payload, version)
        except (ValueError, TypeError, KeyError) as exc:
            raise bad(f"invalid model: {exc}") from None

    @classmethod
    def _from_payload(cls, p: dict[str, Any], version: int = SCHEMA_VERSION) -> FittedModel:
        def req(d: Mapping[str, Any], key: str, where: str) -> Any:
            if not isinstance(d, Mapping):
                raise ValueError(f"{where} must be a JSON object")
            if key not in d:
                raise ValueError(f"missing key {where}.{key}")
            return d[key]

        exact(p, PAYLOAD_KEYS if version >= 3 else PAYLOAD_KEYS_V2, "payload")
        method = req(p, "method", "payload")
        if method not in (*METHODS, AUTO):
            raise ValueError(
                f"unknown method {method!r}; expected one of {', '.join((*METHODS, AUTO))}"
            )
        channels = req(p, "channels", "payload")
        if (
            not isinstance(channels, list)
            or not channels
            or not all(isinstance(c, str) and c in CHANNELS for c in channels)
            or len(set(channels)) != len(channels)
        ):
            raise ValueError(f"channels must be distinct names among {CHANNELS}, got {channels!r}")
        created_by = p["created_by"]
        if not isinstance(created_by, str):
            raise ValueError("created_by must be text")
        feats = req(p, "features", "payload")
        exact(feats, ("names", "units", "use_gradient", "derivative"), "features")
        use_gradient = req(feats, "use_gradient", "features")
        if not isinstance(use_gradient, bool):
            raise ValueError("features.use_gradient must be true or false")
        k = 3 if use_gradient else 2
        if req(feats, "names", "features") != list(INPUT_NAMES[:k]):
            raise ValueError(f"features.names must be {list(INPUT_NAMES[:k])}")
        if req(feats, "units", "features") != list(INPUT_UNITS[:k]):
            raise ValueError(f"features.units must be {list(INPUT_UNITS[:k])}")
        deriv = req(feats, "derivative", "features")
        exact(deriv, ("kind", "window_s", "estimator"), "features.derivative")
        if deriv["estimator"] != RATE_ESTIMATOR:
            raise ValueError(f"features.derivative.estimator must be {RATE_ESTIMATOR!r}")
        kind = req(deriv, "kind", "features.derivative")
        if kind not in ("centred", "causal"):
            raise ValueError(f"features.derivative.kind must be centred or causal, got {kind!r}")
        window = req(deriv, "window_s", "features.derivative")
        if (
            isinstance(window, bool)
            or not isinstance(window, (int, float))
            or not (np.isfinite(window) and window > 0)
        ):
            raise ValueError(
                f"features.derivative.window_s must be a positive number, got {window!r}"
            )
        source = p["source"]
        if not isinstance(source, dict):
            raise ValueError("source must be a JSON object")
        cms = req(p, "channel_models", "payload")
        if not isinstance(cms, dict) or set(cms) != set(channels):
            raise ValueError("channel_models must hold exactly one entry per channel")
        models = {}
        for c in channels:
            models[c] = ChannelModel(**channel_fields(cms[c], c, method, k, version))
        imu = p.get("imu_calibration")
        stage = None if imu is None else ImuStage.from_dict(imu)
        return cls(
            method=method,
            channels=tuple(channels),
            models=models,
            derivative_kind=kind,
            derivative_window_s=float(window),
            use_gradient=use_gradient,
            source=source,
            created_by=created_by,
        ).with_imu(stage)

    # ------------------------------------------------------------------ inference

    @property
    def n_features(self) -> int:
        """Feature columns the model expects: 3 with ``ΔT``, else 2."""
        return 3 if self.use_gradient else 2

    def feature_matrix(
        self,
        channel: str,
        temp: np.ndarray,
        rate: np.ndarray,
        temp_out: np.ndarray | None = None,
    ) -> np.ndarray:
        """Feature matrix of one channel from its temperature, rate and the outer temperature.

        Parameters
        ----------
        channel : str
            Channel name (its inner temperature is ``temp`` itself).
        temp : ndarray, shape (n,) [°C]
            Inner temperature of the channel.
        rate : ndarray, shape (n,) [°C/min]
            Its rate.
        temp_out : ndarray, shape (n,), optional [°C]
            Outer temperature; required if the model uses ``ΔT``.

        Returns
        -------
        ndarray, shape (n, n_features)
        """
        temp = np.asarray(temp, dtype=np.float64).reshape(-1)
        rate = np.broadcast_to(np.asarray(rate, dtype=np.float64), temp.shape)
        if not self.use_gradient or self.models[channel].n_inputs < 3:
            return np.column_stack([temp, rate])
        if temp_out is None:
            raise ModelFileError(
                f"the {self.method} model of {channel} uses the gradient ΔT = T − temp_out: "
                "give the outer temperature temp_out"
            )
        tout = np.broadcast_to(np.asarray(temp_out, dtype=np.float64).reshape(-1), temp.shape)
        return np.column_stack([temp, rate, temp - tout])

    def apply_policy(
        self, channel: str, x: np.ndarray, policy: Policy = "extrapolate"
    ) -> tuple[np.ndarray, np.ndarray]:
        """Flag (and clamp, or refuse) inputs outside the training data of one channel.

        A sample is flagged when an input the model uses lies outside its training range, or
        when the combination lies outside the joint domain of the training data (the
        channel's ``domain``, when the file has one).

        Parameters
        ----------
        channel : str
            Channel.
        x : ndarray, shape (n, k)
            Feature matrix.
        policy : {"clamp", "fallback", "extrapolate", "error"}
            ``clamp`` clips every input to its training range (and ``fallback`` too, for the
            samples it keeps on the model), ``extrapolate`` evaluates the model as it is,
            ``error`` raises :class:`~rinscal.errors.RangeError` at the first flagged sample.

        Returns
        -------
        x : ndarray, shape (n, k)
            The inputs to evaluate.
        flagged : ndarray of bool, shape (n,)
            True where the sample lies outside the training data.
        """
        check_policy(policy)
        cm = self.models[channel]
        k = cm.n_inputs
        lo, hi = cm.train_range[:k, 0], cm.train_range[:k, 1]
        xs = x[:, :k]
        outside = np.zeros(x.shape[0], dtype=bool)
        for v in range(k):  # column by column: several times faster than axis=1 on (n, 3)
            outside |= (xs[:, v] < lo[v]) | (xs[:, v] > hi[v])
        flags = outside.copy()
        if cm.domain is not None:
            flags |= ~inside_domain(cm.domain, xs)
        if policy == "error" and flags.any():
            i = int(np.argmax(flags))
            unit = (" °C", " °C/min", " °C")
            which = [
                f"{INPUT_NAMES[j]} = {xs[i, j]:.6g}{unit[j]} outside "
                f"[{lo[j]:.6g}, {hi[j]:.6g}]{unit[j]}"
                for j in range(k)
                if not lo[j] <= xs[i, j] <= hi[j]
            ]
            if not which:
                point = ", ".join(f"{INPUT_NAMES[j]} = {xs[i, j]:.6g}{unit[j]}" for j in range(k))
                which = [f"({point}) outside the joint domain of the training data"]
            what = (
                f"{', '.join(which)} (the training data; {int(flags.sum())} row(s) flagged); "
                "use policy clamp, fallback or extrapolate to compensate anyway"
            )
            err = RangeError(f"{channel}: input row {i + 1} has {what}")
            err.row = i  # type: ignore[attr-defined]
            err.what = what  # type: ignore[attr-defined]
            raise err
        if policy in ("clamp", "fallback") and outside.any():
            x = x.copy()
            x[:, :k] = np.clip(xs, lo, hi)
        return x, flags

    def predict_channel(
        self, channel: str, x: np.ndarray, policy: Policy = "extrapolate"
    ) -> tuple[np.ndarray, np.ndarray]:
        """Modelled output of one channel from its feature matrix.

        Parameters
        ----------
        channel : str
            Channel.
        x : ndarray, shape (n, k)
            ``T`` [°C], ``Ṫ`` [°C/min] and, if used, ``ΔT`` [°C].
        policy : {"clamp", "fallback", "extrapolate", "error"}
            Handling of samples outside the training data (see :meth:`apply_policy`);
            ``fallback`` evaluates the channel's T-only fallback model (``T`` clamped to
            its training range) on the flagged samples.

        Returns
        -------
        f : ndarray, shape (n,) [log units]
            ``f(T, Ṫ, ΔT)``.
        flagged : ndarray of bool, shape (n,)
        """
        if channel not in self.models:
            raise ModelFileError(f"the model has no channel {channel!r} (it has {self.channels})")
        cm = self.models[channel]
        if policy == "fallback" and cm.fallback is None:
            raise ModelFileError(
                f"the model of {channel} has no fallback model (written by an older rinscal); "
                "refit it, or use policy clamp"
            )
        x = np.asarray(x, dtype=np.float64)
        x, flags = self.apply_policy(channel, x, policy)
        f = predict_params(cm.params, x)
        if policy == "fallback" and flags.any() and cm.fallback is not None:
            t = np.clip(x[flags, :1], cm.train_range[0, 0], cm.train_range[0, 1])
            f[flags] = predict_params(cm.fallback, t)
        return f, flags

    def _inputs(self, temp: Any, rate: Any) -> tuple[np.ndarray, np.ndarray]:
        m = len(self.channels)
        t = array("temp", temp)  # a wrong type is named here, not by numpy inside
        r = array("rate", rate)
        if t.ndim == 1:
            t = np.repeat(t[:, None], m, axis=1)
        if r.ndim == 1:
            r = np.repeat(r[:, None], m, axis=1)
        if t.ndim != 2 or t.shape[1] != m or r.shape != t.shape:
            raise ConfigError(
                f"temp and rate must have shape (n,) or (n, {m}); got {np.shape(temp)} and "
                f"{np.shape(rate)}"
            )
        return t, r

    def predict(
        self,
        temp: Any,
        rate: Any,
        temp_out: Any = None,
        *,
        policy: Policy = "extrapolate",
    ) -> np.ndarray:
        """Modelled output of every channel, in log units.

        Parameters
        ----------
        temp : array_like, shape (n, m) or (n,) [°C]
            Inner temperature per channel (one column per channel in :attr:`channels`
            order), or one temperature shared by all.
        rate : array_like, same shape [°C/min]
            Temperature rate.
        temp_out : array_like, shape (n,), optional [°C]
            Outer temperature (needed when :attr:`use_gradient`).
        policy : {"clamp", "fallback", "extrapolate", "error"}
            Handling of samples outside the training data.

        Returns
        -------
        ndarray, shape (n, m) [log units]
        """
        t, r = self._inputs(temp, rate)
        out = np.empty_like(t)
        for j, c in enumerate(self.channels):
            x = self.feature_matrix(c, t[:, j], r[:, j], temp_out)
            out[:, j] = self.predict_channel(c, x, policy)[0]
        return out

    def predict_bias_si(
        self,
        temp: Any,
        rate: Any,
        temp_out: Any = None,
        *,
        policy: Policy = "extrapolate",
    ) -> np.ndarray:
        """Modelled thermal bias of every channel in SI: ``(f − static_reference) · unit_to_si``.

        Parameters
        ----------
        temp : array_like, shape (n, m) or (n,) [°C]
            Inner temperature per channel, or shared.
        rate : array_like, same shape [°C/min]
            Temperature rate (°C/s × 60).
        temp_out : array_like, shape (n,), optional [°C]
            Outer temperature.
        policy : {"clamp", "fallback", "extrapolate", "error"}
            Handling of samples outside the training data.

        Returns
        -------
        ndarray, shape (n, m) [rad/s for gyros, m/s² for accelerometers]
            The bias: model output minus the Earth rate or gravity component read on the
            calibration table. It holds the thermal bias plus the mean turn-on offset of the
            calibration runs.

        Raises
        ------
        ModelFileError
            When the file lacks the unit or the static reference of a channel (the log had
            no metadata with units, latitude and heading).
        """
        k = self.si_factors()
        f = self.predict(temp, rate, temp_out, policy=policy)
        ref = np.array([self.models[c].static_reference for c in self.channels])
        return (f - ref) * k

    def si_factors(self) -> np.ndarray:
        """SI value of one log unit per channel [rad/s or m/s² per unit], for a bias in SI.

        Raises
        ------
        ModelFileError
            When the file lacks the unit or the static reference of a channel (the log had
            no metadata with units, latitude and heading): its bias in SI is then unknown.
        """
        for c in self.channels:
            cm = self.models[c]
            if cm.unit_to_si is None or cm.static_reference is None:
                missing = "unit" if cm.unit_to_si is None else "static_reference"
                raise ModelFileError(
                    f"model of {c} has no {missing} (the calibration log had no metadata with "
                    "units, latitude_deg and heading_deg); predict() gives the full output in "
                    "log units"
                )
        return np.array([self.models[c].unit_to_si for c in self.channels], dtype=np.float64)

    def subset(self, channels: Sequence[str]) -> FittedModel:
        """The same model restricted to some of its channels (e.g. one at a time)."""
        unknown = [c for c in channels if c not in self.models]
        if unknown:
            raise ModelFileError(f"the model has no channel(s) {unknown} (it has {self.channels})")
        return dataclasses.replace(
            self, channels=tuple(channels), models={c: self.models[c] for c in channels}
        )

    def with_static_reference(
        self, reference: Mapping[str, float], unit_to_si: Mapping[str, float] | None = None
    ) -> FittedModel:
        """A copy with the static reference (and units) of some channels set."""
        models = dict(self.models)
        for c, v in reference.items():
            cm = models[c]
            k = cm.unit_to_si if unit_to_si is None else float(unit_to_si[c])
            models[c] = dataclasses.replace(cm, unit_to_si=k, static_reference=float(v))
        return FittedModel(
            method=self.method,
            channels=self.channels,
            models=models,
            derivative_kind=self.derivative_kind,
            derivative_window_s=self.derivative_window_s,
            use_gradient=self.use_gradient,
            source=self.source,
            created_by=self.created_by,
            imu_stage=self.imu_stage,
        )


#: Old name of :class:`FittedModel` (the fitted model), kept for one release.
ThermalModelFile = FittedModel
