"""Monte Carlo studies: many units, many cold starts, every method on the same raw data.

A study is named by a :class:`StudySpec` (built in: :data:`BUILTIN_STUDIES`, or a TOML
file; see ``docs/study.md``). It expands into tasks of two kinds:

* a **calibration task** per plant variant and unit (:func:`calibrate_unit`): the unit is
  simulated on its own soak runs and every method of the spec is fitted to them, as in
  production;
* a **navigation task** per plant variant, unit, scenario and cold start
  (:func:`navigate_unit`): one raw IMU output navigated with no compensation, each fitted
  model and the true thermal bias (the oracle), so that every comparison between methods is
  paired on the same raw data.

Each task is a pure function of the spec, its key and the seeds derived from the spec's seed
and the key (:func:`task_seed`): results do not depend on where, in which order or on how
many workers the tasks run. The same unit has the same seeds in every plant variant of a
sweep (common random numbers), so a sweep's points are paired too.

This module holds the spec (its TOML layout, validation and sweeps); the tasks and their
pure functions are in :mod:`rinscal.experiments.study.tasks`. Nothing here reads or writes
files except :func:`load_spec` (the spec itself); execution on Dask and the results store
are in :mod:`rinscal.experiments.study.runner`, statistics in
:mod:`rinscal.experiments.study.stats`.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass
from importlib import resources
from pathlib import Path
from typing import Any

import pandas as pd

from rinscal import units
from rinscal.calibration.thermal.model import FIT_METHODS
from rinscal.errors import ConfigError
from rinscal.experiments.paper.config import METHODS, ReproConfig, load_plant
from rinscal.experiments.paper.imucal import IMU_VARIANT
from rinscal.experiments.study.compare import FIELD_VARIANT, NO_DT_VARIANT
from rinscal.presets import PRESETS

__all__ = [
    "BUILTIN_STUDIES",
    "FIELD_AMBIENTS_C",
    "MECH_SPREAD_FIELDS",
    "SCENARIO_KINDS",
    "SPREAD_FIELDS",
    "STUDY_VARIANTS",
    "SWEEP_PARAMETERS",
    "CalibrationSpec",
    "PlantVariant",
    "ScenarioSpec",
    "StudySpec",
    "load_spec",
    "plant_table",
    "reproduction_spec",
    "spec_from_dict",
    "sweep_columns",
]

#: Studies shipped with rinscal (``src/rinscal/data/studies/<name>.toml``).
BUILTIN_STUDIES = ("paper", "sensitivity", "field")
#: Variants a spec may list: uncompensated, the models (``regression+sf``: method 2 behind the
#: thermal part of the unit's own multi-position calibration, see
#: :mod:`rinscal.experiments.paper.imucal`; ``regression-no-dT``: method 2 on ``T`` and ``Ṫ``
#: only, the gradient ablation; ``field``: calibrated without a chamber from the unit's own
#: parked cold starts, :func:`rinscal.nav.fieldcal.calibrate_field`), the true-bias oracle.
#: ``none`` and
#: ``true`` are navigated in every task whether listed or not (the thermal part needs the
#: oracle); the list decides which models are fitted.
STUDY_VARIANTS = ("none", *METHODS, NO_DT_VARIANT, IMU_VARIANT, FIELD_VARIANT, "true")
#: The fitted variants (every study variant but ``none`` and ``true``).
_MODEL_VARIANTS = (*METHODS, NO_DT_VARIANT, IMU_VARIANT, FIELD_VARIANT)
#: The ambients of the field variant's parked starts by default (Table 3's soaks) [°C].
FIELD_AMBIENTS_C = (0.0, 7.0, 14.0, 21.0, 28.0, 35.0, 42.0)
#: Scenario kinds (:data:`rinscal.sim.scenario.SCENARIOS`).
SCENARIO_KINDS = ("quasi-static", "swing", "vehicle", "ramp")

#: Sweepable plant parameters: each multiplies a group of thermal-bias coefficients of the
#: accelerometers or the gyros: ``(sensors, ChannelThermal fields of the polynomial law,
#: MechanisticThermal fields of the mechanistic law)``. Under the mechanistic law the groups
#: mean the same physics: ``t`` the terms of the sensor's own and its mount's temperature;
#: ``rate`` the terms that follow the warm-up's history and speed (the lagged electronics box;
#: a gyro coil's radial gradient, which grows with the heating rate); ``grad`` the gradients
#: no thermometer pair spans (electronics to block, the coil, the package stress); ``dynamic``
#: both (everything but the own and mount temperatures). Shupe is a field of both laws.
_SWEEP_GROUPS: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    "t": (("t",), ("k_t", "k_mount", "k_mount2")),
    "rate": (("rate", "t_rate"), ("k_elec", "k_coil")),
    "grad": (("grad", "t_grad"), ("k_path", "k_coil", "k_stress")),
    "dynamic": (("rate", "t_rate", "grad", "t_grad"), ("k_elec", "k_path", "k_coil", "k_stress")),
}
#: The ``ChannelThermal`` fields of the scale-factor and axis drift with temperature.
_SIGNAL_DRIFT = (
    "scale_factor_ppm_per_c",
    "misalignment_arcsec_per_c",
    "sf_asym_ppm_per_c",
    "sf_quad_per_c",
)
SWEEP_PARAMETERS: dict[str, tuple[str, tuple[str, ...], tuple[str, ...]]] = {
    **{
        f"{sensors}_{group}_scale": (sensors, poly, mech)
        for sensors in ("accel", "gyro")
        for group, (poly, mech) in _SWEEP_GROUPS.items()
    },
    "gyro_shupe_scale": ("gyro", ("shupe",), ()),
    # the temperature dependence of scale factor, its nonlinear terms and the axes (issue
    # 25): 0 switches it off in the plant, 1 keeps it (the values at t_cal are not thermal)
    **{
        f"{sensors}_signal_drift_scale": (sensors, _SIGNAL_DRIFT, ())
        for sensors in ("accel", "gyro")
    },
}
#: Coefficients scattered from unit to unit by ``coefficient_spread`` (relative, 1σ): of the
#: polynomial law and Shupe/hysteresis (``ChannelThermal``), and of the mechanistic law
#: (``MechanisticThermal``: every sensitivity, not the nonlinear shape parameters).
SPREAD_FIELDS = ("t", "rate", "grad", "t_grad", "t_rate", "stress", "shupe", "hysteresis")
MECH_SPREAD_FIELDS = ("k_t", "k_mount", "k_mount2", "k_elec", "k_path", "k_coil", "k_stress")


# --------------------------------------------------------------------------- the spec
@dataclass(frozen=True)
class CalibrationSpec:
    """How each unit is calibrated: the soak protocol (Table 3) at ``rate_hz`` [Hz] with
    runs of ``hours`` [h]; the BP network is trained on ``neural_max_samples`` samples.

    The ``field`` variant instead learns from ``field_runs`` parked cold starts of the unit
    (:func:`rinscal.sim.fieldstarts.simulate_field_starts`), each ``field_hours`` [h] long
    at ``field_rate_hz`` [Hz] (a whole number), run ``k`` at ``field_ambient_c[k % len]``
    [°C], fitted with ``field_method`` (default ``regression``, method 2's form: the
    comparison with the chamber's method 2 then differs only in where the data come
    from)."""

    hours: float = 3.0
    rate_hz: float = 10.0
    neural_max_samples: int = 20000
    field_runs: int = 7
    field_hours: float = 4.0
    field_rate_hz: float = 10.0
    field_ambient_c: tuple[float, ...] = FIELD_AMBIENTS_C
    field_method: str = "regression"


@dataclass(frozen=True)
class PlantVariant:
    """One plant of a study: an IMU (preset name or TOML path) with its sweep parameters
    (``(name, factor)`` pairs of :data:`SWEEP_PARAMETERS`) applied."""

    imu: str
    params: tuple[tuple[str, float], ...] = ()

    @property
    def label(self) -> str:
        """``imu`` then each ``name=factor``, e.g. ``paper accel_dynamic_scale=3``."""
        name = Path(self.imu).stem if self.imu not in PRESETS else self.imu
        return " ".join([name, *(f"{k}={v:g}" for k, v in self.params)])


@dataclass(frozen=True)
class ScenarioSpec:
    """One group of cold starts, one per ``ambient_c`` entry.

    Parameters
    ----------
    name : str
        Label of the group in tables and the report (unique in the spec).
    kind : str
        One of :data:`SCENARIO_KINDS`.
    hours : float [h]
        Length of each run (vehicle: of the drive).
    rate_hz : float [Hz]
        IMU rate.
    ambient_c : tuple of float or None [°C]
        Lab temperature (quasi-static, swing) or ambient at the cold start (vehicle) of each
        start; ``None`` keeps the scenario's own chamber (the ramp).
    align_s : float [s]
        Coarse plus fine alignment time.
    align_start_s : float [s]
        Time after power-on at which the alignment starts.
    """

    name: str
    kind: str
    hours: float
    rate_hz: float
    ambient_c: tuple[float | None, ...]
    align_s: float = 600.0
    align_start_s: float = 0.0


@dataclass(frozen=True)
class StudySpec:
    """A whole study; see ``docs/study.md`` for the TOML layout.

    Parameters
    ----------
    name, description : str
        Free text.
    seed : int
        Root of every seed (:func:`task_seed`).
    units : int
        Number of simulated units (each a seed).
    coefficient_spread : float
        Relative unit-to-unit scatter (1σ) of the thermal coefficients
        (:data:`SPREAD_FIELDS`); 0 for identical units that differ only in noise and
        turn-on offsets.
    methods : tuple of str
        Variants (:data:`STUDY_VARIANTS`); the models among them are fitted for every unit.
    calibration : CalibrationSpec
        Each unit's calibration protocol.
    plants : tuple of PlantVariant
        The plant variants (a plant's sweep expanded).
    scenarios : tuple of ScenarioSpec
        The scenario groups (lists of ``align_start_s`` expanded).
    quick : bool
        Whether the spec's ``[quick]`` sizes were applied.
    """

    name: str
    description: str
    seed: int
    units: int
    coefficient_spread: float
    methods: tuple[str, ...]
    calibration: CalibrationSpec
    plants: tuple[PlantVariant, ...]
    scenarios: tuple[ScenarioSpec, ...]
    quick: bool = False

    @property
    def models(self) -> tuple[str, ...]:
        """The methods that are fitted (the spec's methods without ``none``/``true``)."""
        return tuple(m for m in self.methods if m in _MODEL_VARIANTS)

    def to_dict(self) -> dict[str, Any]:
        """Plain JSON-able form (what the results folder records)."""
        return json.loads(json.dumps(asdict(self)))

    def fingerprint(self) -> str:
        """Hash of everything that decides a task's result (all but ``units``, which only
        adds or drops tasks, and the free text)."""
        d = self.to_dict()
        for k in ("units", "description"):
            d.pop(k)
        if FIELD_VARIANT not in self.methods:  # they decide nothing then (older folders too)
            for k in [k for k in d["calibration"] if k.startswith("field_")]:
                d["calibration"].pop(k)
        return hashlib.sha256(json.dumps(d, sort_keys=True).encode()).hexdigest()[:16]


_TOP = {"study", "calibration", "plants", "scenarios", "quick"}
_STUDY = {"name", "description", "seed", "units", "coefficient_spread", "methods"}
_CAL = {
    "hours",
    "rate_hz",
    "neural_max_samples",
    "field_runs",
    "field_hours",
    "field_rate_hz",
    "field_ambient_c",
    "field_method",
}
_PLANT = {"imu", "sweep"}
_SCEN = {"name", "kind", "hours", "rate_hz", "ambient_c", "align_s", "align_start_s"}
_QUICK = {"calibration", "scenarios"}
_QUICK_SCEN = {"hours", "rate_hz"}


def _keys(where: str, table: Any, known: set[str], source: str) -> dict[str, Any]:
    if not isinstance(table, dict):
        raise ConfigError(f"{source}: {where} must be a table")
    extra = sorted(set(table) - known)
    if extra:
        raise ConfigError(
            f"{source}: {where}: unknown key(s) {', '.join(extra)}; known: "
            + ", ".join(sorted(known))
        )
    return table


def _number(where: str, v: Any, source: str, *, positive: bool = True) -> float:
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
        raise ConfigError(f"{source}: {where} must be a finite number, got {v!r}")
    if positive and v <= 0:
        raise ConfigError(f"{source}: {where} must be > 0, got {v!r}")
    if not positive and v < 0:
        raise ConfigError(f"{source}: {where} must be >= 0, got {v!r}")
    return float(v)


def _count(where: str, v: Any, source: str, minimum: int = 1) -> int:
    if isinstance(v, bool) or not isinstance(v, int) or v < minimum:
        raise ConfigError(f"{source}: {where} must be an integer >= {minimum}, got {v!r}")
    return int(v)


def _array_of_tables(data: Mapping[str, Any], key: str, source: str) -> list[Any]:
    """``data[key]``, which must be a non-empty TOML array of tables (``[[key]]``)."""
    v = data[key]
    if not isinstance(v, list) or not v:
        raise ConfigError(f"{source}: [[{key}]] must list at least one {key[:-1]}")
    return v


def _list(v: Any) -> list[Any]:
    return list(v) if isinstance(v, list | tuple) else [v]


def _resolve_imu(imu: Any, where: str, source: str, base: Path | None) -> str:
    if not isinstance(imu, str) or not imu:
        raise ConfigError(f"{source}: {where} must be a preset name or a TOML file path")
    if imu in PRESETS:
        return imu
    p = Path(imu)
    if not p.is_absolute() and base is not None:
        p = base / p
    if p.suffix.lower() != ".toml" or not p.is_file():
        raise ConfigError(
            f"{source}: {where} = {imu!r} is neither a preset ({', '.join(PRESETS)}) nor an "
            "existing .toml file"
        )
    return str(p.resolve())


def spec_from_dict(
    data: Mapping[str, Any],
    source: str = "<spec>",
    *,
    quick: bool = False,
    units_override: int | None = None,
    imu_override: str | Sequence[str] | None = None,
    base: Path | None = None,
) -> StudySpec:
    """Validate a study spec in its TOML layout and expand its sweeps.

    Parameters
    ----------
    data : mapping
        The parsed TOML: ``[study]``, ``[calibration]``, ``[[plants]]``, ``[[scenarios]]``
        and an optional ``[quick]``.
    source : str
        Name of the spec in error messages.
    quick : bool
        Apply the ``[quick]`` sizes (an error if the spec has none).
    units_override : int, optional
        Number of units instead of ``study.units``.
    imu_override : str or sequence of str, optional
        IMUs (presets or TOML files) that replace the spec's plants, each with the spec's
        sweep (the spec's plants must then share one sweep), e.g. ``("navigation_grade",
        "navigation_grade_mechanistic")`` for the same study over both thermal laws.
    base : Path, optional
        Folder that relative IMU file paths are relative to (the spec file's).

    Raises
    ------
    ConfigError
        Naming the key: unknown keys, non-positive sizes, negative counts, unknown presets,
        methods, scenario kinds or sweep parameters, duplicate scenario names.
    """
    data = _keys("top level", dict(data), _TOP, source)
    for required in ("study", "calibration", "plants", "scenarios"):
        if required not in data:
            raise ConfigError(f"{source}: missing [{required}]")
    st = _keys("[study]", data["study"], _STUDY, source)
    name = str(st.get("name", Path(source).stem))
    seed = st.get("seed", 0)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ConfigError(f"{source}: study.seed must be an integer >= 0, got {seed!r}")
    n_units = _count("study.units", st.get("units", 10), source)
    if units_override is not None:
        n_units = _count("--units", units_override, source)
    spread = _number(
        "study.coefficient_spread", st.get("coefficient_spread", 0.0), source, positive=False
    )
    if spread >= 1.0:
        raise ConfigError(f"{source}: study.coefficient_spread must be < 1, got {spread}")
    methods = _list(st.get("methods", list(STUDY_VARIANTS)))
    for m in methods:
        if m not in STUDY_VARIANTS:
            raise ConfigError(
                f"{source}: study.methods: unknown method {m!r}; known: "
                + ", ".join(STUDY_VARIANTS)
            )
    if len(set(methods)) != len(methods):
        raise ConfigError(f"{source}: study.methods lists a method twice")
    qk = _keys("[quick]", data.get("quick", {}), _QUICK, source)
    if quick and not qk:
        raise ConfigError(f"{source}: --quick: this spec has no [quick] section")
    cal_d = dict(_keys("[calibration]", data["calibration"], _CAL, source))
    if quick:
        cal_d.update(_keys("[quick.calibration]", qk.get("calibration", {}), _CAL, source))
    cal = CalibrationSpec(
        hours=_number("calibration.hours", cal_d.get("hours", 3.0), source),
        rate_hz=_number("calibration.rate_hz", cal_d.get("rate_hz", 10.0), source),
        neural_max_samples=_count(
            "calibration.neural_max_samples", cal_d.get("neural_max_samples", 20000), source, 100
        ),
        **_field_calibration(cal_d, source),
    )
    plants_d = _array_of_tables(data, "plants", source)
    sweeps: list[tuple[str, list[tuple[tuple[str, float], ...]]]] = []
    for i, p in enumerate(plants_d):
        where = f"plants[{i}]"
        p = _keys(where, p, _PLANT, source)
        if "imu" not in p:
            raise ConfigError(f"{source}: {where}.imu is missing")
        imu = _resolve_imu(p["imu"], f"{where}.imu", source, base)
        sweep = _keys(f"{where}.sweep", p.get("sweep", {}), set(SWEEP_PARAMETERS), source)
        axes = []
        for k, vals in sweep.items():
            vals = _list(vals)
            if not vals:
                raise ConfigError(f"{source}: {where}.sweep.{k} is empty")
            axes.append(
                [(k, _number(f"{where}.sweep.{k}", v, source, positive=False)) for v in vals]
            )
        sweeps.append((imu, list(itertools.product(*axes))))
    if imu_override:
        overrides = [imu_override] if isinstance(imu_override, str) else list(imu_override)
        combos = {tuple(c) for _, c in sweeps}
        if len(combos) > 1:
            raise ConfigError(
                f"{source}: --imu replaces the plants' IMUs, but the spec's [[plants]] have "
                "different sweeps: edit the spec instead"
            )
        sweeps = [
            (_resolve_imu(o, "--imu", source, Path.cwd()), sweeps[0][1] if sweeps else [()])
            for o in overrides
        ]
    plants = [PlantVariant(imu, tuple(c)) for imu, cs in sweeps for c in cs]
    if len({(p.imu, p.params) for p in plants}) != len(plants):
        raise ConfigError(f"{source}: [[plants]] names the same plant variant twice")
    quick_scen = _keys("[quick.scenarios]", qk.get("scenarios", {}), set(SCENARIO_KINDS), source)
    scen_d = _array_of_tables(data, "scenarios", source)
    scenarios: list[ScenarioSpec] = []
    for i, s in enumerate(scen_d):
        where = f"scenarios[{i}]"
        s = dict(_keys(where, s, _SCEN, source))
        kind = s.get("kind")
        if kind not in SCENARIO_KINDS:
            raise ConfigError(
                f"{source}: {where}.kind must be one of {', '.join(SCENARIO_KINDS)}, got {kind!r}"
            )
        if quick and kind in quick_scen:
            s.update(_keys(f"quick.scenarios.{kind}", quick_scen[kind], _QUICK_SCEN, source))
        for req in ("hours", "rate_hz"):
            if req not in s:
                raise ConfigError(f"{source}: {where}.{req} is missing")
        hours = _number(f"{where}.hours", s["hours"], source)
        rate = _number(f"{where}.rate_hz", s["rate_hz"], source)
        align_s = _number(f"{where}.align_s", s.get("align_s", 600.0), source)
        amb_raw = s.get("ambient_c", [] if kind == "ramp" else [20.0])
        if kind == "ramp":
            if _list(amb_raw):
                raise ConfigError(f"{source}: {where}.ambient_c: the ramp has its own chamber")
            ambient: tuple[float | None, ...] = (None,)
        else:
            ambient = tuple(_celsius(f"{where}.ambient_c", a, source) for a in _list(amb_raw))
            if not ambient:
                raise ConfigError(f"{source}: {where}.ambient_c must list at least one start")
        starts = _list(s.get("align_start_s", 0.0))
        if not starts:
            raise ConfigError(f"{source}: {where}.align_start_s is empty")
        base_name = str(s.get("name", kind))
        for a0 in starts:
            a0 = _number(f"{where}.align_start_s", a0, source, positive=False)
            if a0 + align_s >= hours * units.HOUR_TO_S and kind != "vehicle":
                raise ConfigError(
                    f"{source}: {where}: the alignment ends {a0 + align_s:g} s after power-on, "
                    f"not before the run ({hours * units.HOUR_TO_S:g} s) ends"
                )
            label = base_name if len(starts) == 1 else f"{base_name}, align at {a0:g} s"
            scenarios.append(ScenarioSpec(label, kind, hours, rate, ambient, align_s, a0))
    names = [s.name for s in scenarios]
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ConfigError(f"{source}: scenarios: name {dup[0]!r} is used twice")
    return StudySpec(
        name=name,
        description=str(st.get("description", "")),
        seed=int(seed),
        units=n_units,
        coefficient_spread=spread,
        methods=tuple(methods),
        calibration=cal,
        plants=tuple(plants),
        scenarios=tuple(scenarios),
        quick=quick,
    )


def _field_calibration(cal: Mapping[str, Any], source: str) -> dict[str, Any]:
    """The ``field_*`` keys of ``[calibration]`` (defaults: :class:`CalibrationSpec`'s),
    validated: at least 3 runs (what :func:`rinscal.nav.fieldcal.calibrate_field` needs),
    positive hours, a whole rate in Hz, a non-empty list of ambients."""
    d = CalibrationSpec()
    rate = _number("calibration.field_rate_hz", cal.get("field_rate_hz", d.field_rate_hz), source)
    if rate < 1.0 or rate != round(rate):
        raise ConfigError(
            f"{source}: calibration.field_rate_hz must be a whole number of Hz >= 1, got {rate:g}"
        )
    amb = _list(cal.get("field_ambient_c", list(d.field_ambient_c)))
    if not amb:
        raise ConfigError(f"{source}: calibration.field_ambient_c must list at least one ambient")
    method = cal.get("field_method", d.field_method)
    if method not in FIT_METHODS:
        raise ConfigError(
            f"{source}: calibration.field_method must be one of {', '.join(FIT_METHODS)}, "
            f"got {method!r}"
        )
    return {
        "field_runs": _count(
            "calibration.field_runs", cal.get("field_runs", d.field_runs), source, 3
        ),
        "field_hours": _number(
            "calibration.field_hours", cal.get("field_hours", d.field_hours), source
        ),
        "field_rate_hz": float(rate),
        "field_ambient_c": tuple(_celsius("calibration.field_ambient_c", a, source) for a in amb),
        "field_method": str(method),
    }


def _celsius(where: str, v: Any, source: str) -> float:
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
        raise ConfigError(f"{source}: {where} must be a finite temperature [°C], got {v!r}")
    if not -60.0 <= v <= 85.0:
        raise ConfigError(f"{source}: {where} = {v} °C is outside -60..85 °C")
    return float(v)


def load_spec(
    spec: str | Path,
    *,
    quick: bool = False,
    units_override: int | None = None,
    imu_override: str | Sequence[str] | None = None,
) -> StudySpec:
    """A study from a built-in name (:data:`BUILTIN_STUDIES`) or a TOML file.

    Raises
    ------
    ConfigError
        For an unknown name, an unreadable or invalid file (the message names the file and
        the key).
    """
    s = str(spec)
    if s in BUILTIN_STUDIES:
        try:
            text = resources.files("rinscal").joinpath("data", "studies", f"{s}.toml").read_text()
        except OSError as e:
            raise ConfigError(
                f"built-in study {s!r}: its file is missing from this installation ({e})"
            ) from None
        source, base = f"built-in study {s!r}", None
    else:
        p = Path(s)
        if not p.is_file():
            raise ConfigError(
                f"study {s!r}: neither a built-in study ({', '.join(BUILTIN_STUDIES)}) nor a file"
            )
        try:
            text = p.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as e:
            raise ConfigError(f"{p}: cannot read it ({e})") from None
        source, base = str(p), p.parent
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ConfigError(f"{source}: not valid TOML ({e})") from None
    return spec_from_dict(
        data,
        source,
        quick=quick,
        units_override=units_override,
        imu_override=imu_override,
        base=base,
    )


def reproduction_spec(cfg: ReproConfig, units: int) -> StudySpec:
    """The navigation part of a reproduction as a study of ``units`` units: the built-in
    ``paper`` study with the reproduction's plant, seed, sizes (calibration and navigation
    rates and lengths, lab and vehicle temperatures) and alignment settings."""
    lab = list(cfg.lab_temps_c)
    scen = {"align_s": cfg.align_s, "align_start_s": cfg.align_start_s}
    data = {
        "study": {
            "name": "paper",
            "description": f"rinscal reproduce{' --quick' if cfg.quick else ''} --units "
            f"{units}: its lab and vehicle navigation runs over {units} units, each "
            "calibrated on its own soak runs.",
            "seed": cfg.seed,
            "units": units,
            "coefficient_spread": load_spec("paper").coefficient_spread,
            "methods": list(STUDY_VARIANTS),
        },
        "calibration": {
            "hours": cfg.soak_hours,
            "rate_hz": cfg.cal_rate_hz,
            "neural_max_samples": cfg.neural_max_samples,
        },
        "plants": [{"imu": cfg.imu}],
        "scenarios": [
            {
                "name": "lab quasi-static",
                "kind": "quasi-static",
                "hours": cfg.qs_hours,
                "rate_hz": cfg.nav_rate_hz,
                "ambient_c": lab,
                **scen,
            },
            {
                "name": "lab swing",
                "kind": "swing",
                "hours": cfg.swing_hours,
                "rate_hz": cfg.swing_rate_hz,
                "ambient_c": lab,
                **scen,
            },
            {
                "name": "vehicle",
                "kind": "vehicle",
                "hours": cfg.vehicle_hours,
                "rate_hz": cfg.nav_rate_hz,
                "ambient_c": list(cfg.vehicle_ambient_c),
                **scen,
            },
        ],
    }
    return spec_from_dict(data, "rinscal reproduce --units", base=Path.cwd())


def sweep_columns(spec: StudySpec) -> list[str]:
    """Names of the sweep parameters used by any plant of the spec, in spec order."""
    out: list[str] = []
    for p in spec.plants:
        for k, _ in p.params:
            if k not in out:
                out.append(k)
    return out


def plant_table(spec: StudySpec) -> pd.DataFrame:
    """One row per plant variant: index, label, IMU, its thermal law (``polynomial`` or
    ``mechanistic``) and each sweep factor (1 where the variant does not set it)."""
    cols = sweep_columns(spec)
    laws = {imu: load_plant(imu).thermal_law for imu in {p.imu for p in spec.plants}}
    rows = []
    for i, p in enumerate(spec.plants):
        d = dict(p.params)
        rows.append(
            {
                "plant": i,
                "plant_label": p.label,
                "imu": p.imu,
                "law": laws[p.imu],
                **{c: d.get(c, 1.0) for c in cols},
            }
        )
    return pd.DataFrame(rows)
