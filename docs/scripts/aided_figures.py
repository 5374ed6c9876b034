"""Figures of the aided INS (docs/navigation.md, "Aided navigation"): in-motion alignment and
GNSS-aided navigation on the tests' drive (``tests/nav/_drive.py``), ours and pyins'.

    PYTHONPATH=src python docs/scripts/aided_figures.py --seeds 1-12
    PYTHONPATH=src python docs/scripts/aided_figures.py --seeds 1-12 --cold
    PYTHONPATH=src python docs/scripts/aided_figures.py --seeds 1-12 --cold \
        --accel-walk 600 --gyro-walk 0.02
    PYTHONPATH=src python docs/scripts/aided_figures.py --seeds 1-12 --rotate
    PYTHONPATH=src python docs/scripts/aided_figures.py --seeds 11 --hours 1 --pyins

Prints, per seed, the heading error at 5 min and the filter's σ, the 3-D position error RMS
and maximum over the run [m] (at every fix, after the in-motion alignment's start), and
with ``--pyins`` the same for pyins' feedback filter on the same data; then the mean, the
rms and a 95 % interval (Student t) of the heading errors over the seeds.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
from scipy import stats

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from tests.nav._drive import WARM_S, paper_noise, simulate_drive
from tests.nav.test_gnss_ins import (
    _heading_error_deg,
    _position_error_m,
    _pyins_aided,
)

from rinscal.nav.inmotion import navigate_aided
from rinscal.nav.rotation import RotationSchedule
from rinscal.sim.config import load_imu
from rinscal.sim.trajectory import euler_from_C_nb


def _seeds(text: str) -> list[int]:
    a, _, b = text.partition("-")
    return list(range(int(a), int(b or a) + 1))


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--seeds", default="1-12", help="seed or range, e.g. 1-12")
    p.add_argument("--hours", type=float, default=300.0 / 3600.0, help="drive length [h]")
    p.add_argument("--cold", action="store_true", help="cold start (powered_s = 0)")
    p.add_argument("--pyins", action="store_true", help="also run pyins' filter")
    p.add_argument("--rotate", action="store_true", help="four-position table under the IMU")
    p.add_argument("--accel-walk", type=float, help="accelerometer bias random walk [µg/√h]")
    p.add_argument("--gyro-walk", type=float, help="gyro bias random walk [°/h/√h]")
    args = p.parse_args()
    warnings.filterwarnings("ignore")
    noise = paper_noise(load_imu("paper"))
    if args.accel_walk is not None:  # µg/√h → m/s²/√s
        noise = replace(noise, accel_bias_rw=args.accel_walk * 9.80665e-6 / 60.0)
    if args.gyro_walk is not None:  # °/h/√h → rad/s/√s
        noise = replace(noise, gyro_bias_rw=math.radians(args.gyro_walk) / 3600.0 / 60.0)
    heads = []
    print("seed  heading@5min[deg]  sigma[deg]  rms[m]  max[m]  coarse[deg]  (pyins ...)")
    for seed in _seeds(args.seeds):
        d = simulate_drive(
            args.hours * 3600.0,
            seed=seed,
            powered_s=0.0 if args.cold else WARM_S,
            schedule=RotationSchedule.four_position() if args.rotate else None,
        )
        t0 = time.perf_counter()
        res = navigate_aided(d.dtheta, d.dv, d.dt, d.track, noise)
        t_ours = time.perf_counter() - t0
        c, a = res.coarse, res.aided
        u = a.updated
        h = _heading_error_deg(d, a.t[u], a.C_nr[u])
        j = int(np.searchsorted(a.t[u], 300.0))
        j = min(j, h.size - 1)
        e = np.linalg.norm(_position_error_m(d, a.t[u], a.lat[u], a.lon[u], a.alt[u]), axis=1)
        hc = _heading_error_deg(d, np.array([c.t]), c.C_nr[None])[0]
        line = (
            f"{seed:4d}  {h[j]:+.4f}  {math.degrees(a.sd[u][j, 8]):.4f}  "
            f"{np.sqrt(np.mean(e**2)):.3f}  {e.max():.3f}  {hc:+.3f}  ours {t_ours:.1f} s"
        )
        heads.append(h[j])
        if args.pyins:
            t0 = time.perf_counter()
            tr, t = _pyins_aided(d, c.index, c.C_nr, c.lat, c.lon, c.alt, c.v_n, noise)
            t_py = time.perf_counter() - t0
            k = np.searchsorted(d.t, np.round(t, 6))
            hp = (tr.heading.to_numpy() - np.degrees(euler_from_C_nb(d.C_nr[k])[:, 0]) + 180) % 360
            hp -= 180
            jp = min(int(np.searchsorted(t, 300.0)), hp.size - 1)
            ep = np.linalg.norm(
                _position_error_m(
                    d,
                    t,
                    np.radians(tr.lat.to_numpy()),
                    np.radians(tr.lon.to_numpy()),
                    tr.alt.to_numpy(),
                ),
                axis=1,
            )
            line += (
                f"  | pyins {hp[jp]:+.4f}  {np.sqrt(np.mean(ep**2)):.3f}  {ep.max():.3f}"
                f"  {t_py:.1f} s"
            )
        print(line, flush=True)
    x = np.array(heads)
    if x.size > 1:
        half = stats.t.ppf(0.975, x.size - 1) * x.std(ddof=1) / math.sqrt(x.size)
        print(
            f"heading@5min over {x.size} seeds: mean {x.mean():+.4f} ± {half:.4f} deg (95 %), "
            f"rms {np.sqrt(np.mean(x**2)):.4f}, max |.| {np.abs(x).max():.4f}"
        )


if __name__ == "__main__":
    main()
