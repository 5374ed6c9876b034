"""Navigate a recorded run: open the log, find the window, navigate every variant.

The library side of ``rinscal navigate --log``: it reads the recording (twice, piece by
piece, through :mod:`rinscal.navlog`), the model files and a reference track, and returns
the results; it prints nothing and writes nothing (the command writes the outputs).

>>> from rinscal.recording import navigate_log                      # doctest: +SKIP
>>> nav = navigate_log("run.parquet", models=["regression.json"])  # doctest: +SKIP
>>> nav.result.summary()["variants"]["regression"]["max_error_nmi"]  # doctest: +SKIP
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from rinscal.errors import ConfigError
from rinscal.nav.recorded import (
    MIN_WINDOW_S,
    BlockStats,
    CausalModelCompensator,
    Noise,
    Reference,
    align_config,
    check_at_rest,
    estimate_noise,
    find_window,
    navigate_recording,
    seen_schedule,
)
from rinscal.schema import CHANNELS

#: Seconds between the temperature samples kept for the figure.
TEMPERATURE_STEP_S = 10.0


@dataclass
class RecordedNavigation:
    """A navigated recording.

    Attributes
    ----------
    result : NavResult
        Errors per variant (``none`` uncompensated, one per model, named by the model
        file's stem), the reference at the same times, the alignment per variant.
    report : dict
        JSON-able: ``log``, ``window`` (start, length, how it was chosen, its quality),
        ``noise`` (what the filter assumed and where it came from), ``at_rest`` (|f| and
        |ω| against gravity and the Earth rate), ``gaps``, ``rotation`` (what the encoder
        saw), ``reference`` and ``warnings``.
    temperatures : DataFrame
        ``time_s, chamber, outer, sensor_<channel>`` every :data:`TEMPERATURE_STEP_S`
        (NaN where the log has none), for the figure.
    """

    result: Any
    report: dict[str, Any]
    temperatures: pd.DataFrame
    warnings: list[str] = field(default_factory=list)


def parse_site(text: str) -> tuple[float, float, float]:
    """``"LAT,LON,HEIGHT"`` [deg, deg, m] → (lat, lon) [rad], height [m].

    Raises
    ------
    ConfigError
        Naming the option for a malformed value or a latitude outside ±90°.
    """
    parts = [p.strip() for p in str(text).split(",")]
    try:
        lat, lon, h = (float(p) for p in parts)
    except ValueError:
        raise ConfigError(f"--site: {text!r} is not LAT,LON,HEIGHT (deg, deg, m)") from None
    if not all(math.isfinite(x) for x in (lat, lon, h)):
        raise ConfigError(f"--site: {text!r} holds a non-finite number")
    if abs(lat) > 90:
        raise ConfigError(f"--site: latitude {lat:g}° lies outside ±90°")
    return math.radians(lat), math.radians(lon), h


def navigate_log(
    path: str | os.PathLike[str],
    *,
    mapping: Any = None,
    run: str | None = None,
    models: Sequence[str | os.PathLike[str]] = (),
    policy: str = "clamp",
    site: tuple[float, float, float] | None = None,
    heading_deg: float | None = None,
    track: str | os.PathLike[str] | None = None,
    track_utc_start: str | None = None,
    align_s: float = 600.0,
    align_start_s: float | None = None,
    min_align_s: float = MIN_WINDOW_S,
    imu: str | None = None,
    allow_gaps: bool = False,
    max_gap_samples: int = 5,
    model_update_s: float = 1.0,
    out_dt_s: float = 1.0,
    progress: Callable[[str, float, float], None] | None = None,
) -> RecordedNavigation:
    """Navigate a recording with and without each thermal model.

    Parameters
    ----------
    path : path-like
        The recorded-navigation log (see :mod:`rinscal.navlog`).
    mapping : NavMapping, optional
        How to read a foreign file.
    run : str, optional
        Which run of a log with several.
    models : sequence of path-like
        Thermal model files; each gives a variant.
    policy : {"clamp", "fallback", "extrapolate", "error"}
        Model inputs outside the training data.
    site : (lat [rad], lon [rad], height [m]), optional
        The static site; default the log's metadata, else the track's first point.
    heading_deg : float, optional [deg]
        True heading of the body at the alignment (default: the metadata's, if any).
    track : path-like, optional
        A reference track file (CSV with ``time_s``, or NMEA GGA).
    track_utc_start : str, optional
        UTC of the log's ``time_s = 0`` (ISO 8601), for an NMEA track.
    align_s : float [s]
        Longest alignment (a found window is cut to it; a given one has this length).
    align_start_s : float, optional [s]
        Set the window's start by hand (default: found).
    min_align_s : float [s]
        Shortest window the finder accepts.
    imu : str, optional
        A preset or IMU TOML file whose noise the filter assumes (else the metadata's, else
        estimated on the window).
    allow_gaps : bool
        Integrate across gaps longer than ``max_gap_samples`` instead of refusing.
    model_update_s : float [s]
        Thermometer reading interval of the compensators.
    out_dt_s : float [s]
        Interval of the reported errors.
    progress : callable, optional
        ``progress(stage, done_s, total_s)``: stage ``"reading"`` or ``"navigating"``.
    """
    from rinscal.calibration.modelfile import POLICIES, ThermalModelFile
    from rinscal.navlog import open_nav_log, read_track

    if policy not in POLICIES:
        raise ConfigError(f"--policy must be one of {', '.join(POLICIES)}, got {policy!r}")
    log = open_nav_log(path, mapping, run=run)
    warnings: list[str] = []

    def pieces() -> Any:
        return log.pieces(max_gap_samples=max_gap_samples, allow_gaps=allow_gaps)

    # pass 1: per-second sums, the temperatures for the figure
    stats = BlockStats()
    temps: list[np.ndarray] = []
    next_t = -math.inf
    for s in pieces():
        stats.add(s)
        if s.temps is not None and s.n:
            keep = _every(s.t, TEMPERATURE_STEP_S, next_t)
            if keep.size:
                out = np.full(keep.size, np.nan) if s.temp_out is None else s.temp_out[keep]
                temps.append(np.column_stack([s.t[keep], out, s.temps[keep]]))
                next_t = float(s.t[keep[-1]]) + TEMPERATURE_STEP_S
        if progress is not None:
            progress("reading", float(s.t[-1]) if s.n else 0.0, math.nan)
    blocks = stats.finish()
    dt = blocks.dt
    rate_meta = (log.meta or {}).get("rate_hz")
    if isinstance(rate_meta, int | float) and rate_meta > 0 and abs(1 / rate_meta - dt) < 1e-6 * dt:
        dt = 1.0 / float(rate_meta)  # the nominal interval exactly (times carry round-off)

    # the reference
    tr = None
    if track is not None:
        tr = read_track(track, track_utc_start or log.utc_start)
    if site is None:
        site = log.site
    if site is None and tr is not None:
        site = (float(tr.lat[0]), float(tr.lon[0]), float(tr.h[0]))
    if site is None:
        raise ConfigError(
            f"{path}: where was it recorded? Give --site LAT,LON,HEIGHT (the log's metadata has "
            "no site, and there is no reference track)"
        )
    if heading_deg is None:
        heading_deg = log.heading_deg
    reference = Reference(
        lat=site[0],
        lon=site[1],
        h=site[2],
        heading=None if heading_deg is None else math.radians(heading_deg),
        track=None if tr is None else (tr.t, tr.lat, tr.lon, tr.h),
    )

    if stats.n_jumps:
        t, row, size = stats.jumps[0]
        warnings.append(
            f"the encoder angle jumps {stats.n_jumps} time(s), the first at {t:.3f} s (data row "
            f"{row}) by {size:.1f}° more than the gyro turned: heading errors near them are "
            "not to be trusted (navigation runs in the IMU frame and does not use the encoder)"
        )
    window = find_window(blocks, align_s, min_s=min_align_s, start_s=align_start_s)
    at_rest, warn = check_at_rest(blocks, window, reference.lat, reference.h)
    warnings += warn
    noise = _noise(log, imu, blocks, window)
    align = align_config(noise, window)

    comps: dict[str, Any] = {"none": None}
    for m in models:
        name = Path(m).stem
        while name in comps:
            name += "_"
        model = ThermalModelFile.load(m)
        comps[name] = CausalModelCompensator(model, policy=policy, update_s=model_update_s)
    if len(comps) > 1 and not log.has_temps:
        raise ConfigError(
            f"{path}: a thermal model needs the sensor temperatures, and the log has none "
            "(temp_<channel> or temp_in columns, or a mapping's temperature)"
        )

    total = float(blocks.t1[-1])

    def tick(done: float) -> None:
        if progress is not None:
            progress("navigating", done, total)

    sched = seen_schedule(blocks)
    result = navigate_recording(
        pieces(),
        reference,
        window,
        align,
        dt,
        comps,
        name=Path(path).name,
        out_dt_s=out_dt_s,
        schedule="encoder" if blocks.has_table else "fixed (no encoder)",
        progress=tick,
    )
    gaps = list(log.gaps)
    report: dict[str, Any] = {
        "log": str(path),
        "run": log.run,
        "kind": log.kind,
        "window": {
            "start_s": window.start_s,
            "length_s": window.length_s,
            "how": window.how,
            **window.quality,
        },
        "noise": noise.to_dict(),
        "at_rest": at_rest,
        "gaps": {
            "count": len(gaps),
            "longest_s": max((g.length_s for g in gaps), default=0.0),
            "first": [
                {"time_s": g.time_s, "row": g.row, "length_s": g.length_s} for g in gaps[:20]
            ],
        },
        "rotation": sched,
        "encoder_jumps": {
            "count": stats.n_jumps,
            "first": [{"time_s": t, "row": r, "deg": d} for t, r, d in stats.jumps],
        },
        "reference": (
            "track file" if tr is not None else "log columns" if log.has_ref else "static site"
        ),
        "site": {
            "lat_deg": math.degrees(reference.lat),
            "lon_deg": math.degrees(reference.lon),
            "h_m": reference.h,
        },
        "heading_deg": heading_deg,
        "models": {name: str(m) for name, m in zip(list(comps)[1:], models, strict=True)},
        "policy": policy,
        "warnings": warnings,
    }
    temp = np.concatenate(temps) if temps else np.empty((0, 8))
    frame = pd.DataFrame({"time_s": temp[:, 0], "chamber": np.nan, "outer": temp[:, 1]})
    for j, c in enumerate(CHANNELS):
        frame[f"sensor_{c}"] = temp[:, 2 + j]
    return RecordedNavigation(result, report, frame, warnings)


def _every(t: np.ndarray, step: float, next_t: float) -> np.ndarray:
    """Indices of the first sample at or after each multiple of ``step`` from ``next_t``."""
    k = np.floor(t / step)
    first = np.flatnonzero(np.diff(k, prepend=-np.inf) != 0)
    return first[t[first] >= next_t - 1e-9]


def _noise(log: Any, imu: str | None, blocks: Any, window: Any) -> Noise:
    """The filter's sensor noise: --imu, else the log's metadata, else estimated."""
    if imu is not None:
        from rinscal.thermal.plant import load_imu

        cfg = load_imu(imu)
        wd = cfg.noise.white_density_si()
        rw = cfg.noise.bias_rw_si()
        return Noise(float(wd[0]), float(wd[3]), float(rw[0]), float(rw[3]), f"--imu {imu}")
    meta = log.noise
    if meta:
        try:
            return Noise(
                float(meta["gyro_noise_density"]),
                float(meta["accel_noise_density"]),
                float(meta.get("gyro_bias_rw", 0.0)),
                float(meta.get("accel_bias_rw", 0.0)),
                "metadata of the log",
            )
        except (KeyError, TypeError, ValueError):
            raise ConfigError(
                f"{log.path}: metadata 'noise' needs gyro_noise_density [rad/√s] and "
                f"accel_noise_density [m/s²/√Hz], got {meta!r}"
            ) from None
    return estimate_noise(blocks, window)


def heading_text(report: dict[str, Any]) -> str:
    """One line on the window for the terminal."""
    w = report["window"]
    return (
        f"alignment window {w['start_s']:.0f}-{w['start_s'] + w['length_s']:.0f} s ({w['how']}"
        f", |f| spread median {w['sd_ug_median']:.0f} µg against a floor of "
        f"{w['floor_ug']:.0f} µg, {100 * w['quiet_fraction']:.0f} % of its seconds quiet); "
        f"filter noise {report['noise']['source']}: "
        f"{report['noise']['gyro_arw_deg_per_rth']:.2g} °/√h, "
        f"{report['noise']['accel_vrw_ug_per_rthz']:.3g} µg/√Hz"
    )


__all__ = ["TEMPERATURE_STEP_S", "RecordedNavigation", "heading_text", "navigate_log", "parse_site"]
