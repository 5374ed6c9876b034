"""A small multi-position log generator for the IMU-calibration tests, following the log
contract of ``rinscal simulate multiposition`` (commanded table columns, runs per set point,
metadata, truth table) so that the simulator's logs fit the same way."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from rinscal import turntable, units
from rinscal.schema import CHANNELS
from rinscal.sensormodel import PARAMETERS, ImuCalibration, TriadErrors, triad_forward

#: A rough 19-position sequence (outer, inner) [deg]: every axis up, down and horizontal at
#: several headings, plus three 45° tilts.
POSITIONS_19 = [(o, i) for o in (0, 90, 180, 270) for i in (0, 90, 180, 270)] + [
    (45, 45),
    (135, 225),
    (-45, 135),
]
#: Rate tests: (turning axis, angle of the other axis [deg]) for IMU z, y, x.
RATE_AXES = (("inner", 0.0), ("outer", 0.0), ("outer", 90.0))
LAT_DEG, HEADING_DEG, ALT_M = 32.06, 270.0, 10.0
_SUB = 16


def paper_like_truth(slopes: bool = True) -> ImuCalibration:
    """Parameters of a navigation-grade unit (values at 20 °C, and per-°C slopes)."""
    rng = np.random.default_rng(12345)
    coefs: dict[str, tuple[float, ...]] = {}
    scale = {
        ("gyro", "bias"): (0.05, 0.002),
        ("gyro", "sf"): (40.0, 3.0),
        ("gyro", "sf_asym"): (3.0, 0.1),
        ("gyro", "sf_quad"): (0.03, 0.001),
        ("gyro", "mis"): (60.0, 0.6),
        ("accel", "bias"): (80.0, 5.0),
        ("accel", "sf"): (300.0, 4.0),
        ("accel", "sf_quad"): (12.0, 0.2),
        ("accel", "mis"): (60.0, 0.6),
    }
    for p in PARAMETERS:
        v, s = scale[(p.sensor, p.kind)]
        value = float(v * rng.uniform(0.5, 1.0) * rng.choice([-1, 1]))
        slope = float(s * rng.uniform(0.5, 1.0) * rng.choice([-1, 1])) if slopes else 0.0
        coefs[p.name] = (value, slope)
    return ImuCalibration(t0_c=20.0, t_range_c=(-60.0, 100.0), t_coefs=coefs)


@dataclass
class Design:
    """What the synthetic turntable does in each run."""

    positions: list[tuple[float, float]] = field(default_factory=lambda: list(POSITIONS_19))
    rates_dps: tuple[float, ...] = (20.0, 100.0)
    rate_axes: tuple[tuple[str, float], ...] = RATE_AXES
    dwell_s: float = 40.0
    settle_s: float = 3.0
    turns: int = 2
    rate_hz: float = 10.0
    transition_rows: int = 4


def _commands(d: Design) -> list[tuple[str, float, float, float, float, int]]:
    """(kind, outer, inner, outer rate, inner rate, rows) of each commanded step."""
    out = []
    dt = 1.0 / d.rate_hz
    for o, i in d.positions:
        out.append(("move", o, i, 0.0, 0.0, d.transition_rows))
        out.append(("static", o, i, 0.0, 0.0, round(d.dwell_s * d.rate_hz)))
    for axis, other in d.rate_axes:
        for r in d.rates_dps:
            for sign in (1.0, -1.0):
                rate = sign * r
                per_turn = 360.0 / (r * dt)
                settle = int(np.ceil(d.settle_s * d.rate_hz)) + 1
                rows = settle + round(d.turns * per_turn)
                o, i = (0.0, other) if axis == "outer" else (other, 0.0)
                out.append(("move", o, i, 0.0, 0.0, d.transition_rows))
                ro, ri = (rate, 0.0) if axis == "outer" else (0.0, rate)
                out.append(("rate", o, i, ro, ri, rows))
    return out


def make_log(
    truth: ImuCalibration,
    set_points: tuple[float, ...] = (0.0, 12.0, 24.0, 36.0, 48.0),
    *,
    design: Design | None = None,
    seed: int = 0,
    gyro_sd_dph: float = 0.13,
    accel_sd_ug: float = 250.0,
    pulses: bool = True,
    turn_on: bool = True,
    creep: tuple[str, int, float] | None = None,
    ramp: bool = False,
) -> tuple[pd.DataFrame, dict, pd.DataFrame]:
    """A multi-position log, its metadata and its truth table.

    ``creep = (run, position number, rate [deg/s])``: the table turns slowly about the outer
    axis during that position while the commanded angles stay put. ``ramp``: one run
    ``cal_ramp`` with the sequence repeated once per set point, the chamber moving linearly
    between them.
    """
    d = design or Design()
    rng = np.random.default_rng(seed)
    dt = 1.0 / d.rate_hz
    lat, heading = LAT_DEG * units.DEG_TO_RAD, HEADING_DEG * units.DEG_TO_RAD
    w_pulse = np.array([0.001 * units.ARCSEC_TO_RAD] * 3 + [1e-6] * 3)
    offsets = np.array([0.4, 0.3, 0.6, 0.2, 0.5, 0.7])
    frames, truth_rows = [], []
    names = [f"cal_{c:+03.0f}C" for c in set_points] if not ramp else ["cal_ramp"]
    sequences = [[c] for c in set_points] if not ramp else [list(set_points)]
    for name, points in zip(names, sequences, strict=True):
        cmds = [(c, step) for c in points for step in _commands(d)]
        rows = []
        angle = {"outer": 0.0, "inner": 0.0}
        pos_no = 0
        for c, (kind, o, i, ro, ri, n) in cmds:
            if kind == "static":
                pos_no += 1
            for k in range(n):
                if kind == "move":
                    rows.append((c, "move", o - (n - k) * 3.0, i + (n - k) * 2.0, 30.0, 20.0, 0))
                elif kind == "static":
                    rows.append((c, kind, o, i, 0.0, 0.0, pos_no))
                else:
                    oo = o + ro * dt * (k + 1)
                    ii = i + ri * dt * (k + 1)
                    rows.append((c, kind, oo, ii, ro, ri, 0))
            angle["outer"], angle["inner"] = o, i
        m = len(rows)
        arr = np.array([r[2:6] for r in rows], dtype=float)
        kind = np.array([r[1] for r in rows])
        posn = np.array([r[6] for r in rows])
        t = (np.arange(m) + 1.0) * dt
        if ramp:
            chamber = np.interp(np.arange(m), np.linspace(0, m - 1, len(points)), points)
        else:
            chamber = np.full(m, points[0])
        temps = chamber[:, None] + offsets + 0.02 * (t / t[-1])[:, None]
        # true inputs, averaged over each sample interval (sub-steps for the rate rows)
        frac = (np.arange(_SUB) + 0.5) / _SUB - 1.0
        oo = arr[:, 0:1] + arr[:, 2:3] * dt * frac
        ii = arr[:, 1:2] + arr[:, 3:4] * dt * frac
        if creep is not None and creep[0] == name:
            sel = (kind == "static") & (posn == creep[1])
            k0 = np.flatnonzero(sel)[0]
            extra = creep[2] * ((t[:, None] - t[k0]) + dt * frac) * sel[:, None]
            oo = oo + extra
            ro_true = arr[:, 2] + creep[2] * sel
        else:
            ro_true = arr[:, 2]
        w, f = turntable.reference_r(
            oo.ravel(),
            ii.ravel(),
            lat,
            heading,
            ALT_M,
            np.repeat(ro_true, _SUB),
            np.repeat(arr[:, 3], _SUB),
        )
        w, f = w.reshape(m, _SUB, 3), f.reshape(m, _SUB, 3)
        g_err, a_err = truth.triads(temps)
        on = rng.normal(0, 1, 6) * np.array(
            [0.01 * units.DPH_TO_RPS] * 3 + [20 * units.UG_TO_MPS2] * 3
        )
        if not turn_on:
            on[:] = 0.0
        out = np.empty((m, 6))
        for sl, s, e in ((slice(0, 3), w, g_err), (slice(3, 6), f, a_err)):
            e1 = TriadErrors(
                bias=(e.bias + on[sl])[:, None, :],
                sf=e.sf[:, None, :],
                asym=e.asym[:, None, :],
                quad=e.quad[:, None, :],
                mis=e.mis[:, None, :, :],
            )
            out[:, sl] = triad_forward(s, e1).mean(axis=1)
        sd = np.array([gyro_sd_dph * units.DPH_TO_RPS] * 3 + [accel_sd_ug * units.UG_TO_MPS2] * 3)
        out += rng.normal(size=out.shape) * sd
        if pulses:
            acc = np.floor(np.cumsum(out * dt / w_pulse, axis=0))
            counts = np.diff(np.vstack([np.zeros(6), acc]), axis=0)
            log_vals, to_si = counts, w_pulse / dt
        else:
            to_si = np.array([units.DPH_TO_RPS] * 3 + [units.UG_TO_MPS2] * 3)
            log_vals = out / to_si
        cols: dict[str, object] = {"time_s": t, "run": name}
        for j, ch in enumerate(CHANNELS):
            cols[ch] = log_vals[:, j]
        for j, ch in enumerate(CHANNELS):
            cols[f"temp_{ch}"] = temps[:, j] + rng.normal(0, 0.004, m)
        cols["temp_out"] = chamber + 0.1
        cols["chamber_temp"] = chamber
        cols["table_outer_deg"] = arr[:, 0]
        cols["table_inner_deg"] = arr[:, 1]
        cols["table_outer_rate_dps"] = arr[:, 2]
        cols["table_inner_rate_dps"] = arr[:, 3]
        frames.append(pd.DataFrame(cols))
        for c in points:
            used = (kind != "move") & (chamber == c if not ramp else True)
            if ramp:
                continue
            mean_t = temps[used].mean(axis=0)
            for p in PARAMETERS:
                v = float(truth.value(p.name, mean_t[p.channel]))
                if p.kind == "bias":
                    v += on[p.channel] / p.to_si
                truth_rows.append((float(c), p.name, v, 0.0, p.unit))
    log = pd.concat(frames, ignore_index=True)
    meta = {
        "generator": "tests/_imu_synth",
        "protocol": "multiposition",
        "imu": "synthetic",
        "units": dict(
            zip(
                CHANNELS,
                ["pulse" if pulses else u for u in ["deg/h"] * 3 + ["ug"] * 3],
                strict=True,
            )
        ),
        "unit_to_si": dict(
            zip(CHANNELS, (w_pulse / dt if pulses else to_si).tolist(), strict=True)
        ),
        "latitude_deg": LAT_DEG,
        "heading_deg": HEADING_DEG,
        "altitude_m": ALT_M,
        "rate_hz": d.rate_hz,
        "seed": seed,
        "set_points_c": {} if ramp else dict(zip(names, map(float, set_points), strict=True)),
        "sequence": "test19",
        "turntable": {"position_error_arcmin": 0.0, "rate_error_ppm": 0.0, "ideal": True},
    }
    truth_df = pd.DataFrame(
        truth_rows, columns=["temperature_c", "parameter", "value", "sd", "unit"]
    )
    return log, meta, truth_df
