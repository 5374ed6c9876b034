"""Navigate a simulated cold start with and without thermal models: the library side of
``rinscal navigate --scenario`` (a recording: :func:`rinscal.nav.recording.navigate_log`).

:func:`navigate` builds the plant (the IMU preset or TOML file), the scenario (Section 5.2 of
the paper: quasi-static, swing, vehicle, ramp), the alignment and one compensator per
variant (none, the true thermal bias, each model), runs it and returns a
:class:`Navigation`: the error series of every variant, the truth, the summary that
``summary.json`` holds, and the thermometer readings. It prints nothing; it writes only the
raw recording when asked (``record=``), streamed as it is simulated.
"""

from __future__ import annotations

import inspect
import os
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rinscal import _check
from rinscal.calibration.modelfile import FittedModel, check_policy
from rinscal.errors import ConfigError
from rinscal.nav.engine import Navigation
from rinscal.nav.rotation import schedule_from_name
from rinscal.presets import DEFAULT_PRESET
from rinscal.sim.config import ImuConfig, resolve_imu
from rinscal.sim.disturbance import DisturbedStart
from rinscal.sim.scenario import NavResult, align_for, daily_ambient, preset, run_scenario
from rinscal.sim.scenario_config import ScenarioConfig
from rinscal.sim.sensors import (
    ModelCompensator,
    ThermalPlant,
    oracle_compensator,
    temperature_frame,
)
from rinscal.sim.trajectory import StaticMotion

__all__ = [
    "Navigation",
    "check_models",
    "model_compensator",
    "navigate",
    "navigate_scenario",
    "recording",
    "recording_meta",
]

ModelLike = str | os.PathLike[str] | FittedModel
#: The lowest IMU rate a disturbed start is simulated at [Hz]: its 1-3 Hz sway must be
#: resolved by each sample's 4-point quadrature.
MIN_DISTURBED_RATE_HZ = 50.0
#: What ``record=`` may be named (the log formats of :data:`rinscal.io.tables.FORMATS`).
RECORD_SUFFIXES = (".parquet", ".pq", ".csv", ".tsv")


def model_compensator(model: ModelLike, plant: ThermalPlant, policy: str = "clamp") -> Any:
    """A :class:`rinscal.sim.sensors.ModelCompensator` of a model (a file's path or loaded).

    Parameters
    ----------
    model : str, PathLike or FittedModel
        The thermal model.
    plant : ThermalPlant
        The plant whose thermometers feed the model.
    policy : {"clamp", "fallback", "extrapolate", "error"}
        Out-of-range handling of the model inputs.
    """
    mf = model if isinstance(model, FittedModel) else FittedModel.load(model)
    return ModelCompensator(mf, plant, policy=policy)


def check_models(models: Any) -> None:
    """Refuse ``models`` that are neither a mapping nor a sequence of models (a single
    path would be read as its characters), naming the argument and the bad entry."""
    accepted = "a list of model files (or loaded models) or a dict of name to model"
    if isinstance(models, str | os.PathLike | FittedModel):
        raise _check.wrong_type("models", models, accepted + f", e.g. [{models!r}]")
    _check.instance("models", models, (Mapping, Sequence), accepted)
    items = models.items() if isinstance(models, Mapping) else enumerate(models)
    for key, m in items:
        model_accepted = "a model file's path (str or os.PathLike) or a loaded model"
        _check.instance(f"models[{key!r}]", m, (str, os.PathLike, FittedModel), model_accepted)


def _named_models(models: Mapping[str, ModelLike] | Sequence[ModelLike]) -> dict[str, ModelLike]:
    """Variant names: a mapping's keys, else each file's stem (``_`` appended to repeats)."""
    if isinstance(models, Mapping):
        return dict(models)
    named: dict[str, ModelLike] = {}
    for k, m in enumerate(models):
        name = f"model{k + 1}" if isinstance(m, FittedModel) else Path(m).stem
        while name in named or name in ("none", "true"):
            name += "_"
        named[name] = m
    return named


def navigate_scenario(
    scenario: str | ScenarioConfig = "quasi-static",
    *,
    imu: str | os.PathLike[str] | ImuConfig = DEFAULT_PRESET,
    models: Mapping[str, ModelLike] | Sequence[ModelLike] = (),
    hours: float | None = None,
    rate_hz: float = 100.0,
    seed: int = 0,
    rotation: str = "four-position",
    align_s: float = 600.0,
    align_start_s: float = 0.0,
    oracle: bool = True,
    policy: str = "clamp",
    record: str | os.PathLike[str] | None = None,
    increments: bool = False,
    quantise: bool | None = None,
    disturbed_start_min: float | None = None,
    ambient_c: float | None = None,
    daily_cycle_c: float = 0.0,
    progress: Callable[[float, float], None] | None = None,
    n_jobs: int | None = None,
) -> Navigation:
    """Navigate a single-axis RINS through a simulated cold start, per compensation variant.

    Parameters
    ----------
    scenario : str or ScenarioConfig
        ``quasi-static``, ``swing``, ``vehicle`` or ``ramp`` (paper Section 5.2), or a
        scenario built in code (then ``hours``, ``rate_hz``, ``rotation`` and the alignment
        arguments are its own).
    imu : str, PathLike or ImuConfig
        The plant: a preset name, an IMU TOML file or a configuration; default the paper's
        own (``paper``), as :func:`rinscal.simulate`'s, so a model fitted on a default
        simulated log navigates the unit it was fitted on.
    models : mapping or sequence
        Thermal models to compensate with (files or loaded); a sequence is named by file
        stem.
    hours : float, optional
        Run length [h] (vehicle: driving time); default per scenario.
    rate_hz : float
        IMU rate [Hz].
    seed : int
        Seed of the sensor noise and turn-on offsets.
    rotation : str
        Turntable: ``four-position``, ``continuous`` or ``none``.
    align_s, align_start_s : float
        Self-alignment length [s] and its start after power-on [s]; navigation starts at
        their sum.
    oracle : bool
        Also navigate with the true thermal bias removed (variant ``true``).
    policy : str
        The models' out-of-range policy.
    record : str or PathLike, optional
        Also stream the raw IMU output navigated into this file (Parquet, CSV or TSV, with
        its ``.meta.json``), readable by :func:`rinscal.navigate` with ``log=``.
    increments : bool
        ``record`` writes increments (``dtheta_*``, ``dvel_*``) [rad, m/s], not rates (nor
        counts).
    quantise : bool, optional
        The IMU puts out whole pulses of its ``[output]`` weights, the remainder carried
        (:class:`rinscal.sim.sensors.ThermalPlant`); ``record`` then writes integer counts
        (``dtheta_*``, ``dvel_*``) with the weights in its metadata, which ``log=`` reads
        as they are. None (default): as the IMU's configuration says (``ring_laser``:
        counts of 0.1″ and 125 µg·s; the other presets: rates).
    disturbed_start_min : float, optional [min]
        People about the parked carrier for the first minutes: sway and small tilt steps
        (:class:`rinscal.sim.disturbance.DisturbedStart`, drawn from ``seed``), carried by
        the truth. Static scenarios only (``quasi-static``, ``ramp``), at
        :data:`MIN_DISTURBED_RATE_HZ` or more.
    ambient_c : float, optional [°C]
        A constant ambient instead of the scenario's chamber profile, the unit soaked at it
        before power-on (a parked cold start at that temperature).
    daily_cycle_c : float [°C]
        With ``ambient_c``: the amplitude of a daily sinusoid about it (period 24 h, rising
        from ``ambient_c`` at power-on; :func:`rinscal.sim.scenario.daily_ambient`).
    progress : callable, optional
        Called with (simulated seconds done, total seconds).
    n_jobs : int or None
        Threads the variants are navigated on, side by side (None or 0: every core; the
        simulation runs on the caller's). The result is the same, bit for bit, whatever
        the number.

    Returns
    -------
    Navigation

    Examples
    --------
    >>> import rinscal
    >>> nav = rinscal.navigate_scenario("quasi-static", models=["m.json"])  # doctest: +SKIP
    >>> nav.summary["variants"]["regression"]["max_error_nmi"]  # doctest: +SKIP
    """
    _check.instance("scenario", scenario, (str, ScenarioConfig), "a scenario name or a Scenario")
    check_policy(policy)
    hours = _check.number("hours", hours, above=0.0, optional=True, unit="h")
    rate_hz = _check.number("rate_hz", rate_hz, above=0.0, unit="Hz")
    align_s = _check.number("align_s", align_s, above=0.0, unit="s")
    align_start_s = _check.number("align_start_s", align_start_s, min=0.0, unit="s")
    seed = _check.number("seed", seed, min=0, integer=True)
    _check.text("rotation", rotation)
    _check.flag("oracle", oracle)
    _check.flag("increments", increments)
    record = _check.path_like("record", record, optional=True)
    _check.flag("quantise", quantise, optional=True)
    disturbed_start_min = _check.number(
        "disturbed_start_min", disturbed_start_min, above=0.0, optional=True, unit="min"
    )
    ambient_c = _check.number("ambient_c", ambient_c, min=-60.0, max=100.0, optional=True,
                              unit="°C")  # fmt: skip
    daily_cycle_c = _check.number("daily_cycle_c", daily_cycle_c, min=0.0, max=40.0, unit="°C")
    n_jobs = _check.number("n_jobs", n_jobs, min=0, integer=True, optional=True)
    if daily_cycle_c and ambient_c is None:
        raise ConfigError("daily_cycle_c: give ambient_c too (the cycle is about it)")
    check_models(models)
    if record is not None and Path(record).suffix.lower() not in RECORD_SUFFIXES:
        raise ConfigError(f"record {record}: give a .parquet, .csv or .tsv file name")
    plant_cfg = resolve_imu(imu)
    if isinstance(scenario, ScenarioConfig):
        cfg = scenario
    else:
        align = align_for(plant_cfg, total_s=align_s, start_s=align_start_s)
        cfg = preset(
            scenario,
            hours=hours,
            rate_hz=rate_hz,
            align=align,
            schedule=schedule_from_name(rotation),
        )
    if ambient_c is not None:
        chamber = daily_ambient(ambient_c, daily_cycle_c, cfg.duration_s)
        cfg = replace(cfg, chamber=chamber)
    if cfg.chamber is None:
        raise ConfigError(f"scenario {cfg.name!r} has no chamber profile: no thermal plant")
    if disturbed_start_min is not None:
        cfg = disturbed(cfg, disturbed_start_min * 60.0, seed=seed)
    plant = ThermalPlant.for_scenario(plant_cfg, cfg, seed=seed, quantise=quantise)
    comps: dict[str, Any] = {"none": None}
    if oracle:
        comps["true"] = oracle_compensator(plant)
    named = _named_models(models)
    for name, m in named.items():
        comps[name] = model_compensator(m, plant, policy=policy)
    if record is None:
        result = run_scenario(cfg, plant, comps, progress=progress, n_jobs=n_jobs)
    else:
        result = _record(cfg, plant, comps, progress, Path(record), increments, seed, n_jobs)
    info: dict[str, Any] = {
        "seed": seed,
        "imu": plant_cfg.name,
        "imu_spec": str(imu) if not isinstance(imu, ImuConfig) else imu.name,
        "output": _output_summary(plant),
    }
    if isinstance(cfg.trajectory, DisturbedStart):
        info["disturbance"] = cfg.trajectory.summary()
    info["models"] = {
        k: (m.source.get("log") if isinstance(m, FittedModel) else str(m)) for k, m in named.items()
    }
    info["chamber"] = {
        "times_s": list(cfg.chamber.times_s),
        "temps_c": list(cfg.chamber.temps_c),
    }
    return Navigation(result, temperature_frame(plant), config=cfg, imu=plant_cfg, info=info)


def _record(
    cfg: ScenarioConfig,
    plant: ThermalPlant,
    comps: dict[str, Any],
    tick: Callable[[float, float], None] | None,
    record: Path,
    increments: bool,
    seed: int,
    n_jobs: int | None = 1,
) -> NavResult:
    """Run the scenario and stream the raw IMU output it navigated into ``record``."""
    moving = cfg.name == "vehicle"
    with recording(record, plant, increments=increments, track=moving) as rec:
        result = run_scenario(cfg, plant, comps, progress=tick, recorder=rec, n_jobs=n_jobs)
    meta = recording_meta(
        cfg, plant, f"rinscal navigate --scenario {cfg.name} --seed {seed}", increments
    )
    meta["heading_deg"] = (
        float(result.truth["heading_deg"].iloc[0]) if len(result.truth) and not moving else None
    )
    if isinstance(cfg.trajectory, DisturbedStart):
        meta["disturbance"] = cfg.trajectory.summary()
    # deferred: the writers only when recording
    from rinscal.io.metadata import write_meta

    write_meta(meta, record)
    return result


@contextmanager
def recording(
    record: Path,
    plant: ThermalPlant,
    *,
    increments: bool = False,
    track: bool = False,
    heading: bool = True,
) -> Iterator[Callable[[Any, NDArray[np.float64], NDArray[np.float64]], None]]:
    """Stream a simulated run's raw IMU output into ``record`` in the recorded-navigation
    log's columns (:func:`rinscal.nav.recorded.frame.recording_frame`), atomically: yields
    ``rec(chunk, dtheta, dv)`` to be called with every chunk from power-on on (the truth and
    the raw increments [rad, m/s]). The plant's thermometer readings (1 s) go with each
    sample; a quantised plant's output is written as integer counts, else rates (deg/h, µg)
    or, with ``increments``, increments [rad, m/s]. ``track`` writes the true position,
    ``heading`` the true body heading (``ref_*`` columns). The metadata is written apart
    (:func:`recording_meta`)."""
    # deferred: the writers (pyarrow) and the recording's columns only when recording
    from rinscal.io.streaming import LogStreamWriter
    from rinscal.nav.recorded.frame import recording_frame

    counts = None if increments else plant.pulse_weights
    grid = np.arange(0.0, float(plant.field.t[-1]) + 1e-9, 1.0)
    inner, outer = plant.measured_temperatures(grid)
    with LogStreamWriter(record, validate=False) as w:

        def rec(ch: Any, dth: Any, dv: Any) -> None:
            w.write(recording_frame(ch, dth, dv, increments=increments, counts=counts,
                                    readings=(grid, inner, outer), track=track,
                                    heading=heading))  # fmt: skip

        yield rec


def recording_meta(
    cfg: ScenarioConfig, plant: ThermalPlant, source: str, increments: bool
) -> dict[str, Any]:
    """The metadata of a recording written by :func:`recording` (rate [Hz], units or pulse
    weights, the site [deg, deg, m], the plant's noise in SI, the IMU's name)."""
    # deferred: the recording's columns, as in recording
    from rinscal.nav.recorded.frame import weight_texts

    tr = cfg.trajectory
    counts = None if increments else plant.pulse_weights
    noise = plant.config.noise
    wd, rw, on = noise.white_density_si(), noise.bias_rw_si(), noise.turn_on_sd_si()
    meta: dict[str, Any] = {
        "kind": "navigation recording",
        "source": source,
        "rate_hz": cfg.rate_hz,
        "units": {"gyro": "deg/h", "accel": "ug"} if not increments and counts is None else {},
        "site": {
            "lat_deg": float(np.rad2deg(tr.lat0)),
            "lon_deg": float(np.rad2deg(tr.lon0)),
            "h_m": float(tr.alt0),
        },
        "noise": {
            "gyro_noise_density": float(wd[0]),
            "accel_noise_density": float(wd[3]),
            "gyro_bias_rw": float(rw[0]),
            "accel_bias_rw": float(rw[3]),
            "gyro_turn_on": float(on[0]),
            "accel_turn_on": float(on[3]),
        },
        "imu": plant.config.name,
    }
    if counts is not None:
        meta["weights"] = weight_texts(counts)
    return meta


def disturbed(cfg: ScenarioConfig, duration_s: float, seed: int = 0) -> ScenarioConfig:
    """The scenario with people about its parked carrier for the first ``duration_s`` [s]
    (:class:`rinscal.sim.disturbance.DisturbedStart` about its static attitude)."""
    if not isinstance(cfg.trajectory, StaticMotion):
        raise ConfigError(
            f"disturbed start: scenario {cfg.name!r} does not stand still (give a static "
            "scenario: quasi-static or ramp)"
        )
    if cfg.rate_hz < MIN_DISTURBED_RATE_HZ:
        raise ConfigError(
            f"disturbed start: the sway (1-3 Hz) is integrated exactly only at "
            f"{MIN_DISTURBED_RATE_HZ:g} Hz or more, not at {cfg.rate_hz:g} Hz (simulate at "
            "100 Hz and sum the counts to a lower rate, as a unit's own output does)"
        )
    if duration_s >= cfg.duration_s:
        raise ConfigError(
            f"disturbed start: {duration_s / 60:g} min is not shorter than the run "
            f"({cfg.duration_s / 60:g} min)"
        )
    return replace(cfg, trajectory=DisturbedStart.draw(cfg.trajectory, duration_s, seed=seed))


def _output_summary(plant: ThermalPlant) -> dict[str, Any]:
    """How the plant puts out its increments, for the summary."""
    if plant.pulse_weights is None:
        return {"quantised": False}
    # deferred: the recording's columns, as in _record
    from rinscal.nav.recorded.frame import weight_texts

    return {"quantised": True, "weights": weight_texts(plant.pulse_weights)}


def navigate(
    scenario: str | ScenarioConfig | None = None,
    *,
    log: str | os.PathLike[str] | None = None,
    **options: Any,
) -> Any:
    """Navigate a single-axis RINS, simulated (``scenario``) or recorded (``log``): the old
    entry point, kept for one release (not in ``rinscal.__all__``); call
    :func:`navigate_scenario` or :func:`rinscal.nav.recording.navigate_log`, whose result
    types differ.

    Parameters
    ----------
    scenario : str or ScenarioConfig, optional
        A simulated cold start: ``quasi-static``, ``swing``, ``vehicle``, ``ramp`` or a
        scenario built in code; the options are those of :func:`navigate_scenario`.
    log : str or PathLike, optional
        A recording (CSV, TSV or Parquet: rates, increments or counts); the options are
        those of :func:`rinscal.nav.recording.navigate_log` (``models``, ``mapping``,
        ``site``, ``heading_deg``, ``track`` ...).
    **options
        Passed on.

    Returns
    -------
    Navigation or RecordedNavigation
        Either way ``.result.errors[variant]`` is the error series [m] and
        ``.result.summary()`` the per-variant summary.

    Raises
    ------
    ConfigError
        Neither or both of ``scenario`` and ``log``.

    Examples
    --------
    >>> import rinscal
    >>> sim = rinscal.navigate("quasi-static", hours=1, models=["m.json"])  # doctest: +SKIP
    >>> rec = rinscal.navigate(log="run.parquet", models=["m.json"])  # doctest: +SKIP
    """
    _check.instance(
        "scenario", scenario, (str, ScenarioConfig), "a scenario name or a Scenario", optional=True
    )
    log = _check.path_like("log", log, optional=True)
    if scenario is None and log is None:
        raise ConfigError("give a scenario (a simulated run) or log= (a recording)")
    if scenario is not None and log is not None:
        raise ConfigError("give a scenario (a simulated run) or log= (a recording), not both")
    if log is not None:
        # deferred: the recording reader and its window finder are not needed by a scenario
        from rinscal.nav.recording import navigate_log

        _known_options(navigate_log, options, "a recording (log=)")
        return navigate_log(log, **options)
    _known_options(navigate_scenario, options, "a scenario")
    return navigate_scenario(scenario, **options)  # type: ignore[arg-type]


def _known_options(target: Callable[..., Any], options: Mapping[str, Any], what: str) -> None:
    """Refuse an option the navigation of ``what`` does not take, naming those it does."""
    known = [p for p in inspect.signature(target).parameters if p not in ("scenario", "path")]
    unknown = [k for k in options if k not in known]
    if unknown:
        raise ConfigError(
            f"navigate: {', '.join(map(repr, unknown))} is not an option of {what}; "
            f"its options: {', '.join(known)}"
        )
