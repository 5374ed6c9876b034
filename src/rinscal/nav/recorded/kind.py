"""What a recording is, said before anything about it is checked: at rest, moving, or a
calibration log that is not a navigation recording at all.

Every check of ``navigate --log`` after this one (the window finder, the units at rest, the
latitude the gyros measure) assumes a base at rest for the alignment. A recording of a
vehicle that drives from its first second breaks that assumption, and the checks then
refuse it for the wrong reason ("wrong gyro units"); a chamber or turntable calibration log
was never meant to be navigated. So the recording is named first:

* a **calibration log** (:func:`calibration_log`): the calibration-log schema of the README
  (several runs with a chamber or outer temperature, the two-axis turntable's
  ``table_outer_deg`` / ``table_inner_deg``, or its metadata's ``protocol``), pointed at
  ``rinscal fit`` or ``rinscal calibrate-imu``;
* a **moving** recording (:func:`motion`): seconds in which the reference track's speed,
  the rotation beyond the Earth rate and the table's own turn, or the specific force
  across gravity is beyond anything a parked vehicle shows. The thresholds are coarse on
  purpose (a metre a second, 3 °/s, 0.5 m/s²): people moving about a parked vehicle sway
  it by a few hundred °/h and tilt it by arc-minutes, far below them, so a parked vehicle is
  never called moving; a car in traffic crosses them within seconds.

Everything is SI inside (s, rad, rad/s, m/s, m/s²); messages say °/s and m/s.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rinscal import earth, units
from rinscal.nav.recorded.blocks import Blocks

__all__ = [
    "ACCEL_TRUSTED_FRACTION",
    "CALIBRATION_PROTOCOLS",
    "GYRO_TRUSTED_EARTH_RATES",
    "G_NOMINAL",
    "MOVING_FORCE_MPS2",
    "MOVING_MIN_S",
    "MOVING_RATE_DPS",
    "MOVING_SPEED_MPS",
    "SPEED_SPAN_S",
    "TURNTABLE_COLUMNS",
    "Motion",
    "RecordingKind",
    "calibration_log",
    "motion",
    "moving_message",
    "recording_motion",
    "still_blocks",
    "track_speed",
    "window_motion",
]

#: A reference track faster than this [m/s] (over :data:`SPEED_SPAN_S`) is moving: a
#: stand-alone GNSS fix wanders by a metre or two, 0.1-0.2 m/s over that span.
MOVING_SPEED_MPS = 1.0
#: The span over which the track's speed is taken [s] (displacement / span).
SPEED_SPAN_S = 10.0
#: Rotation beyond the Earth rate and the table's own turn that is a vehicle's [°/s] (a
#: parked vehicle with people about it sways by 0.1-0.2 °/s; a car turns at 5-20 °/s).
MOVING_RATE_DPS = 3.0
#: Change of the specific force across the gravity direction (a second's mean) beyond the
#: tilt a parked vehicle allows [m/s²] (0.5 m/s² is a 3° tilt; a car accelerates, brakes
#: and turns at 0.5-4 m/s²).
MOVING_FORCE_MPS2 = 0.5
#: Seconds of motion, in all, that make a recording "moving" (a door slammed is one).
MOVING_MIN_S = 5.0
#: A median rate (the rate at rest) beyond this many Earth rates, or below its inverse, is a
#: unit mix-up or a bias the checks at rest refuse: the gyros are then no evidence of motion.
GYRO_TRUSTED_EARTH_RATES = 20.0
#: A median ``|f|`` farther from g than this fraction is a unit mix-up: the accelerometers
#: are then no evidence of motion.
ACCEL_TRUSTED_FRACTION = 0.1
#: Gravity for that test [m/s²] (within 0.3 % anywhere on Earth's surface).
G_NOMINAL = 9.80665
#: A calibration log's metadata ``protocol`` and what it calibrates.
CALIBRATION_PROTOCOLS: dict[str, str] = {
    "soak": "thermal",
    "ramp": "thermal",
    "repeat": "thermal",
    "multiposition": "turntable",
}
#: The two-axis turntable's columns of a multiposition calibration log.
TURNTABLE_COLUMNS = (
    "table_outer_deg",
    "table_inner_deg",
    "table_outer_rate_dps",
    "table_inner_rate_dps",
)
#: Temperature columns of a chamber calibration log.
_CHAMBER_COLUMNS = ("chamber_temp", "temp_out")
#: Columns only a navigation recording has (its encoder, its reference).
_NAV_ONLY_COLUMNS = ("table_deg", "ref_lat_deg", "ref_heading_deg")


@dataclass(frozen=True)
class RecordingKind:
    """What a recording is.

    Attributes
    ----------
    kind : str
        ``"at rest"``, ``"moving"``, ``"at rest, moving in part"``, ``"calibration log"``
        or ``"calibration log run"`` (one run of one, chosen with ``--run``).
    evidence : dict
        JSON-able: what was seen (track speed [m/s], rates [°/s], force [m/s²], seconds
        moving, columns, runs, metadata protocol).
    text : str
        One line for the terminal.
    """

    kind: str
    evidence: dict[str, Any] = field(default_factory=dict)
    text: str = ""

    def to_dict(self) -> dict[str, Any]:
        return {"kind": self.kind, "evidence": self.evidence}


# --------------------------------------------------------------------------- calibration log
def calibration_log(
    path: Any,
    columns: Sequence[str],
    meta: Mapping[str, Any] | None,
    runs: Sequence[str] | None,
    run: str | None = None,
) -> tuple[RecordingKind | None, str | None]:
    """Whether a file is a calibration log (the README's schema), and whether to refuse it.

    It is one when its metadata's ``protocol`` is a calibration protocol, when it has the
    two-axis turntable's columns, or when it holds several runs with a ``chamber_temp``
    column, or a ``temp_out`` column and none of a navigation recording's own (``table_deg``,
    ``ref_*``).

    Parameters
    ----------
    path : path-like
        The file (for messages).
    columns : sequence of str
        Its header.
    meta : mapping, optional
        Its sidecar metadata.
    runs : sequence of str, optional
        The names in its ``run`` column (None: no such column, or not read).
    run : str, optional
        The run chosen with ``--run``.

    Returns
    -------
    (RecordingKind or None, str or None)
        The kind (None: not a calibration log) and the refusal (None: navigate it). A
        turntable log is always refused (the IMU tumbles through positions and rate tests);
        a thermal one unless a run was chosen (a run of a chamber soak at rest can be
        navigated as a static recording, if it is long and fast enough).
    """
    meta = meta or {}
    cols = set(columns)
    protocol = meta.get("protocol")
    protocol = protocol if isinstance(protocol, str) and protocol in CALIBRATION_PROTOCOLS else None
    table = [c for c in TURNTABLE_COLUMNS[:2] if c in cols]
    chamber = [c for c in _CHAMBER_COLUMNS if c in cols]
    several = runs is not None and len(runs) > 1
    # temp_out alone: a navigation log may have it too, but not the encoder or a reference
    nav_only = any(c in cols for c in _NAV_ONLY_COLUMNS)
    thermal = "chamber_temp" in chamber or (bool(chamber) and not nav_only)
    if not (protocol or table or (several and thermal)):
        return None, None
    what = "turntable" if (table or protocol == "multiposition") else "thermal"
    seen: list[str] = []
    if runs is not None:
        shown = ", ".join(repr(r) for r in list(runs)[:4]) + (", ..." if len(runs) > 4 else "")
        seen.append(f"{len(runs)} run(s) {shown}")
    if table or chamber:
        seen.append("columns " + ", ".join(table + chamber))
    if protocol:
        seen.append(f"metadata protocol {protocol!r}")
    rate = meta.get("rate_hz")
    if isinstance(rate, int | float) and not isinstance(rate, bool) and rate > 0:
        seen.append(f"{rate:g} Hz")
    evidence: dict[str, Any] = {
        "calibrates": what,
        "runs": None if runs is None else len(runs),
        "columns": table + chamber,
        "protocol": protocol,
    }
    said = f"{path} is a {what} calibration log ({'; '.join(seen)}), not a navigation recording"
    if what == "turntable":
        refuse = (
            f"{said}: the IMU is turned through positions and rate tests on a two-axis "
            f"turntable. Calibrate the IMU with `rinscal calibrate-imu {path} --out imu.json` "
            "(then `rinscal fit LOG --imu-cal imu.json` on a thermal calibration log), and "
            "navigate a recording of the IMU at rest or on its single-axis table with "
            "--model M.json"
        )
        return RecordingKind("calibration log", evidence, said), refuse
    if run is None:
        refuse = (
            f"{said}: fit a thermal model on it with `rinscal fit {path} --out M.json`, then "
            "navigate a recording with --model M.json. To navigate one of its runs as a static "
            "recording anyway, choose it with run= (the alignment needs at least 5 min at "
            "rest, sampled at 10 Hz or more)"
        )
        return RecordingKind("calibration log", evidence, said), refuse
    evidence["run"] = run
    text = (
        f"recording: run {run!r} of a thermal calibration log ({'; '.join(seen)}), "
        "navigated at rest"
    )
    return RecordingKind("calibration log run", evidence, text), None


# --------------------------------------------------------------------------- motion
@dataclass(frozen=True)
class Motion:
    """Which seconds of the recording move, and why.

    Attributes
    ----------
    moving : ndarray of bool
        Per block of the first pass.
    by_track, by_rate, by_force : ndarray of bool
        The evidence, per block: the track's speed, rotation beyond rest, specific force
        across gravity.
    speed : ndarray [m/s]
        The track's speed at each block's middle (NaN outside the track).
    rate : ndarray [rad/s]
        Rotation beyond the rate at rest (the recording's median: Earth rate and bias) and
        the encoder's turn.
    yaw : ndarray [rad/s]
        Rotation about the gravity direction, the rate at rest and the encoder's turn
        removed.
    force : ndarray [m/s²]
        Change of the specific force across gravity from its median.
    """

    moving: NDArray[np.bool_]
    by_track: NDArray[np.bool_]
    by_rate: NDArray[np.bool_]
    by_force: NDArray[np.bool_]
    speed: NDArray[np.float64]
    rate: NDArray[np.float64]
    yaw: NDArray[np.float64]
    force: NDArray[np.float64]

    @property
    def sustained(self) -> bool:
        """Whether the recording moves for at least :data:`MOVING_MIN_S` in all."""
        return bool(self.moving.sum() >= MOVING_MIN_S)


def track_speed(
    t_track: NDArray[np.float64],
    lat: NDArray[np.float64],
    lon: NDArray[np.float64],
    at: NDArray[np.float64],
    span_s: float = SPEED_SPAN_S,
) -> NDArray[np.float64]:
    """Horizontal speed of a track [m/s] at times ``at`` [s]: the displacement between
    ``at ± span_s/2`` (interpolated, each end held within the track) over the time between.

    Parameters
    ----------
    t_track : ndarray [s]
        The track's times (increasing).
    lat, lon : ndarray [rad]
    at : ndarray [s]
        Where the speed is wanted; NaN outside the track's span.
    span_s : float [s]
        The span the displacement is taken over (a GNSS fix's metre of wander becomes
        1/span m/s).
    """
    t_track = np.asarray(t_track, dtype=float)
    lat, lon = np.asarray(lat, dtype=float), np.asarray(lon, dtype=float)
    ok = np.isfinite(t_track) & np.isfinite(lat) & np.isfinite(lon)  # empty cells left out
    t_track, lat, lon = t_track[ok], lat[ok], lon[ok]
    at = np.asarray(at, dtype=float)
    out = np.full(at.shape, np.nan)
    if t_track.size < 2:
        return out
    a = np.clip(at - 0.5 * span_s, t_track[0], t_track[-1])
    b = np.clip(at + 0.5 * span_s, t_track[0], t_track[-1])
    inside = (at >= t_track[0]) & (at <= t_track[-1]) & (b - a > 0)
    lat_a, lat_b = np.interp(a, t_track, lat), np.interp(b, t_track, lat)
    lon_a, lon_b = np.interp(a, t_track, np.unwrap(lon)), np.interp(b, t_track, np.unwrap(lon))
    rn, re = earth.principal_radii(0.5 * (lat_a + lat_b))
    north = (lat_b - lat_a) * rn
    east = (lon_b - lon_a) * re * np.cos(0.5 * (lat_a + lat_b))
    with np.errstate(invalid="ignore", divide="ignore"):
        out[inside] = (np.hypot(north, east) / (b - a))[inside]
    return out


def motion(
    blocks: Blocks,
    track: tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]] | None = None,
) -> Motion:
    """Which seconds move: the track's speed, rotation or specific force beyond rest.

    Parameters
    ----------
    blocks : Blocks
        The first pass (per-second means of rate and force in the IMU frame).
    track : (t [s], lat [rad], lon [rad]), optional
        A reference track on the recording's clock.

    Notes
    -----
    * Rotation beyond rest: ``|ω − ω₀|``, ω₀ the recording's median rate (the Earth rate and
      the gyro bias), with the encoder's turn removed about z. Without an encoder a turn
      about z alone may be an unrecorded turntable at rest, so only the x and y rates count
      then (a vehicle that turns feels the centripetal force, counted below); with one, only
      the seconds the table stands still. Gyros whose median is beyond
      :data:`GYRO_TRUSTED_EARTH_RATES` Earth rates (or below its inverse), and accelerometers
      whose median ``|f|`` is off g by :data:`ACCEL_TRUSTED_FRACTION`, are read in a wrong
      unit: they are no evidence (the checks at rest name the unit).
    * Specific force across gravity: the component of each second's mean ``f`` normal to
      the recording's median direction of ``f``, less its median; a tilted IMU on a turning
      table moves it by twice its tilt (0.2 m/s² for 1°), a parked vehicle by less.
    """
    w = blocks.rate_less_table()
    f = blocks.f_mean
    u = np.median(f, axis=0)
    u = u / max(float(np.linalg.norm(u)), 1e-300)
    # the rate at rest (Earth rate and bias) is the recording's median; what varies about it
    # is motion. A median far beyond the Earth rate is a unit the checks at rest will name,
    # not motion (its noise, scaled by the wrong factor, could pass for it): not counted.
    w0 = np.median(w, axis=0)
    dw = w - w0
    yaw = dw @ u
    beyond = np.linalg.norm(dw if blocks.has_table else dw[:, :2], axis=1)
    r0 = float(np.linalg.norm(w0)) / earth.RATE
    gyro_ok = 1 / GYRO_TRUSTED_EARTH_RATES <= r0 <= GYRO_TRUSTED_EARTH_RATES
    fmag = float(np.median(blocks.fmag_mean))
    accel_ok = abs(fmag / G_NOMINAL - 1.0) <= ACCEL_TRUSTED_FRACTION
    perp = f - np.outer(f @ u, u)
    force = np.linalg.norm(perp - np.median(perp, axis=0), axis=1)
    by_rate = (beyond > MOVING_RATE_DPS * units.DEG_TO_RAD) & gyro_ok
    if blocks.has_table:  # where the table turns, a wrong encoder unit or sign would pass
        by_rate &= np.abs(blocks.table_turn / blocks.span) < 0.1 * units.DEG_TO_RAD  # for motion
    by_force = (force > MOVING_FORCE_MPS2) & accel_ok
    if track is not None:
        speed = track_speed(*track, at=0.5 * (blocks.t0 + blocks.t1))
    else:
        speed = np.full(blocks.t0.shape, np.nan)
    by_track = np.nan_to_num(speed, nan=0.0) > MOVING_SPEED_MPS
    return Motion(
        moving=by_track | by_rate | by_force,
        by_track=by_track,
        by_rate=by_rate,
        by_force=by_force,
        speed=speed,
        rate=beyond,
        yaw=np.abs(yaw),
        force=force,
    )


def still_blocks(blocks: Blocks, mo: Motion) -> Blocks:
    """The first pass with the moving seconds marked as gaps: no window finder takes them
    (the window's own checks still see the recording as it is)."""
    gaps = mo.moving if blocks.gaps is None else (blocks.gaps | mo.moving)
    return replace(blocks, gaps=gaps)


def _stretches(mask: NDArray[np.bool_]) -> list[tuple[int, int]]:
    q = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(q == 1).tolist(), np.flatnonzero(q == -1).tolist(), strict=True))


def _evidence(blocks: Blocks, mo: Motion, sel: NDArray[np.bool_]) -> tuple[dict[str, Any], str]:
    """What moved within the blocks ``sel``: JSON-able and in words."""
    m = mo.moving & sel
    ev: dict[str, Any] = {"moving_s": float(np.sum((blocks.t1 - blocks.t0)[m]))}
    said: list[str] = []
    if m.any():
        ev["from_s"] = float(blocks.t0[np.argmax(m)])
    if (mo.by_track & sel).any():
        v = mo.speed[mo.by_track & sel]
        lo, hi = np.percentile(v, [10, 90])
        t = float(blocks.t0[np.argmax(mo.by_track & sel)])
        ev["track_speed_mps"] = [float(lo), float(hi)]
        rng = f"{lo:.0f}-{hi:.0f}" if round(hi) > round(lo) else f"{hi:.0f}"
        if hi < 2:
            rng = f"{lo:.1f}-{hi:.1f}"
        said.append(f"track speed {rng} m/s from {t:.0f} s")
    if m.any():
        yaw = float(np.max(mo.yaw[m])) / units.DEG_TO_RAD
        rate = float(np.max(mo.rate[m])) / units.DEG_TO_RAD
        force = float(np.max(mo.force[m]))
        ev.update(yaw_dps_max=yaw, rate_dps_max=rate, force_mps2_max=force)
        if (mo.by_rate & sel).any() or yaw > MOVING_RATE_DPS:
            said.append(f"yaw rates up to {yaw:.0f} °/s")
        if (mo.by_force & sel).any():
            said.append(f"specific force across gravity up to {force:.1f} m/s²")
    return ev, "; ".join(said)


def recording_motion(blocks: Blocks, mo: Motion, min_s: float) -> tuple[RecordingKind, str | None]:
    """The recording named by its motion, and the refusal when it has no still stretch of
    ``min_s`` [s] to align on (None: it has one, or does not move)."""
    everything = np.ones(blocks.t0.shape, dtype=bool)
    ev, said = _evidence(blocks, mo, everything)
    if not mo.sustained:
        text = "at rest" + ("" if not mo.moving.any() else f" ({ev['moving_s']:.0f} s of jolts)")
        return RecordingKind("at rest", ev, f"recording: {text}"), None
    longest = (0.0, 0.0)
    for a, b in _stretches(~mo.moving):
        t0, t1 = float(blocks.t0[a]), float(blocks.t1[b - 1])
        if t1 - t0 > longest[1]:
            longest = (t0, t1 - t0)
    ev["longest_still_s"] = longest[1]
    ev["longest_still_from_s"] = longest[0]
    if longest[1] >= min_s - 0.5 * blocks.dt:
        text = (
            f"recording: at rest {longest[0]:.0f}-{sum(longest):.0f} s, moving "
            f"{ev['moving_s']:.0f} s in all ({said})"
        )
        return RecordingKind("at rest, moving in part", ev, text), None
    kind = RecordingKind("moving", ev, f"recording: moving ({said})")
    return kind, moving_message(said, longest, min_s)


def window_motion(blocks: Blocks, mo: Motion, start_s: float, end_s: float) -> str | None:
    """The refusal of an alignment window set by hand that moves (None: it is still)."""
    sel = blocks.select(start_s, end_s)
    if int((mo.moving & sel).sum()) < 2:
        return None
    _, said = _evidence(blocks, mo, sel)
    still = [(float(blocks.t0[a]), float(blocks.t1[b - 1])) for a, b in _stretches(~mo.moving)]
    longest = max(still, key=lambda s: s[1] - s[0], default=(0.0, 0.0))
    return moving_message(
        said, (longest[0], longest[1] - longest[0]), end_s - start_s, (start_s, end_s)
    )


def moving_message(
    said: str,
    longest: tuple[float, float],
    min_s: float,
    given: tuple[float, float] | None = None,
) -> str:
    """The refusal of a recording (or a window set by hand) that moves.

    Parameters
    ----------
    said : str
        What moved, in words.
    longest : (start [s], length [s])
        The longest still stretch.
    min_s : float [s]
        The alignment length wanted.
    given : (start [s], end [s]), optional
        The window set by hand.
    """
    what = (
        f"the alignment window set by hand ({given[0]:.0f}-{given[1]:.0f} s) moves"
        if given is not None
        else "the recording moves"
    )
    still = (
        f"the longest still stretch is {longest[1]:.0f} s from {longest[0]:.0f} s"
        if longest[1] > 0
        else "no second of it is still"
    )
    where = (
        f"set the window on a still stretch ({still}) or stop"
        if given is not None
        else f"no still stretch of {min_s:.0f} s is in it ({still}); stop"
    )
    return (
        f"{what} ({said}): the alignment needs the vehicle at rest; {where} for 5-10 min for "
        "the alignment"
        + (
            ""
            if given is not None
            else ", or give its reference track file (track=) to align it in motion"
        )
    )
