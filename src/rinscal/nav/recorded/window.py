"""From the first pass's sums: the alignment window, the sensor noise, the plausibility checks
and what the turntable did.

What "quiet" means is told in :mod:`~rinscal.nav.recorded.motion` (:func:`motion`): the
window is the earliest quiet stretch long enough; where the recording moved is reported with
it. The checks at rest use means over the window (a median of magnitudes is biased low).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rinscal import earth, units
from rinscal.errors import ConfigError, LogError
from rinscal.nav.align import AlignConfig, align_from_noise
from rinscal.nav.recorded.blocks import BLOCK_S, Blocks
from rinscal.nav.recorded.motion import (
    FLOOR_PERCENTILE,
    MAX_LISTED,
    QUIET_FACTOR,
    TABLE_RATE_DPS,
    TABLE_STILL_DPS,
    Disturbance,
    Motion,
    motion,
    quiet_blocks,
    robust_limit,
    table_frame,
)

__all__ = [
    "FLOOR_PERCENTILE",
    "LATITUDE_TOL_DEG",
    "MIN_WINDOW_S",
    "QUIET_FACTOR",
    "Disturbance",
    "Motion",
    "Noise",
    "Window",
    "align_config",
    "check_at_rest",
    "check_encoder",
    "check_never_at_rest",
    "check_turning_without_encoder",
    "estimate_noise",
    "find_window",
    "motion",
    "quiet_blocks",
    "robust_limit",
    "seen_schedule",
    "table_frame",
]

#: Turned about z at rest, in all, beyond which a log without encoder angle is warned of [°].
TABLE_TURN_DEG = 20.0
#: What "at rest" allows the horizontal specific force to change while turning [m/s²] (2 mg:
#: a vehicle that turns at 1 °/s while moving at 1 m/s feels 17 mg).
AT_REST_HORIZONTAL_MPS2 = 2e-3 * 9.80665

#: Shortest stretch the window finder accepts [s] (the issue's "at least 300 s").
MIN_WINDOW_S = 300.0
#: The averaging time at which the window's scatter is compared with the noise told [s].
AT_REST_TAU_S = 10.0
#: The latitude the gyros measure at rest may differ from the site's by this much [deg]
#: before the site is questioned (a 0.1 °/h gyro bias moves it by about 0.4°).
LATITUDE_TOL_DEG = 2.0


# --------------------------------------------------------------------------- the window
@dataclass(frozen=True)
class Window:
    """The alignment window and how it was chosen.

    Attributes
    ----------
    start_s, length_s : float [s]
        Start (time since the recording's time origin) and length.
    how : {"found", "given"}
        Found by :func:`find_window` or set by hand.
    quality : dict
        ``floor_ug`` (the recording's noise floor of ``|f|`` per sample), ``threshold_ug``,
        ``sd_ug_median`` and ``sd_ug_max`` (spread of ``|f|`` within the window's seconds),
        ``quiet_fraction`` (of its seconds), ``stretch_s`` (length of the quiet stretch it
        starts, when found).
    disturbed : tuple of Disturbance
        Where the recording moved (all of it, not only before the window).
    limits : dict
        The limits of motion judged (:attr:`Motion.limits`).
    """

    start_s: float
    length_s: float
    how: str
    quality: dict[str, float] = field(default_factory=dict)
    disturbed: tuple[Disturbance, ...] = ()
    limits: dict[str, float] = field(default_factory=dict)

    def text(self) -> str:
        """Where the recording moved and where the window lies, e.g. ``"0-540 s disturbed:
        gyro peaks 730 °/h, tilt step at 540 s; window 560-1160 s"``."""
        a = round(self.start_s, 3) + 0.0
        said = [d.text() for d in self.disturbed[:MAX_LISTED]]
        if len(self.disturbed) > MAX_LISTED:
            said.append(f"{len(self.disturbed) - MAX_LISTED} more disturbed stretch(es)")
        return "; ".join([*said, f"window {a:.0f}-{a + self.length_s:.0f} s"])

    @property
    def end_s(self) -> float:
        return self.start_s + self.length_s


def _stretches(quiet: NDArray[np.bool_]) -> list[tuple[int, int]]:
    """[a, b) index ranges of consecutive True."""
    q = np.concatenate([[False], quiet, [False]]).astype(np.int8)
    d = np.diff(q)
    return list(zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist(), strict=True))


def find_window(
    blocks: Blocks,
    align_s: float,
    min_s: float = MIN_WINDOW_S,
    start_s: float | None = None,
) -> Window:
    """The alignment window: the earliest quiet stretch of at least ``min_s``, up to ``align_s``.

    Parameters
    ----------
    blocks : Blocks
        The first pass.
    align_s : float [s]
        Longest alignment wanted (the window is cut to it).
    min_s : float [s]
        Shortest acceptable window (at most ``align_s``).
    start_s : float, optional [s]
        Set the window by hand: ``[start_s, start_s + align_s)``; it is checked (its quiet
        fraction reported) but not moved.

    Raises
    ------
    LogError
        When no quiet stretch is long enough (naming the quietest found), or a given window
        lies outside the recording.
    """
    if not (math.isfinite(align_s) and align_s > 0):
        raise ConfigError(f"alignment length must be > 0 s, got {align_s}")
    mot = motion(blocks)
    quiet, floor, thr = mot.quiet, mot.floor, mot.threshold
    ug = units.UG_TO_MPS2
    base = {"floor_ug": floor / ug}
    if math.isfinite(thr):  # at a low rate no spread is judged
        base["threshold_ug"] = thr / ug
    said = {"disturbed": mot.disturbed, "limits": mot.limits}
    t_first, t_last = float(blocks.t0[0]), float(blocks.t1[-1])

    def rate(sel: NDArray[np.bool_]) -> dict[str, float]:
        sd = blocks.fmag_sd[sel]
        return {
            **base,
            "sd_ug_median": float(np.median(sd)) / ug if sd.size else float("nan"),
            "sd_ug_max": float(np.max(sd)) / ug if sd.size else float("nan"),
            "quiet_fraction": float(np.mean(quiet[sel])) if sd.size else 0.0,
        }

    if start_s is not None:
        end = start_s + align_s
        if start_s < t_first - 1e-9 or end > t_last + 1e-6:
            raise LogError(
                f"alignment window {start_s:g}-{end:g} s lies outside the recording "
                f"({t_first:g}-{t_last:g} s)"
            )
        return Window(start_s, align_s, "given", rate(blocks.select(start_s, end)), **said)
    min_s = min(min_s, align_s)
    best: tuple[float, float] = (float("nan"), 0.0)
    for a, b in _stretches(quiet):
        t0, t1 = float(blocks.t0[a]), float(blocks.t1[b - 1])
        if t1 - t0 > best[1]:
            best = (t0, t1 - t0)
        if t1 - t0 >= min_s - 0.5 * blocks.dt:
            length = min(t1 - t0, align_s)
            q = rate(blocks.select(t0, t0 + length))
            q["stretch_s"] = t1 - t0
            return Window(t0, length, "found", q, **said)
    what = (
        f"the longest quiet stretch is {best[1]:.0f} s from {best[0]:.0f} s"
        if best[1] > 0
        else "no second of it is quiet"
    )
    moved = "; ".join(d.text() for d in mot.disturbed[:3])
    raise LogError(
        f"no static window of at least {min_s:g} s to align on: {what} (quiet: {mot.judged})"
        f"{'; ' + moved if moved else ''}; set one by hand with align_start_s= and align_s="
    )


# --------------------------------------------------------------------------- noise, checks
@dataclass(frozen=True)
class Noise:
    """White-noise densities and bias random walks the alignment filter assumes.

    Attributes
    ----------
    gyro_density : float [rad/√s]
        Angle random walk ``N`` (the filter's gyro process noise).
    accel_density : float [m/s²/√Hz]
        Velocity random walk ``N`` (its accelerometer process noise).
    gyro_bias_rw : float [rad/s/√s]
    accel_bias_rw : float [m/s²/√s]
    source : str
        ``"metadata of the log"``, ``"--imu NAME"`` or ``"estimated on the window
        (Allan: ...)"``.
    gyro_angle_white : float [rad]
        White angle noise / quantisation ``Q`` of the gyros (0: none known).
    accel_velocity_white : float [m/s]
        White velocity noise / quantisation ``Q`` of the accelerometers (0: none known).
    velocity_meas_sd : float or None [m/s]
        The zero-velocity measurement's sd the filter gets (None: its default).
    allan : dict or None
        What the Allan curves of the window showed (:mod:`~rinscal.nav.recorded.noise`).
    """

    gyro_density: float
    accel_density: float
    gyro_bias_rw: float = 0.0
    accel_bias_rw: float = 0.0
    source: str = "given"
    gyro_angle_white: float = 0.0
    accel_velocity_white: float = 0.0
    velocity_meas_sd: float | None = None
    allan: dict[str, Any] | None = None

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "source": self.source,
            "gyro_arw_deg_per_rth": self.gyro_density / units.DPRH_TO_RPRS,
            "accel_vrw_ug_per_rthz": self.accel_density / units.UG_TO_MPS2,
        }
        if self.gyro_angle_white > 0 or self.accel_velocity_white > 0:
            out["gyro_angle_white_arcsec"] = self.gyro_angle_white / units.ARCSEC_TO_RAD
            out["accel_velocity_white_mm_per_s"] = 1e3 * self.accel_velocity_white
        if self.velocity_meas_sd is not None:
            out["velocity_meas_sd_mm_per_s"] = 1e3 * self.velocity_meas_sd
        if self.allan is not None:
            out["allan"] = self.allan
        return out


def estimate_noise(blocks: Blocks, window: Window) -> Noise:
    """White-noise densities from the first differences within the window's seconds.

    The per-sample variance is half the mean square of first differences (white noise:
    ``var(x_k − x_{k−1}) = 2σ²``; a smooth motion adds ``O((a·dt)²)``), the median over the
    window's seconds (a turntable's start and stop spoil a few). Density = σ·√dt.
    """
    sel = blocks.select(window.start_s, window.end_s)
    if not sel.any():
        raise LogError("the alignment window holds no complete second to estimate noise on")
    dt = blocks.dt
    w_sd = np.sqrt(np.median(blocks.w_dvar[sel], axis=0))
    f_sd = np.sqrt(np.median(blocks.f_dvar[sel], axis=0))
    # x and y: the table turns about z, whose rate changes at the stops
    return Noise(
        gyro_density=float(np.mean(w_sd[:2]) * math.sqrt(dt)),
        accel_density=float(np.mean(f_sd) * math.sqrt(dt)),
        source="estimated on the window",
    )


def check_at_rest(
    blocks: Blocks,
    window: Window,
    lat: float,
    h: float,
    declared: Mapping[str, str | None] | None = None,
) -> tuple[dict[str, Any], list[str]]:
    """Plausibility of the units on the alignment window: |f| against g, |ω| against Earth rate.

    Returns the measured values and warnings; raises for a factor no sensor error explains
    (a wrong unit: deg/s read as rad/s, counts without weights, increments read as rates).

    Parameters
    ----------
    lat : float [rad]
    h : float [m]
    declared : mapping, optional
        The unit the rates were read in, by sensor type (``{"gyro": "deg/h", "accel":
        "ug"}``; None where unknown, mixed, or not rates): the message then names the unit
        the magnitudes point to (``m/s² read as µg``) and how to declare it.

    Raises
    ------
    LogError
        When ``|f|`` differs from local gravity by more than 10 % or the rate at rest from
        the Earth rate by more than a factor 20.
    """
    sel = blocks.select(window.start_s, window.end_s)
    if not sel.any():
        raise LogError("the alignment window holds no complete second")
    given = dict(declared or {})
    g = float(earth.gravity(lat, h))
    n = blocks.n[sel]
    fbar = float(np.sum(blocks.fmag_mean[sel] * n) / np.sum(n))
    out: dict[str, Any] = {"f_mps2": fbar, "g_mps2": g, "f_over_g": fbar / g}
    warn: list[str] = []
    ratio = fbar / g
    if not 0.9 <= ratio <= 1.1:
        raise LogError(
            f"at rest the accelerometers read |f| = {fbar:.6g} m/s² where local gravity is "
            f"{g:.5f} m/s² (× {ratio:.4g}): wrong accelerometer units"
            f"{_factor_hint(ratio, blocks.dt, 'accel', given.get('accel'), fbar)}"
            f"{_gyro_too(blocks, sel, given.get('gyro'))}"
        )
    if abs(ratio - 1) > 0.01:
        warn.append(f"at rest |f| is {100 * (ratio - 1):+.2f} % from local gravity")
    # rate at rest: means over the window (a median of magnitudes is biased low), with the
    # turntable's turn taken out: by the encoder (turned back into the base's frame, where
    # the Earth rate stands still), else dwell by dwell (the seconds the z gyro stands)
    n_all = blocks.n[sel]
    if blocks.has_table:
        f_tab, w_tab = table_frame(blocks)
        groups = [(w_tab[sel], f_tab[sel], n_all)]
    else:
        w_imu, f_imu = blocks.w_mean[sel], blocks.f_mean[sel]
        mag = np.linalg.norm(w_imu, axis=1)
        turns = np.abs(w_imu[:, 2]) > 5 * earth.RATE
        if np.mean(turns) > 0.5 and np.median(np.abs(w_imu[:, 2]) / np.maximum(mag, 1e-30)) > 0.99:
            out["omega_checked"] = False
            warn.append(
                "the gyros were not checked against the Earth rate: the table turns all "
                "through the window and the log has no encoder angle"
            )
            return out, warn
        table = np.abs(w_imu[:, 2]) > 0.5 * TABLE_RATE_DPS * units.DEG_TO_RAD
        table[1:] |= table[:-1].copy()  # a start or a stop spills into the next second
        table[:-1] |= table[1:].copy()
        groups = [(w_imu[a:b], f_imu[a:b], n_all[a:b]) for a, b in _stretches(~table)]
        out["dwells"] = len(groups)
    wbar, lat_meas = _at_rest_means(groups)
    if not math.isfinite(wbar):
        out["omega_checked"] = False
        warn.append(
            "the gyros were not checked against the Earth rate: the table never stands "
            "through the window and the log has no encoder angle"
        )
        return out, warn
    rr = wbar / earth.RATE
    out.update({"omega_dph": wbar / units.DPH_TO_RPS, "earth_rate_dph": earth.RATE /
                units.DPH_TO_RPS, "omega_over_earth_rate": rr, "omega_checked": True})  # fmt: skip
    if not 1 / 20 <= rr <= 20:
        raise LogError(
            f"at rest the gyros read |ω| = {wbar / units.DPH_TO_RPS:.6g} °/h where the Earth "
            f"turns at {earth.RATE / units.DPH_TO_RPS:.4f} °/h (× {rr:.4g}): wrong gyro "
            f"units{_factor_hint(rr, blocks.dt, 'gyro', given.get('gyro'), wbar)}, or a gyro "
            "whose bias is beyond "
            "20 × the Earth rate (a consumer MEMS cannot find north by itself)"
        )
    if not 0.5 <= rr <= 2:
        warn.append(
            f"at rest |ω| is {rr:.2f} × the Earth rate (a gyro bias of that size spoils "
            "the heading of any alignment)"
        )
        return out, warn
    # the latitude the IMU measures: the angle between the Earth rate and gravity
    out["latitude_measured_deg"] = math.degrees(lat_meas)
    if abs(lat_meas - lat) > math.radians(LATITUDE_TOL_DEG):
        warn.append(
            f"the gyros at rest measure latitude {math.degrees(lat_meas):.2f}° (the angle "
            f"between the Earth rate and gravity), the site says {math.degrees(lat):.2f}°: "
            "is the site right (the sign of its latitude)?"
        )
    return out, warn


def _at_rest_means(
    groups: list[tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]],
) -> tuple[float, float]:
    """|ω| [rad/s] and the latitude [rad] the gyros measure at rest, from mean vectors.

    Each group (a stretch in which the IMU does not turn against the base: per-second rates,
    forces and sample counts) gives its mean rate ``m`` and force; ``|m|²`` less the variance
    of ``m`` (from the scatter of its chunks' means) is unbiased for ``|ω|²`` whatever the
    noise, and ``m · f`` for ``|ω| |f| sin L``; both are averaged over the groups, weighted
    by their samples (:func:`_var_of_mean`).
    """
    w2 = w2_raw = dot = wt = 0.0
    fbar = np.zeros(3)
    for w, f, n in groups:
        if n.size == 0:
            continue
        mw = np.sum(w * n[:, None], axis=0) / np.sum(n)
        mf = np.sum(f * n[:, None], axis=0) / np.sum(n)
        var = _var_of_mean(w)
        k = float(np.sum(n))
        w2 += k * (float(mw @ mw) - var)
        w2_raw += k * float(mw @ mw)
        dot += k * float(mw @ mf)
        fbar += k * mf
        wt += k
    if wt == 0:
        return math.nan, math.nan
    # the scatter as large as the mean (a wrong unit, a table turning unseen): the biased
    # magnitude, which the unit checks read as well
    wbar = math.sqrt((w2 if w2 > 0.25 * w2_raw else w2_raw) / wt)
    fmag = float(np.linalg.norm(fbar / wt))
    sin_lat = dot / wt / max(wbar * fmag, 1e-300)
    return wbar, math.asin(min(max(sin_lat, -1.0), 1.0))


def check_never_at_rest(
    blocks: Blocks, window: Window, accel_density: float, source: str
) -> tuple[dict[str, float], list[str]]:
    """The window's scatter against the accelerometer noise the filter is told.

    Judged where a coarse count no longer hides the motion: the Allan deviation of the
    force at τ = :data:`AT_REST_TAU_S` (non-overlapping means, each pair within one stretch
    of consecutive seconds in which the table stands; the median of the axes) against what
    the told noise gives, ``q / √τ``, and what a count can: quantisation falls as 1/τ (a sum
    of counts with the remainder carried is exact to one count), so it is at most the
    deviation measured at 1 s over τ. Beyond 3 × that is warned of: the IMU may never have
    been at rest (motion does not average out as noise does).

    Parameters
    ----------
    accel_density : float [m/s²/√Hz]
    source : str
        Where the noise came from (for the message).

    Returns
    -------
    (dict, list of str)
        ``adev_1s_ug``, ``adev_tau_ug``, ``expected_tau_ug``, ``tau_s`` and the warning.
    """
    sel = blocks.select(window.start_s, window.end_s)
    ok = sel & blocks.table_still(TABLE_STILL_DPS) & blocks.consecutive()
    tau = max(1, round(AT_REST_TAU_S / BLOCK_S))
    a1, at = _adev(blocks.f_mean, ok, 1), _adev(blocks.f_mean, ok, tau)
    if not (math.isfinite(a1) and math.isfinite(at)):
        return {}, []
    tau_s = tau * BLOCK_S
    expected = math.hypot(accel_density / math.sqrt(tau_s), a1 / tau)
    ug = units.UG_TO_MPS2
    info = {
        "adev_1s_ug": a1 / ug,
        "adev_tau_ug": at / ug,
        "expected_tau_ug": expected / ug,
        "tau_s": tau_s,
    }
    if not at > 3 * expected:
        return info, []
    return info, [
        f"the accelerometers' Allan deviation over the window is {at / ug:.0f} µg at "
        f"{tau_s:g} s, {at / expected:.1f} × what the noise of {source} and the counts' "
        f"quantisation give ({expected / ug:.0f} µg): the IMU may never have been at rest"
    ]


def _adev(x: NDArray[np.float64], ok: NDArray[np.bool_], k: int) -> float:
    """Allan deviation of per-block means ``x`` (m, 3) over clusters of ``k`` blocks, pairs
    of clusters within one stretch of consecutive ``ok`` blocks; the median of the axes
    (NaN with fewer than 3 pairs)."""
    diffs = []
    for a, b in _stretches(ok):
        n = (b - a) // k
        if n < 2:
            continue
        c = x[a : a + n * k].reshape(n, k, -1).mean(axis=1)
        diffs.append(np.diff(c, axis=0))
    if not diffs or sum(d.shape[0] for d in diffs) < 3:
        return math.nan
    d = np.concatenate(diffs)
    return float(np.median(np.sqrt(0.5 * np.mean(d * d, axis=0))))


def _var_of_mean(w: NDArray[np.float64]) -> float:
    """The variance of the mean of per-second vectors (summed over the axes), from the
    scatter of the means of up to 10 chunks of at least 10 s: white rate noise gives
    ``var/N`` as independent seconds would; angle noise or a sway (whose seconds cancel)
    far less, as their mean has."""
    n = w.shape[0]
    if n < 4:
        return 0.0
    m = max(2, min(10, n // 10))
    chunks = np.array([c.mean(axis=0) for c in np.array_split(w, m)])
    return float(np.sum(np.var(chunks, axis=0, ddof=1))) / m


def check_encoder(blocks: Blocks) -> list[str]:
    """The encoder against the z gyro over the seconds the table turns: same sense, same unit.

    A wrong ``table_sign`` or ``table_unit`` does not touch the navigation (it runs in the
    IMU frame) but turns every heading error into nonsense; the gyro knows the truth. The
    sense is judged where both turn (a vehicle's own yaw is in the gyro, not the encoder);
    the unit where the gyro turns, only when the ratio is a degree-radian factor.
    """
    if not blocks.has_table:
        return []
    span = blocks.span
    gyro = blocks.w_mean[:, 2] * span
    fast = 1.0 * units.DEG_TO_RAD * span
    both = (np.abs(gyro) > fast) & (np.abs(blocks.table_turn) > fast)
    out = []
    if both.sum() >= 3 and float(np.sum(np.sign(blocks.table_turn[both]) * gyro[both])) < 0:
        out.append(
            "the encoder turns against the z gyro (the IMU's own turn): its sign is wrong "
            "(table_sign in the mapping); positive table_deg turns the IMU counter-clockwise "
            "seen from above, as the z gyro reads it"
        )
    turning = np.abs(gyro) > fast
    if turning.sum() >= 3:
        size = float(np.sum(np.abs(blocks.table_turn[turning])) / np.sum(np.abs(gyro[turning])))
        for k in (units.DEG_TO_RAD, 1 / units.DEG_TO_RAD):
            # size 0: the table stood while the vehicle turned (its yaw is not the encoder's)
            if size > 0 and abs(math.log(size / k)) < math.log(1.1):
                out.append(
                    f"the encoder turns {size:.3g} × what the z gyro turns while the table "
                    "moves: its unit is wrong (table_unit in the mapping: deg or rad)"
                )
    return out


def check_turning_without_encoder(
    blocks: Blocks, lat: float, h: float
) -> tuple[dict[str, Any], list[str]]:
    """A turntable the log does not record: the z gyro turns while the base stands still.

    With no encoder angle, the navigation (in the IMU frame) is right but its heading is the
    IMU's, compared with the body's: a table turned by 135° reads as a 135° heading error.
    Seconds in which the z gyro, the Earth rate's vertical part ``Ω sin L`` removed, turns
    faster than :data:`TABLE_RATE_DPS` while ``|f|`` stays at gravity and the horizontal
    specific force at what it is in the still seconds (a vehicle that turns while moving feels
    the centripetal ``v ω``) are the table's; with no still second (a table turning on and
    on), those that turn at one steady rate (within 1 %) with a steady horizontal force. More
    than :data:`TABLE_TURN_DEG` of them in all is warned of, naming the missing column and
    how to map it.

    Parameters
    ----------
    lat : float [rad]
    h : float [m]

    Returns
    -------
    (dict, list of str)
        ``turned_deg``, ``seconds``, ``rate_dps_median`` of the turning at rest (empty when
        there is an encoder or no such turning), and the warning.
    """
    if blocks.has_table or blocks.t0.size < 3:
        return {}, []
    span = blocks.span
    wz = blocks.w_mean[:, 2] - earth.RATE * math.sin(lat)
    turning = np.abs(wz) > TABLE_RATE_DPS * units.DEG_TO_RAD
    still = np.abs(wz) < 0.1 * TABLE_RATE_DPS * units.DEG_TO_RAD
    if turning.sum() < 3:
        return {}, []
    g = float(earth.gravity(lat, h))
    fh = np.hypot(blocks.f_mean[:, 0], blocks.f_mean[:, 1])
    at_rest = turning & (np.abs(blocks.fmag_mean - g) < 0.01 * g)
    if still.sum() >= 3:  # the horizontal force of the still seconds: the IMU's tilt
        at_rest &= np.abs(fh - float(np.median(fh[still]))) < AT_REST_HORIZONTAL_MPS2
    else:  # never still (a table turning on and on): a steady rate and a steady force
        rate = float(np.median(np.abs(wz[turning])))
        at_rest &= (np.abs(np.abs(wz) - rate) < 0.01 * rate) & (
            np.abs(fh - float(np.median(fh[turning]))) < AT_REST_HORIZONTAL_MPS2
        )
    turned = float(np.sum(np.abs(wz[at_rest]) * span[at_rest])) / units.DEG_TO_RAD
    if at_rest.sum() < 3 or turned < TABLE_TURN_DEG:
        return {}, []
    rate = float(np.median(np.abs(wz[at_rest]))) / units.DEG_TO_RAD
    seconds = float(np.sum(span[at_rest]))
    info = {"turned_deg": turned, "seconds": seconds, "rate_dps_median": rate}
    return info, [
        f"the z gyro (Earth rate removed) turns the IMU {turned:.0f}° in all, over "
        f"{seconds:.0f} s at a median {rate:.1f} °/s, while the accelerometers say the base "
        "stood still: the IMU is on a turntable, and the log has no encoder angle "
        "(table_deg). The heading error compares the IMU's heading with the body's and is "
        "meaningless (the position error, computed in the IMU frame, is not touched): map the "
        'encoder column, e.g. [columns] ENCODER = "table_deg" in the mapping (mapping=; '
        "table_unit, table_sign, table_zero_deg if it needs them)"
    ]


#: How a unit is written in a message (the name to declare it by is the SENSOR_UNITS key).
_SHOWN = {"m/s^2": "m/s²", "ug": "µg"}


def _unit_mixups(sensor: str, declared: str | None) -> list[tuple[float, str, str]]:
    """Every (measured/expected ratio, actual unit, unit read as) a wrong unit gives for a
    sensor type: a column in ``a`` read as ``b`` is ``SI(b) / SI(a)`` times the truth. Only
    the pairs read as ``declared`` when the unit the log was read in is known."""
    names = [u for u in units.SENSOR_TYPE_UNITS[sensor] if u in units.SENSOR_UNITS]
    return [
        (units.SENSOR_UNITS[b] / units.SENSOR_UNITS[a], a, b)
        for b in names
        for a in names
        if a != b and (declared is None or b == declared)
    ]


def _gyro_too(blocks: Blocks, sel: NDArray[np.bool_], declared: str | None) -> str:
    """With the accelerometers' units refused: the gyros' mix-up too, when their quietest
    seconds point to one (an SI log read in the default units is wrong in both)."""
    if declared is None:
        return ""
    w = np.linalg.norm(blocks.w_mean[sel], axis=1)
    rr = float(np.median(w[w <= np.percentile(w, 25)])) / earth.RATE
    for k, a, _ in _unit_mixups("gyro", declared):
        if abs(math.log(max(rr, 1e-300) / k)) < math.log(1.5):  # a bias may add to Ω
            return (
                f"; the gyros too read {rr:.3g} × the Earth rate at rest: {_SHOWN.get(a, a)} "
                f'read as {_SHOWN.get(declared, declared)}? (gyro = "{a}")'
            )
    return ""


def _factor_hint(
    ratio: float, dt: float, sensor: str, declared: str | None = None, si: float = math.nan
) -> str:
    """Name the unit mix-up a measured/expected ratio points to, if one is near (10 %), and
    how to declare the unit; ``declared``: the unit the log's rates were read in, ``si``:
    the magnitude measured, in SI (the columns' own number is said when both are known)."""

    def near(k: float) -> bool:
        return abs(math.log(max(ratio, 1e-300) / k)) < math.log(1.1)

    found = [(a, b) for k, a, b in _unit_mixups(sensor, declared) if near(k)]
    if found:
        a = found[0][0]
        what = " or ".join(f"{_SHOWN.get(x, x)} read as {_SHOWN.get(y, y)}" for x, y in found)
        if declared is not None and math.isfinite(si):
            what = f"the columns hold {si / units.SENSOR_UNITS[declared]:.4g}: {what}"
        return (
            f' ({what}?: declare the unit, e.g. {sensor} = "{a}" under [units] in the '
            f'mapping (mapping=), or "units": {{"{sensor}": "{a}"}} in the '
            "log's .meta.json)"
        )
    for k, what in (
        (dt, "increments read as rates (× the interval)"),
        (1 / dt, "rates read as increments"),
    ):
        if near(k):
            return f" ({what}?)"
    return " (counts without pulse weights, or a unit mix-up)"


def seen_schedule(blocks: Blocks) -> dict[str, Any]:
    """What the encoder says the turntable did: positions held, dwell, turning rate."""
    if not blocks.has_table:
        return {"source": "none (no encoder angle: the IMU is fixed to the body)"}
    rate = blocks.table_turn / blocks.span
    angle = blocks.table_start + np.cumsum(blocks.table_turn)  # at each block's end
    still = np.abs(rate) < 0.1 * units.DEG_TO_RAD
    dwell = [(a, b) for a, b in _stretches(still) if b - a >= 2]
    pos = sorted({round(float(np.rad2deg(angle[a:b].mean())) % 360.0) % 360 for a, b in dwell})
    moving = ~still
    return {
        "source": "encoder",
        "positions_deg": [p if p <= 180 else p - 360 for p in pos][:24],
        "dwells": len(dwell),
        "dwell_s_median": float(np.median([blocks.t1[b - 1] - blocks.t0[a] for a, b in dwell]))
        if dwell
        else 0.0,
        "turning_rate_dps_median": float(np.median(np.abs(rate[moving])) / units.DEG_TO_RAD)
        if moving.any()
        else 0.0,
        "total_turn_deg": float(np.sum(np.abs(blocks.table_turn)) / units.DEG_TO_RAD),
    }


def align_config(
    noise: Noise, window: Window, coarse_s: float = 60.0, base: AlignConfig | None = None
) -> AlignConfig:
    """Alignment settings for a window and a noise (bias Markov floors as :func:`align_for`;
    the zero-velocity measurement sd from ``noise.velocity_meas_sd`` where it has one)."""
    cfg = align_from_noise(
        noise.gyro_density,
        noise.accel_density,
        noise.gyro_bias_rw,
        noise.accel_bias_rw,
        total_s=window.length_s,
        coarse_s=coarse_s,
        start_s=max(window.start_s, 0.0),  # informative only: a log's clock may start < 0
    )
    if noise.velocity_meas_sd is not None:
        cfg = replace(cfg, velocity_meas_sd=noise.velocity_meas_sd)
    return cfg
