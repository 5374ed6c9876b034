"""The recording's sensor noise from the Allan variance of the alignment window.

Why not first differences. The first pass's per-sample first differences give the white
*rate* noise of one sample, ``σ_1``, and ``σ_1·√dt`` is the angle random walk only when the
output is white rate noise (a FOG or a MEMS gyro with analogue output). A pulse-output
gyro (a dithered ring laser, a FOG with a counter) or an accelerometer with coarse counts
is dominated at the sample rate by its count: white *angle* (velocity) noise, whose Allan
deviation falls as ``1/τ`` (IEEE Std 952 ``Q``), not as ``1/√τ``. Read as a random walk it
is 5-30 times too large at 100 Hz (one 0.1″ count in 10 ms is 36 °/h a sample, a
125 µg·s count 12.5 mg), and the alignment filter that is told so trusts its model too
little.

What is done here (:func:`estimate_noise_allan`):

1. The window's **per-second means** of the rates and forces (``Blocks.w_mean``,
   ``f_mean``: the counts of a second divided by its length, so the count's remainder is
   carried exactly as the hardware carries it) are laid on a 1 s grid. Their overlapping
   Allan deviation at ``τ = m`` s (1, 2, 3, 4, 6, 8, ... s and the longest the longest
   stretch holds) is the recording's own at those τ: τ ≥ 1 s, which is where
   the filter works (it updates every ``kf_interval_s`` = 0.5 s and its errors grow over
   minutes). Shorter τ would need a second pass over every sample (an 8 h × 200 Hz file
   read again) and would show the count even more plainly, not the random walk.
2. Seconds that cannot be used are NaN, so that each dwell is its own stretch (the Allan
   variance pools NaN-free stretches and never differences across one,
   :mod:`rinscal.calibration.allan`): a second in which the table turned (encoder turn
   above :data:`TURN_DEG`, or, with or without an encoder, the z gyro beyond
   :data:`TURN_SIGMA` robust sd of its window median, at least :data:`TURN_FLOOR_DPH`),
   its two neighbours, a second with a gap in time or fewer than 90 % of the usual
   samples. Each stretch's mean (the Earth rate's and gravity's projection at that table
   position) changes no second difference, so it drops out by itself.
3. The three axes' Allan variances are averaged (clusters summed: the mean-square noise of
   the triad, which the filter's one density per triad stands for) and the IEEE 952 terms
   ``Q, N, B, K, R`` fitted to every τ, weighted by its clusters
   (:func:`~rinscal.calibration.allan.fit_noise_terms`), with, for the gyros, a dithered
   laser's exponentially correlated angle noise ``M`` (τc searched over 5-500 s); it looks
   like a random walk below τc, so ``N`` is resolved only where the fit tells it from ``M``.

What the filter gets (:class:`~rinscal.nav.align.AlignConfig`: attitude, horizontal
velocity and bias states, a zero-velocity update every ``T = kf_interval_s``):

* ``gyro_noise_density`` / ``accel_noise_density``: the fit's ``N``, resolved or not, at
  most its bound ``σ(τ)·√τ`` at the longest reliable τ (the truth lies under it; the bound
  itself where the fit put no ``N``). Measured on ring-laser recordings made like the real
  one (``docs/navigation.md``), the bound told to the filter gave larger heading errors than
  the fit's ``N`` (rms 420″ against 394″; 393″ with the true noise). The count ``Q`` and the
  correlated angle ``M`` are never turned into a random walk.
* ``velocity_meas_sd``: the count enters where it belongs, the zero-velocity measurement.
  The strapdown velocity is the counted one: it lacks the accelerometers' uncounted
  remainder, a white velocity error of sd ``Q_v`` [m/s] at each update (IEEE 952: ``Q`` is
  the sd of the sample's angle or velocity error, ``σ²(τ) = 3Q²/τ²``), independent from
  one update to the next. The gyros' uncounted angle ``Q_θ`` [rad] is an attitude error
  that does not grow; it tilts gravity into the horizontal channels, ``δv̇ = g·e_θ``, and
  over one interval adds ``∫_T g·e_θ dt``, at most ``g·Q_θ·T`` (the error held over the
  whole interval; less where the dither decorrelates it sooner); the correlated angle
  ``M`` likewise, ``Q_θ² + M_θ²`` in its place (its slow wander beyond T is followed by the
  filter's attitude states). Both add, as variances,
  to the filter's default ``d`` = 1 mm/s (what its model leaves out at rest: a parked
  vehicle's sway):

  ``velocity_meas_sd = √(d² + Q_v² + (g·Q_θ·T)²)``

  (a 125 µg·s count: ``Q_v`` = 0.35 mm/s; 2″ of angle noise: ``g·Q_θ·T`` = 0.05 mm/s at
  T = 0.5 s).

Bias instability, rate random walk and rate ramp are reported, not given to the filter:
on a 10 min window they are rarely resolved, and the filter's bias states keep their
Gauss-Markov defaults.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rinscal import earth, units
from rinscal.calibration.allan import (
    AllanCurve,
    NoiseFit,
    NoiseTerm,
    allan_deviation,
    fit_noise_terms,
    pool_curves,
)
from rinscal.errors import ConfigError, LogError
from rinscal.nav.align import AlignConfig
from rinscal.nav.recorded.blocks import BLOCK_S, Blocks
from rinscal.nav.recorded.window import Noise, Window, estimate_noise

__all__ = [
    "KF_INTERVAL_S",
    "TURN_DEG",
    "TURN_FLOOR_DPH",
    "TURN_SIGMA",
    "estimate_noise_allan",
    "noise_text",
    "usable_seconds",
    "velocity_meas_sd",
]

#: The alignment filter's update interval T [s] (AlignConfig's default).
KF_INTERVAL_S = AlignConfig().kf_interval_s
#: An encoder turn within a second above this [deg] marks the second as turning.
TURN_DEG = 0.01
#: A second whose z rate is beyond this many robust sd of the window's median turns.
TURN_SIGMA = 6.0
#: ... and at least this far from it [deg/h].
TURN_FLOOR_DPH = 1.0
#: Fewest usable seconds in a row the estimate needs (τ up to 2 s).
MIN_STRETCH_S = 5


def velocity_meas_sd(
    accel_velocity_white: float,
    gyro_angle_white: float,
    kf_interval_s: float,
    g: float = 9.80665,
    default: float | None = None,
) -> float:
    """The zero-velocity measurement's sd [m/s] for sensors with white angle/velocity noise.

    ``√(d² + Q_v² + (g·Q_θ·T)²)``, see the module docstring. ``accel_velocity_white`` =
    ``Q_v`` [m/s], ``gyro_angle_white`` = ``Q_θ`` [rad], ``kf_interval_s`` = ``T`` [s],
    ``g`` [m/s²], ``default`` = ``d`` [m/s] (the filter's own default where None).
    """
    d = AlignConfig().velocity_meas_sd if default is None else default
    return math.sqrt(d**2 + accel_velocity_white**2 + (g * gyro_angle_white * kf_interval_s) ** 2)


def usable_seconds(blocks: Blocks, window: Window) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
    """The window's seconds on a 1 s grid, and which of them the Allan variance may use.

    Returns ``(index, ok)``: ``index[i]`` is the block at grid second ``i`` (−1 where no
    block: a second without samples), ``ok[i]`` whether it is usable (see the module
    docstring: not turning, nor next to a turn, no gap, a full second).
    """
    idx = np.flatnonzero(blocks.select(window.start_s, window.end_s))
    if idx.size == 0:
        raise LogError("the alignment window holds no complete second to estimate noise on")
    pos = np.round((blocks.t1[idx] - blocks.t1[idx[0]]) / BLOCK_S).astype(np.int64)
    keep = np.concatenate(([True], np.diff(pos) > 0))  # never two blocks on one second
    idx, pos = idx[keep], pos[keep]
    grid = np.full(int(pos[-1]) + 1, -1, dtype=np.int64)
    grid[pos] = idx
    have = grid >= 0
    ok = have.copy()
    b = grid[have]
    n = blocks.n[b]
    full = n >= 0.9 * float(np.median(n))
    if blocks.gaps is not None:
        full &= ~blocks.gaps[b]
    turning = np.zeros(b.size, dtype=bool)
    if blocks.has_table:
        turning |= np.abs(blocks.table_turn[b]) > TURN_DEG * units.DEG_TO_RAD
    wz = blocks.w_mean[b, 2]
    still = wz[~turning] if np.any(~turning) else wz
    med = float(np.median(still))
    rsd = 1.4826 * float(np.median(np.abs(still - med)))
    thr = max(TURN_SIGMA * rsd, TURN_FLOOR_DPH * units.DPH_TO_RPS)
    turning |= np.abs(wz - med) > thr
    bad = np.zeros(grid.size, dtype=bool)
    bad[have] = turning
    near = bad.copy()  # and the seconds next to a turn (the table starts and stops)
    near[1:] |= bad[:-1]
    near[:-1] |= bad[1:]
    ok[have] = full
    ok &= ~near
    return grid, ok


def _series(x: NDArray[np.float64], grid: NDArray[np.int64], ok: NDArray[np.bool_]) -> Any:
    out = np.full((grid.size, 3), np.nan)
    out[ok] = x[grid[ok]]
    return out


def _taus(ok: NDArray[np.bool_]) -> NDArray[np.float64]:
    """τ [s]: 1, 2, 3, 4, 6, 8, 12, ... (half octaves) up to the longest the longest usable
    stretch holds, and that longest one (a turntable's dwells end the curve early)."""
    edges = np.flatnonzero(np.diff(np.concatenate(([0], ok.view(np.int8), [0]))))
    longest = int(np.max(edges[1::2] - edges[::2]))
    m_max = (longest - 1) // 2
    octave = 2 ** np.arange(max(m_max, 1).bit_length())
    m = np.unique(np.concatenate((octave, np.round(1.5 * octave), [m_max])))
    return (m[(m >= 1) & (m <= m_max)] * BLOCK_S).astype(np.float64)


def _pooled(series: NDArray[np.float64], taus: NDArray[np.float64]) -> AllanCurve:
    return pool_curves([allan_deviation(series[:, j], 1.0 / BLOCK_S, taus) for j in range(3)])


# what each term is, and its display unit: (label, scale from SI for gyros, unit; for accels)
_GYRO_UNITS = {
    "q": ("white angle noise Q", 1.0 / units.ARCSEC_TO_RAD, "″"),
    "n": ("angle random walk N", 1.0 / units.DPRH_TO_RPRS, "°/√h"),
    "b": ("bias instability B", 1.0 / units.DPH_TO_RPS, "°/h"),
    "k": ("rate random walk K", 60.0 / units.DPH_TO_RPS, "°/h/√h"),
    "r": ("rate ramp R", 3600.0 / units.DPH_TO_RPS, "°/h/h"),
    "m": ("correlated angle noise M", 1.0 / units.ARCSEC_TO_RAD, "″"),
}
_ACCEL_UNITS = {
    "q": ("white velocity noise Q", 1e3, "mm/s"),
    "n": ("velocity random walk N", 1.0 / units.UG_TO_MPS2, "µg/√Hz"),
    "b": ("bias instability B", 1.0 / units.UG_TO_MPS2, "µg"),
    "k": ("rate random walk K", 60.0 / units.UG_TO_MPS2, "µg/√h"),
    "r": ("rate ramp R", 3600.0 / units.UG_TO_MPS2, "µg/h"),
    "m": ("correlated velocity noise M", 1e3, "mm/s"),
}


def _term_dict(t: NoiseTerm, table: dict[str, tuple[str, float, str]]) -> dict[str, Any]:
    label, scale, unit = table[t.name]
    d: dict[str, Any] = {
        "what": label,
        "unit": unit,
        "value": t.value * scale,
        "sd": t.sd * scale if math.isfinite(t.sd) else None,
        "resolved": t.resolved,
        "dominant_tau_s": list(t.dominant_tau_s) if t.dominant_tau_s else None,
    }
    if t.bound is not None:
        d["bound"] = t.bound * scale
        d["bound_tau_s"] = t.bound_tau_s
    return d


def _fit_dict(
    fit: NoiseFit, curve: AllanCurve, table: dict[str, tuple[str, float, str]]
) -> dict[str, Any]:
    scale = table["b"][1]
    return {
        "terms": {t.name: _term_dict(t, table) for t in fit.terms},
        "found": [t.name.upper() for t in fit.terms if t.resolved],
        "tau_s": list(fit.tau_s),
        "tau_reliable_s": fit.tau_reliable_s,
        "chi2_dof": fit.chi2_dof,
        "correlated": {
            "kept": fit.tau_c_s is not None,
            "tau_c_s": fit.tau_c_s,
            "tau_c_range_s": list(fit.tau_c_range_s) if fit.tau_c_range_s else None,
            "weight": fit.markov_weight,
        },
        "adev": {
            "tau_s": curve.tau_s.tolist(),
            "value": (curve.adev * scale).tolist(),
            "unit": table["b"][2],
            "clusters": curve.clusters.tolist(),
        },
    }


def _fmt(x: float) -> str:
    return f"{x:.2g}" if abs(x) < 10 else f"{x:.0f}"


def _sensor_text(name: str, d: dict[str, Any]) -> str:
    parts = []
    for key in ("q", "m", "n", "b", "k"):
        t = d["terms"][key]
        sym = key.upper()
        corr = d.get("correlated") or {}
        if key == "m" and corr.get("kept") and t["value"] > 0:
            sep = "" if t["unit"] == "″" else " "
            state = "resolved" if t["resolved"] else "not resolved"
            parts.append(
                f"M {_fmt(t['value'])}{sep}{t['unit']} correlated over τc "
                f"{corr['tau_c_s']:.0f} s ({state})"
            )
        elif key == "m":
            continue
        elif t["resolved"]:
            dom = t["dominant_tau_s"]
            where = ""
            if dom:
                span = f"{dom[0]:g}" if dom[0] == dom[1] else f"{dom[0]:g}-{dom[1]:g}"
                where = f", dominant at τ {span} s"
            rel = f" ±{100 * t['sd'] / t['value']:.0f} %" if t["sd"] is not None else ""
            sep = "" if t["unit"] == "″" else " "
            parts.append(f"{sym} {_fmt(t['value'])}{sep}{t['unit']}{rel} (resolved{where})")
        elif key == "q" and t["value"] > 0:  # used for the velocity measurement all the same
            sep = "" if t["unit"] == "″" else " "
            parts.append(f"Q ≈ {_fmt(t['value'])}{sep}{t['unit']} (not resolved)")
        elif key == "n" and "bound" in t:
            fit = f"; fit {_fmt(t['value'])}" if t["value"] > 0 else ""
            parts.append(
                f"N ≤ {_fmt(t['bound'])} {t['unit']} (bound at τ = {t['bound_tau_s']:g} s{fit}, "
                "not told from a correlated angle noise)"
            )
    lo, hi = d["tau_s"]
    return f"{name} on τ {lo:g}-{hi:g} s: " + ", ".join(parts or ["no term resolved"])


def noise_text(report_noise: dict[str, Any]) -> str:
    """The filter's noise in one line for the terminal (from ``Noise.to_dict()``)."""
    allan = report_noise.get("allan")
    told = (allan or {}).get("filter", {})
    how_g = f" ({told['gyro_n']})" if "gyro_n" in told else ""
    how_a = f" ({told['accel_n']})" if "accel_n" in told else ""
    used = (
        f"ARW {_fmt(report_noise['gyro_arw_deg_per_rth'])} °/√h{how_g}, "
        f"VRW {_fmt(report_noise['accel_vrw_ug_per_rthz'])} µg/√Hz{how_a}"
    )
    if "velocity_meas_sd_mm_per_s" in report_noise:
        used += f", velocity measurement sd {report_noise['velocity_meas_sd_mm_per_s']:.2f} mm/s"
        if "gyro_angle_noise_arcsec" in told:
            used += f" (angle noise {_fmt(told['gyro_angle_noise_arcsec'])}″)"
    if not allan or "gyro" not in allan:
        return f"filter noise {report_noise['source']}: {used}"
    return (
        f"noise from the window's Allan deviation ({allan['seconds_used']} s used): "
        f"{_sensor_text('gyro', allan['gyro'])}; {_sensor_text('accel', allan['accel'])}; "
        f"filter: {used}"
    )


def _told(fit: NoiseFit, resolved: bool) -> str:
    """What the filter was told of N, in words."""
    if resolved:
        return "resolved"
    if fit.n.value > 0 or fit.n.bound is None:
        return "the fit's N, unresolved"
    return f"bound at τ = {fit.n.bound_tau_s:g} s"


def estimate_noise_allan(
    blocks: Blocks,
    window: Window,
    kf_interval_s: float | None = None,
    lat: float | None = None,
) -> Noise:
    """The filter's noise from the Allan variance of the window's per-second means.

    Parameters
    ----------
    blocks : Blocks
        The first pass.
    window : Window
        The alignment window.
    kf_interval_s : float or None [s]
        The filter's update interval ``T`` (default :class:`AlignConfig`'s).
    lat : float or None [rad]
        Latitude for gravity in ``g·Q_θ·T`` (default standard gravity).

    Returns
    -------
    Noise
        ``gyro_density`` / ``accel_density``: the fit's ``N`` (at most its bound);
        ``gyro_angle_white`` / ``accel_velocity_white``: ``Q``; ``velocity_meas_sd``;
        ``allan``: the curves, the terms, what was resolved on which τ, the first-difference
        estimate for comparison. Where the window has no 5 usable seconds in a row (a table
        that never rests), the first-difference estimate, saying so in ``source``.
    """
    T = AlignConfig().kf_interval_s if kf_interval_s is None else float(kf_interval_s)
    g = 9.80665 if lat is None else float(earth.gravity(lat, 0.0))
    first = estimate_noise(blocks, window)
    fd = {
        "gyro_arw_deg_per_rth": first.gyro_density / units.DPRH_TO_RPRS,
        "accel_vrw_ug_per_rthz": first.accel_density / units.UG_TO_MPS2,
    }
    grid, ok = usable_seconds(blocks, window)
    run = 0
    longest = 0
    for v in ok.tolist():
        run = run + 1 if v else 0
        longest = max(longest, run)
    if longest < MIN_STRETCH_S:
        return Noise(
            first.gyro_density,
            first.accel_density,
            source=(
                "estimated on the window (first differences: no "
                f"{MIN_STRETCH_S} s in a row without turning for an Allan deviation)"
            ),
            allan={"first_differences": fd, "seconds_used": int(ok.sum())},
        )
    try:
        taus = _taus(ok)
        gc = _pooled(_series(blocks.w_mean, grid, ok), taus)
        ac = _pooled(_series(blocks.f_mean, grid, ok), taus)
        gf = fit_noise_terms(gc)
        af = fit_noise_terms(ac, correlated=False)  # the correlated angle is the dither's
    except ConfigError as exc:  # too little for a fit
        raise LogError(f"noise from the alignment window: {exc}") from None
    n_g, g_res = gf.n_for_filter()
    n_a, a_res = af.n_for_filter()
    q_g, q_a = gf.q.value, af.q.value
    # the angle (velocity) noise that does not accumulate: white and correlated
    vsd = velocity_meas_sd(math.hypot(q_a, af.m.value), math.hypot(q_g, gf.m.value), T, g)
    allan = {
        "method": (
            "IEEE 952 terms fitted to the overlapping Allan variance of the window's "
            "per-second means, three axes pooled"
        ),
        "seconds_used": int(ok.sum()),
        "seconds_excluded": int(ok.size - ok.sum()),
        "gyro": _fit_dict(gf, gc, _GYRO_UNITS),
        "accel": _fit_dict(af, ac, _ACCEL_UNITS),
        "filter": {
            "gyro_n": _told(gf, g_res),
            "accel_n": _told(af, a_res),
            "gyro_angle_noise_arcsec": math.hypot(q_g, gf.m.value) / units.ARCSEC_TO_RAD,
            "accel_velocity_noise_mm_per_s": 1e3 * math.hypot(q_a, af.m.value),
            "kf_interval_s": T,
        },
        "first_differences": fd,
    }

    def found(fit: NoiseFit) -> str:
        return ", ".join(t.name.upper() for t in fit.terms if t.resolved) or "none"

    def said(fit: NoiseFit, resolved: bool) -> str:
        return "" if resolved else f", N {_told(fit, resolved)}"

    return Noise(
        gyro_density=n_g,
        accel_density=n_a,
        source=(
            f"estimated on the window (Allan, τ {gf.tau_s[0]:g}-{gf.tau_s[1]:g} s: "
            f"gyro {found(gf)} resolved{said(gf, g_res)}; "
            f"accel {found(af)} resolved{said(af, a_res)})"
        ),
        gyro_angle_white=q_g,
        accel_velocity_white=q_a,
        velocity_meas_sd=vsd,
        allan=allan,
    )
