"""Navigate a recorded run: open the log, find the window, navigate every variant.

The library side of ``rinscal navigate --log``: it reads the recording (twice, piece by
piece, through :mod:`rinscal.io.navopen`), the model files and a reference track, and returns
the results; it prints nothing and writes nothing (the command writes the outputs).

Why one module: about 700 lines, one idea: :func:`navigate_log`, whose checks run in the
order a user's mistakes are to be named (what the recording is before its units, everything
that can be refused before the data are read); the helpers below serve it and the
command's words on its result.

>>> from rinscal.nav.recording import navigate_log                  # doctest: +SKIP
>>> nav = navigate_log("run.parquet", models=["regression.json"])  # doctest: +SKIP
>>> nav.summary["variants"]["regression"]["max_error_nmi"]  # doctest: +SKIP
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from rinscal import _check
from rinscal.calibration.compensator import Compensator
from rinscal.calibration.imulog import check_recording_for_imu
from rinscal.calibration.modelfile import POLICIES, FittedModel
from rinscal.errors import ConfigError, LogError
from rinscal.imunoise import NoiseSource, load_noise
from rinscal.io.mapping import ColumnMapping
from rinscal.io.navopen import nav_log_header, open_nav_log
from rinscal.io.track import parse_utc, read_track
from rinscal.nav.engine import Navigation
from rinscal.nav.recorded.aided import (
    AIDING,
    GNSS_NOTE,
    IN_MOTION_NAV_MIN_S,
    IN_MOTION_SHARE,
    gnss_aiding,
    in_motion_alignment,
    in_motion_lengths,
)
from rinscal.nav.recorded.blocks import BlockStats
from rinscal.nav.recorded.kind import (
    calibration_log,
    motion,
    recording_motion,
    still_blocks,
    window_motion,
)
from rinscal.nav.recorded.navigate import Reference, navigate_recording
from rinscal.nav.recorded.noise import (
    KF_INTERVAL_S,
    estimate_noise_allan,
    noise_text,
    velocity_meas_sd,
)
from rinscal.nav.recorded.window import (
    MIN_WINDOW_S,
    Disturbance,
    Noise,
    align_config,
    check_at_rest,
    check_encoder,
    check_never_at_rest,
    check_turning_without_encoder,
    find_window,
    seen_schedule,
)
from rinscal.parallel import read_ahead, resolve_jobs
from rinscal.schema import CHANNELS

#: Seconds between the temperature samples kept for the figure.
TEMPERATURE_STEP_S = 10.0
#: Pieces the first pass reads ahead on a thread of its own (each of at most
#: :data:`~rinscal.io.streaming.PIECE_ROWS` samples: about 40 MB of a recording with every
#: column, so about 0.25 GB held at most).
FIRST_PASS_AHEAD = 6


#: A navigated recording: :class:`rinscal.nav.engine.Navigation` (``result``, ``report``,
#: ``temperatures``, ``warnings``; ``summary`` what ``summary.json`` holds).
RecordedNavigation = Navigation


def parse_site(text: str) -> tuple[float, float, float]:
    """``"LAT,LON,HEIGHT"`` [deg, deg, m] → (lat, lon) [rad], height [m].

    Raises
    ------
    ConfigError
        Naming the argument (``site=``) for a malformed value or a latitude outside ±90°.
    """
    parts = [p.strip() for p in str(text).split(",")]
    try:
        lat, lon, h = (float(p) for p in parts)
    except ValueError:
        raise ConfigError(f"site={text!r} is not LAT,LON,HEIGHT (deg, deg, m)") from None
    if not all(math.isfinite(x) for x in (lat, lon, h)):
        raise ConfigError(f"site={text!r} holds a non-finite number")
    if abs(lat) > 90:
        raise ConfigError(f"site={text!r}: latitude {lat:g}° lies outside ±90°")
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
    imu: str | os.PathLike[str] | NoiseSource | None = None,
    allow_gaps: bool = False,
    max_gap_samples: int = 5,
    model_update_s: float = 1.0,
    out_dt_s: float = 1.0,
    aiding: str = "none",
    gnss_sd_m: float = 2.0,
    track_velocity_sd: float = 0.1,
    progress: Callable[[float, float], None] | None = None,
    n_jobs: int | None = None,
    temperatures: Callable[[pd.DataFrame], None] | None = None,
) -> RecordedNavigation:
    """Navigate a recording with and without each thermal model.

    Parameters
    ----------
    path : path-like
        The recorded-navigation log (see :mod:`rinscal.io.navopen`).
    mapping : ColumnMapping, optional
        How to read a foreign file (``rinscal.io.mapping.read_mapping(path, "navigation")``
        reads a TOML file).
    run : str, optional
        Which run of a log with several.
    models : sequence of path-like
        Thermal model files; each gives a variant (one that holds an IMU calibration applies
        it first, as every compensator does).
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
    imu : str, path-like or ImuConfig, optional
        A preset, IMU TOML file or configuration whose noise the filter assumes (else the
        metadata's, else estimated on the window).
    allow_gaps : bool
        Integrate across gaps longer than ``max_gap_samples`` instead of refusing.
    model_update_s : float [s]
        Thermometer reading interval of the compensators.
    out_dt_s : float [s]
        Interval of the reported errors.
    aiding : {"none", "gnss"}
        ``"none"``: pure inertial after the alignment, the errors taken against the
        reference. ``"gnss"``: every variant navigates aided by the positions of ``track``
        (loosely coupled, :mod:`rinscal.nav.gnss_ins`), the errors taken against the same
        track (so they are not independent of it).
    gnss_sd_m : float [m]
        With ``aiding="gnss"`` or an in-motion alignment: standard deviation of each
        coordinate of the track's fixes that the filter assumes (an assumption, reported;
        not measured here).
    track_velocity_sd : float [m/s]
        With the same: standard deviation of each velocity component of a track that has
        them (``ref_ve_mps, ref_vn_mps, ref_vu_mps``), assumed likewise. A track is used at
        most :data:`~rinscal.nav.recorded.aided.TRACK_MAX_RATE_HZ` fixes a second (every
        k-th fix of a faster one).
    progress : callable, optional
        ``progress(done_s, total_s)`` [s of the recording]: ``total_s`` is NaN while the
        first pass reads the log (its length not known yet), then the log's length while it
        is navigated.
    n_jobs : int or None
        Threads (None/0: every core) for the variants and reading ahead; same result on 1.
    temperatures : callable, optional
        ``temperatures(frame)``: called once with the result's ``temperatures`` (read by the
        first pass) when the second pass has navigated its first piece, e.g. to draw their
        figure meanwhile; the frame is not to be changed.

    Returns
    -------
    Navigation
        ``result``: errors per variant (``none`` uncompensated, one per model, named by the
        model file's stem), the reference at the same times, the alignment per variant;
        ``report`` (JSON-able): ``log``, ``recording_kind`` (what the recording is:
        ``kind``, ``evidence``, ``text``, ``rate_hz``; :mod:`rinscal.nav.recorded.kind`),
        ``window`` (start, length, how it was chosen, its quality), ``noise`` (what the
        filter assumed and where it came from), ``at_rest`` (|f| and |ω| against gravity
        and the Earth rate), ``gaps``, ``rotation`` (what the encoder saw), ``reference``
        and ``warnings``; ``temperatures``: ``time_s, chamber, outer, sensor_<channel>``
        every :data:`TEMPERATURE_STEP_S` [s, °C] (NaN where the log has none);
        ``summary``: what ``summary.json`` holds.

    Raises
    ------
    LogError
        Among the reader's and the checks' refusals: a calibration log (named, pointed at
        ``fit`` or ``calibrate-imu``), a recording that moves with no still stretch to align
        on or a window set by hand that moves (said before any unit check); a refusal of the
        window finder names the rate.
    """
    _check.path_like("log", path)  # the types here (named as rinscal.navigate's), ranges below
    _check.instance(
        "mapping",
        mapping,
        ColumnMapping,
        'a ColumnMapping (rinscal.io.mapping.read_mapping(path, "navigation") reads a TOML file)',
        optional=True,
    )
    _check.instance("models", models, (list, tuple), "a list of model files' paths")
    for k, m in enumerate(models):
        _check.instance(f"models[{k}]", m, (str, os.PathLike), "a model file's path")
    _check.numbers_of("site", site, length=3, optional=True)
    for name, v in (("heading_deg", heading_deg), ("align_start_s", align_start_s)):
        _check.number(name, v, optional=True)
    for name, v in (
        ("align_s", align_s),
        ("min_align_s", min_align_s),
        ("model_update_s", model_update_s),
        ("out_dt_s", out_dt_s),
    ):
        _check.number(name, v)
    _check.number("max_gap_samples", max_gap_samples, integer=True, min=0)
    if aiding not in AIDING:
        raise ConfigError(f"aiding must be one of {', '.join(AIDING)}, got {aiding!r}")
    _check.number("gnss_sd_m", gnss_sd_m)
    if not gnss_sd_m > 0:
        raise ConfigError(f"gnss_sd_m must be > 0 m, got {gnss_sd_m}")
    _check.number("track_velocity_sd", track_velocity_sd)
    if not track_velocity_sd > 0:
        raise ConfigError(f"track_velocity_sd must be > 0 m/s, got {track_velocity_sd}")
    _check.flag("allow_gaps", allow_gaps)
    n_jobs = resolve_jobs(_check.number("n_jobs", n_jobs, min=0, integer=True, optional=True))
    _check.instance(
        "imu",
        imu,
        (str, os.PathLike, NoiseSource),
        "an IMU preset name, TOML file or ImuConfig",
        optional=True,
    )
    if policy not in POLICIES:
        raise ConfigError(f"policy={policy!r} is not one of {', '.join(POLICIES)}")
    if track_utc_start is not None:  # checked before the log is read, not only with a track
        if track is None:
            raise ConfigError(
                "track_utc_start= sets the clock of a reference track: give the track "
                "(track=) or drop it"
            )
        parse_utc(track_utc_start, "track_utc_start=")
    # what the recording is, first: a calibration log is named before its units are read
    head = nav_log_header(path, mapping)
    cal_kind, refuse = calibration_log(path, head.columns, head.meta, head.runs, run)
    if refuse is not None:
        raise LogError(refuse)
    log = open_nav_log(path, mapping, run=run)
    warnings: list[str] = []
    # everything that can be refused without reading the data, before reading it
    loaded = []
    for m in models:
        model = FittedModel.load(m)
        loaded.append((m, model))
        if not log.has_temps:
            raise ConfigError(
                f"{path}: a thermal model needs the sensor temperatures, and the log has none "
                "(temp_<channel> or temp_in columns, or a mapping's temperature)"
            )
        if model.imu_stage is not None:  # its raw units and unit against the recording's
            warnings += check_recording_for_imu(
                model.imu_stage, log.kind, log.units, _units_declared(log), log.meta,
                f"{path}", f"the IMU calibration of {m}",
            )  # fmt: skip
        comp = Compensator(model, policy=policy, update_s=model_update_s)
        if comp.needs_outer and not log.has_temp_out:
            raise ConfigError(
                f"{path}: the model {m} uses the gradient ΔT = T − temp_out, and the log has no "
                "outer temperature (a temp_out column, or a mapping's [columns] entry onto it)"
            )
    imu_noise = _imu_noise(imu) if imu is not None else None
    tr = None
    if track is not None:
        tr = read_track(track, track_utc_start or log.utc_start)
    if site is None:
        site = log.site
    if site is None and tr is not None:
        site = (float(tr.lat[0]), float(tr.lon[0]), float(tr.h[0]))
    if site is None:
        raise ConfigError(
            f"{path}: where was it recorded? Give its site (site=: latitude, "
            "longitude, height; the log's metadata has no site, and there is no reference track)"
        )
    # the body's true heading: --heading, else the log's ref_heading_deg column, else metadata
    if heading_deg is not None:
        heading_source = "--heading"
    elif log.has_ref_heading:
        heading_source = "the log's ref_heading_deg column"
    elif log.heading_deg is not None:
        heading_deg, heading_source = log.heading_deg, "metadata of the log"
    else:
        heading_source = "none (no heading error)"
    reference = Reference(
        lat=site[0],
        lon=site[1],
        h=site[2],
        heading=None if heading_deg is None else math.radians(heading_deg),
        track=None if tr is None else (tr.t, tr.lat, tr.lon, tr.h),
    )

    def pieces() -> Any:
        return log.pieces(
            max_gap_samples=max_gap_samples, allow_gaps=allow_gaps, threads=n_jobs > 1
        )

    # pass 1: per-second sums, the temperatures for the figure
    stats = BlockStats()
    temps: list[np.ndarray] = []
    refs: list[np.ndarray] = []  # the log's own track, a point a second (its speed)
    next_t = next_ref = -math.inf
    t_first = math.nan  # the start of the first sample's interval [s]
    # pieces read ahead: the reading goes on while this thread is held by work that keeps
    # the interpreter (numba's start at the first sums, 0.3-0.4 s, in which a reader takes
    # six to eight pieces of a 200 Hz recording); the second pass holds more of its own
    for s in read_ahead(pieces(), n_jobs, ahead=FIRST_PASS_AHEAD):
        stats.add(s)
        if s.n and math.isnan(t_first):
            t_first = float(s.t[0] - s.dt[0])
        if s.ref is not None and s.n:
            keep = _every(s.t, 1.0, next_ref)
            if keep.size:
                refs.append(np.column_stack([s.t[keep], s.ref[keep, :2]]))
                next_ref = float(s.t[keep[-1]]) + 1.0
        if s.temps is not None and s.n:
            keep = _every(s.t, TEMPERATURE_STEP_S, next_t)
            if keep.size:
                out = np.full(keep.size, np.nan) if s.temp_out is None else s.temp_out[keep]
                temps.append(np.column_stack([s.t[keep], out, s.temps[keep]]))
                next_t = float(s.t[keep[-1]]) + TEMPERATURE_STEP_S
        if progress is not None:
            progress(float(s.t[-1]) if s.n else 0.0, math.nan)
    blocks = stats.finish()
    frame = _temperature_frame(temps, float(blocks.t0[0]))
    dt = blocks.dt
    rate_meta = (log.meta or {}).get("rate_hz")
    if isinstance(rate_meta, int | float) and rate_meta > 0 and abs(1 / rate_meta - dt) < 1e-3 * dt:
        dt = 1.0 / float(rate_meta)  # the nominal interval exactly (times carry round-off)
    if blocks.dt_jitter > 0.005:
        warnings.append(
            f"the sample intervals scatter by {100 * blocks.dt_jitter:.1f} % about their mean "
            f"({1e3 * dt:.4g} ms): navigation steps by the mean; timestamps of a coarse clock "
            "are fine, a sampling that really jitters is not"
        )
    if stats.n_jumps:
        t, row, size = stats.jumps[0]
        warnings.append(
            f"the encoder angle jumps {stats.n_jumps} time(s), the first at {t:.3f} s (data row "
            f"{row}) by {size:.1f}° more than the gyro turned: heading errors near them are "
            "not to be trusted (navigation runs in the IMU frame and does not use the encoder)"
        )
    warnings += check_encoder(blocks)
    # moving or at rest, said before the window and the units are judged on it
    ref_track = np.concatenate(refs) if refs else None
    moved = motion(
        blocks,
        (tr.t, tr.lat, tr.lon) if tr is not None
        else None if ref_track is None
        else (ref_track[:, 0], ref_track[:, 1], ref_track[:, 2]),
    )  # fmt: skip
    kind, refuse = recording_motion(blocks, moved, min(min_align_s, align_s))
    rate_hz = 1.0 / dt
    # a moving recording with a track file and no still stretch: aligned in motion on it
    in_motion = refuse is not None and align_start_s is None and tr is not None
    aligner: Any = None
    if in_motion:
        duration = float(blocks.t1[-1]) - t_first
        noise, align, window, aligner = in_motion_alignment(
            log, imu_noise, lambda lg: _noise(lg, None, None, 0.0), tr, gnss_sd_m, dt,
            t_first, align_s, path, duration_s=duration, velocity_sd=track_velocity_sd,
        )  # fmt: skip
        at_rest: dict[str, Any] = {}
        in_motion_s = window.length_s
        warnings.append(
            f"the recording moves and has no still stretch: aligned in motion on the track "
            f"(OBA + GNSS, {in_motion_s:g} s, heading unknown), navigated from its end"
        )
        if in_motion_s < align_s:
            warnings.append(
                f"align_s={align_s:g} s leaves less than {IN_MOTION_NAV_MIN_S:g} s of the "
                f"{duration:.1f} s recording to navigate: aligned in motion on its first "
                f"{in_motion_s:.1f} s ({100 * IN_MOTION_SHARE:.0f} %), navigated the last "
                f"{duration - in_motion_s:.1f} s"
            )
    else:
        if refuse is None and align_start_s is not None:
            refuse = window_motion(blocks, moved, align_start_s, align_start_s + align_s)
        if refuse is not None:
            raise LogError(f"{path}: {refuse}")
        if cal_kind is not None:
            kind = replace(cal_kind, evidence={**cal_kind.evidence, "motion": kind.to_dict()})
        try:
            window = find_window(
                blocks if align_start_s is not None or not moved.moving.any()
                else still_blocks(blocks, moved),
                align_s, min_s=min_align_s, start_s=align_start_s,
            )  # fmt: skip
        except LogError as exc:  # name the rate: few samples a second at a low rate
            raise LogError(f"{path} ({rate_hz:.3g} Hz, {kind.kind}): {exc}") from None
        # a second holding one or two samples has no spread of |f| to judge it quiet by (1-2 Hz):
        # the window set by hand was checked for motion above, its quiet fraction says nothing
        judged = float(np.median(blocks.n)) >= 3
        if window.how == "given" and judged and window.quality.get("quiet_fraction", 1.0) < 0.9:
            warnings.append(
                f"only {100 * window.quality['quiet_fraction']:.0f} % of the seconds of the "
                "alignment window set by hand are quiet: the base moved while it aligned"
            )
        if (
            blocks.gaps is not None
            and blocks.gaps[blocks.select(window.start_s, window.end_s)].any()
        ):
            warnings.append("the alignment window holds a gap in time: the alignment steps over it")
        try:
            at_rest, warn = check_at_rest(
                blocks, window, reference.lat, reference.h, _declared_units(log)
            )
        except LogError as exc:
            low = f" ({rate_hz:.3g} Hz)" if rate_hz < 10 else ""
            raise LogError(f"{path}{low}: {exc} [{_unit_source(log)}]") from None
        warnings += warn
        noise = imu_noise or _noise(log, blocks, window, reference.lat)
        if not noise.source.startswith("estimated on the window"):
            at_rest["scatter"], warn = check_never_at_rest(
                blocks, window, noise.accel_density, noise.source
            )
            warnings += warn
        align = align_config(noise, window)

    comps: dict[str, Any] = {"none": None}
    for m, model in loaded:
        name = Path(m).stem
        while name in comps:
            name += "_"
        comps[name] = Compensator(model, policy=policy, update_s=model_update_s)

    total = float(blocks.t1[-1])

    handed = temperatures is None

    def tick(done: float) -> None:
        nonlocal handed
        if not handed:  # the second pass's threads are at work (numba kernels, mostly)
            handed = True
            temperatures(frame)  # type: ignore[misc]
        if progress is not None:
            progress(done, total)

    sched = seen_schedule(blocks)
    unseen, warn = check_turning_without_encoder(blocks, reference.lat, reference.h)
    if unseen:
        sched["source"] = "none (no encoder angle), but the z gyro shows a turntable turning"
        sched["turning_without_encoder"] = unseen
    warnings += warn
    aided: dict[str, Any] = {}
    if aiding == "gnss":
        if tr is None:
            raise ConfigError(
                f"{path}: aiding='gnss' takes its fixes from a reference track file (track=)"
            )
        aided = gnss_aiding(tr, noise, gnss_sd_m, dt, track_velocity_sd)
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
        use_heading_column=heading_source != "--heading",
        progress=tick,
        aligner=aligner,
        n_jobs=n_jobs,
        **aided,
    )
    warnings += list(result.config.notes)
    for name, c in comps.items():
        if c is not None and c.skipped:
            warnings.append(
                f"{name}: {c.skipped} thermometer reading(s) before the first complete one "
                "were skipped (the model compensated nothing until then)"
            )
    gaps = list(log.gaps)
    report: dict[str, Any] = {
        "log": str(path),
        "run": log.run,
        "kind": log.kind,
        "recording_kind": {**kind.to_dict(), "text": kind.text, "rate_hz": rate_hz},
        "window": {
            "start_s": window.start_s,
            "length_s": window.length_s,
            "how": window.how,
            **window.quality,
            "disturbed": [d.to_dict() for d in window.disturbed],
            "motion_limits": window.limits,
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
        "track": None
        if tr is None
        else {
            "file": str(track),
            "used": tr.used,
            "skipped": dict(tr.skipped),
            "velocities": tr.v_n is not None,
        },
        "heading_source": heading_source,
        # said only when in motion (a summary at rest stays as it was)
        **(
            {
                "alignment": f"in motion (OBA + GNSS, {window.length_s:g} s)",
                "in_motion": {
                    "align_s": window.length_s,
                    "coarse_s": in_motion_lengths(align_s, float(blocks.t1[-1]) - t_first)[1],
                    "align_s_asked": align_s,
                    "duration_s": float(blocks.t1[-1]) - t_first,
                    "track_velocities": tr is not None and tr.v_n is not None,
                },
            }
            if in_motion
            else {}
        ),
        **(
            {}
            if aiding == "none"
            else {
                "aiding": aiding,
                "gnss_sd_m": gnss_sd_m,
                **(
                    {"track_velocity_sd_mps": track_velocity_sd}
                    if tr is not None and tr.v_n is not None
                    else {}
                ),
                "aiding_note": GNSS_NOTE,
            }
        ),
        "site": {
            "lat_deg": math.degrees(reference.lat),
            "lon_deg": math.degrees(reference.lon),
            "h_m": reference.h,
        },
        "heading_deg": heading_deg,
        "models": {name: str(m) for name, m in zip(list(comps)[1:], models, strict=True)},
        # a model file holding an IMU calibration is applied in its order: the inverse sensor
        # model at the thermometer readings, then the thermal bias
        "imu_calibration": {
            name: c.stage is not None for name, c in comps.items() if c is not None
        },
        "policy": policy,
        "warnings": warnings,
    }
    return Navigation(result, frame, report=report, warnings=warnings)


def _temperature_frame(temps: list[np.ndarray], t0: float) -> pd.DataFrame:
    """The temperatures kept by the first pass (rows ``time, outer, six sensors``) as the
    result's frame, its clock from ``t0`` [s], the recording's start (a log may keep UNIX
    time): ``time_s, chamber`` (NaN), ``outer, sensor_<channel>`` [s, °C]."""
    temp = np.concatenate(temps) if temps else np.empty((0, 8))
    frame = pd.DataFrame({"time_s": temp[:, 0] - t0, "chamber": np.nan, "outer": temp[:, 1]})
    for j, c in enumerate(CHANNELS):
        frame[f"sensor_{c}"] = temp[:, 2 + j]
    return frame


def _every(t: np.ndarray, step: float, next_t: float) -> np.ndarray:
    """Indices of the first sample at or after each multiple of ``step`` from ``next_t``."""
    k = np.floor(t / step)
    first = np.flatnonzero(np.diff(k, prepend=-np.inf) != 0)
    return first[t[first] >= next_t - 1e-9]


def _imu_noise(imu: str | os.PathLike[str] | NoiseSource) -> Noise:
    """The noise of a plant (preset, TOML file or an ``ImuConfig``) the filter is told to
    assume (a configuration is read for its ``noise`` and ``name`` only: the recorded path
    imports no simulator module)."""
    if isinstance(imu, str | os.PathLike):
        noise = load_noise(imu)
    else:
        noise, imu = imu.noise, imu.name
    wd = noise.white_density_si()
    rw = noise.bias_rw_si()
    return Noise(float(wd[0]), float(wd[3]), float(rw[0]), float(rw[3]), f"--imu {imu}")


def _units_declared(log: Any) -> bool:
    """Whether a mapping or the metadata declared the recording's rate units."""
    return bool(log.mapping is not None and log.mapping.units) or bool(
        (log.meta or {}).get("units")
    )


def _declared_units(log: Any) -> dict[str, str | None]:
    """The unit a rate log was read in, by sensor type (None: not rates, or mixed)."""
    out: dict[str, str | None] = {}
    for sensor in ("gyro", "accel"):
        seen = {log.units.get(c) for c in CHANNELS if c.startswith(sensor)}
        out[sensor] = seen.pop() if log.kind == "rates" and len(seen) == 1 else None
    return out


def _unit_source(log: Any) -> str:
    """Where the log's units came from, for a message about them."""
    if log.kind == "counts":
        given = log.mapping is not None and bool(getattr(log.mapping, "weights", None))
        return "counts × the " + ("mapping's [weights]" if given else "metadata's weights")
    if log.kind == "increments":
        return "increments in rad and m/s"
    src = (
        "the mapping's [units]"
        if log.mapping is not None and log.mapping.units
        else (
            "the metadata's units"
            if (log.meta or {}).get("units")
            else "the default units: no [units] in a mapping, no units in the metadata"
        )
    )
    by_unit: dict[str, list[str]] = {}
    for c in CHANNELS:
        by_unit.setdefault(str(log.units.get(c)), []).append(c)
    said = "; ".join(f"{', '.join(cs)} in {u}" for u, cs in by_unit.items())
    return f"rates read as {said}, from {src}"


def _noise(log: Any, blocks: Any, window: Any, lat: float) -> Noise:
    """The filter's sensor noise: the log's metadata, else estimated on the window (from its
    Allan deviation, :mod:`rinscal.nav.recorded.noise`)."""
    meta = log.noise
    if meta:
        try:
            q_th = float(meta.get("gyro_angle_noise", 0.0))
            q_v = float(meta.get("accel_velocity_noise", 0.0))
            if not (q_th >= 0 and q_v >= 0 and math.isfinite(q_th + q_v)):
                raise ValueError("negative")
            return Noise(
                float(meta["gyro_noise_density"]),
                float(meta["accel_noise_density"]),
                float(meta.get("gyro_bias_rw", 0.0)),
                float(meta.get("accel_bias_rw", 0.0)),
                "metadata of the log",
                gyro_angle_white=q_th,
                accel_velocity_white=q_v,
                velocity_meas_sd=(
                    velocity_meas_sd(q_v, q_th, KF_INTERVAL_S) if q_th > 0 or q_v > 0 else None
                ),
            )
        except (KeyError, TypeError, ValueError):
            raise ConfigError(
                f"{log.path}: metadata 'noise' needs gyro_noise_density [rad/√s] and "
                f"accel_noise_density [m/s²/√Hz] (optionally gyro_bias_rw, accel_bias_rw, "
                f"gyro_angle_noise [rad], accel_velocity_noise [m/s], none negative), "
                f"got {meta!r}"
            ) from None
    return estimate_noise_allan(blocks, window, lat=lat)


def heading_text(report: dict[str, Any]) -> str:
    """One line on the window for the terminal."""
    w = report["window"]
    a = round(w["start_s"], 3) + 0.0  # never "-0" for a clock starting a hair before 0
    if w["how"] == "in motion":
        return (
            f"alignment {a:.0f}-{a + w['length_s']:.0f} s {report['alignment']}, heading "
            "unknown: coarse on the track's velocity changes, then the filter on its "
            "positions; " + noise_text(report["noise"])
        )
    return (
        f"alignment window {a:.0f}-{a + w['length_s']:.0f} s ({w['how']}"
        f", |f| spread median {w['sd_ug_median']:.0f} µg against a floor of "
        f"{w['floor_ug']:.0f} µg, {100 * w['quiet_fraction']:.0f} % of its seconds quiet); "
        + noise_text(report["noise"])
        + "".join(f"\n{_disturbed_text(d)}" for d in w.get("disturbed", [])[:5])
    )


def _disturbed_text(d: dict[str, Any]) -> str:
    """One disturbed stretch of the report, in words (as :meth:`Disturbance.text`)."""
    tilt = [(s["time_s"], s["arcsec"]) for s in d.get("tilt_steps", [])]
    return Disturbance(
        d["start_s"],
        d["end_s"],
        d["seconds_moving"],
        math.nan if d["gyro_peak_dph"] is None else d["gyro_peak_dph"],
        math.nan if d["accel_peak_mg"] is None else d["accel_peak_mg"],
        tuple(tilt),
        d.get("tilt_count", len(tilt)),
    ).text()


__all__ = ["TEMPERATURE_STEP_S", "RecordedNavigation", "heading_text", "navigate_log", "parse_site"]
