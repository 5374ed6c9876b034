"""Benchmark the navigation package (issue: single-axis rotational INS).

Targets, on one core:

1. the strapdown integrator alone: < 150 ns per step (moving vehicle increments, so the
   latitude-dependent terms are recomputed every step; the static case is also shown);
2. a whole 8 h, 200 Hz quasi-static cold-start scenario (ideal-IMU synthesis with
   four-position modulation, thermal plant errors and noise, coarse + Kalman alignment,
   navigation, error report): < 10 s wall time and < 2 GB peak memory;
3. our synthesis + integration against pyins's (``pyins.sim.generate_imu`` +
   ``compute_increments_from_imu`` + ``Integrator``) on the same 2 h, 100 Hz vehicle
   trajectory: time ratio (target: ours at least 10× faster, issue 12), and both position
   errors against the truth.

Each part runs in its own child process (pinned to the first allowed core) so that its
peak resident memory is its own; numba kernels are compiled (or loaded from the cache)
before timing.

    taskset -c 0 python benchmarks/bench_nav.py [--part all|integrator|scenario|pyins]
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import time

import numpy as np

TARGET_NS = 150.0
TARGET_S = 10.0
TARGET_GB = 2.0
#: pyins's time over ours for synthesis + integration (issue 12).
TARGET_PYINS_SPEEDUP = 10.0


def _rss_gb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024**2


def _ok(good: bool) -> str:
    return "OK" if good else "MISSED"


def part_integrator() -> None:
    from rinscal.nav.rotation import C_br, RotationSchedule
    from rinscal.nav.strapdown import Strapdown
    from rinscal.sim.ideal_imu import ImuSynthesizer
    from rinscal.sim.trajectory import C_nb_from_euler, StaticMotion, vehicle_route

    for label, traj, seconds in (
        ("vehicle (moving)", vehicle_route(duration_s=3000.0, stationary_s=60.0), 3000.0),
        ("quasi-static", StaticMotion(), 3000.0),
    ):
        sched = RotationSchedule.four_position()
        syn = ImuSynthesizer(traj, sched, 200.0)
        ch = syn.next_chunk(int(seconds * 200))
        kin = traj.kinematics(np.zeros(1))
        C_nr = C_nb_from_euler(kin.euler[0]) @ C_br(sched.angle(0.0)[0])

        def make() -> Strapdown:
            return Strapdown(traj.lat0, traj.lon0, traj.alt0, kin.v_n[0], C_nr, 1 / 200, "hold")  # noqa: B023

        make().run(ch.dtheta[:10], ch.dv[:10], alt_ref=ch.alt[:10], vu_ref=ch.v_n[:10, 2])
        best = np.inf
        for _ in range(5):
            nav = make()
            t0 = time.perf_counter()
            nav.run(ch.dtheta, ch.dv, alt_ref=ch.alt, vu_ref=ch.v_n[:, 2], out_every=200)
            best = min(best, time.perf_counter() - t0)
        ns = best / ch.n * 1e9
        print(
            f"integrator alone, {label:17s}: {ns:6.1f} ns/step ({ch.n:,} steps, best of 5)  "
            f"target < {TARGET_NS:.0f} ns  {_ok(ns < TARGET_NS)}"
        )


def part_scenario() -> None:
    from rinscal.sim.config import ImuConfig
    from rinscal.sim.scenario import ThermalPlant, preset, run_scenario

    imu = ImuConfig.paper()  # every effect on: Shupe, hysteresis, scale factor,
    assert all(vars(imu.effects).values())  # misalignment, lever arm, hot side by angle
    # warm the compiled kernels (cache) on a short run
    short = preset("quasi-static", hours=0.2, rate_hz=200.0)
    run_scenario(short, ThermalPlant.for_scenario(imu, short, seed=0))
    cfg = preset("quasi-static", hours=8.0, rate_hz=200.0)
    t0 = time.perf_counter()
    plant = ThermalPlant.for_scenario(imu, cfg, seed=1)
    res = run_scenario(cfg, plant)
    wall = time.perf_counter() - t0
    n = round(cfg.duration_s * cfg.rate_hz)
    rss = _rss_gb()
    print(
        f"8 h x 200 Hz quasi-static cold start, paper preset, every effect on ({n:,} samples:"
        f" synthesis, thermal field by encoder angle, errors + noise, alignment, navigation)"
    )
    print(f"  wall time {wall:.2f} s  target < {TARGET_S:.0f} s  {_ok(wall < TARGET_S)}")
    print(f"  peak RSS  {rss:.2f} GB  target < {TARGET_GB:.0f} GB  {_ok(rss < TARGET_GB)}")
    print(f"  max position error {res.max_error_m('none') / 1852:.2f} nmi (uncompensated)")


def part_pyins() -> None:
    import dataclasses

    from rinscal import earth
    from rinscal.nav.rotation import RotationSchedule
    from rinscal.nav.strapdown import Strapdown
    from rinscal.sim.ideal_imu import ImuSynthesizer
    from rinscal.sim.trajectory import C_nb_from_euler, StepChannel, vehicle_route

    try:
        import pyins.sim
        import pyins.strapdown
        import pyins.transform
    except ImportError:
        print("pyins not installed: skipping the comparison")
        return

    rate, seconds = 100, 7200.0
    # flat route: pyins without altitude zeroes the vertical velocity
    route = dataclasses.replace(
        vehicle_route(duration_s=seconds - 60.0, stationary_s=60.0), grade=StepChannel(0.0)
    )
    sched = RotationSchedule.none()
    kin0 = route.kinematics(np.zeros(1))
    C_nr0 = C_nb_from_euler(kin0.euler[0])

    def ours() -> tuple[float, np.ndarray, np.ndarray]:
        t0 = time.perf_counter()
        syn = ImuSynthesizer(route, sched, rate)
        nav = Strapdown(route.lat0, route.lon0, route.alt0, kin0.v_n[0], C_nr0, 1 / rate, "hold")
        pos, tru = [], []
        for ch in syn.chunks(seconds, 60.0):
            out = nav.run(ch.dtheta, ch.dv, alt_ref=ch.alt, vu_ref=ch.v_n[:, 2], out_every=rate)
            pos.append(out[:, :2])
            sel = (ch.k0 + np.arange(1, ch.n + 1)) % rate == 0
            tru.append(np.column_stack([ch.lat[sel], ch.lon[sel]]))
        return time.perf_counter() - t0, np.concatenate(pos), np.concatenate(tru)

    ours()  # warm-up (compile / load cache)
    t_ours, pos_ours, truth = ours()

    # the same trajectory handed to pyins: time, lla [deg], rph [deg] (NED/FRD), v_NED
    t = np.arange(int(seconds * rate) + 1) / rate
    P = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
    syn = ImuSynthesizer(route, sched, rate)
    lat, lon, alt, vel, eul = (
        [route.lat0],
        [route.lon0],
        [route.alt0],
        [kin0.v_n[0]],
        [kin0.euler[0]],
    )
    for ch in syn.chunks(seconds, 600.0):
        lat.append(ch.lat)
        lon.append(ch.lon)
        alt.append(ch.alt)
        vel.append(ch.v_n)
        eul.append(ch.euler)
    lla = np.column_stack([np.rad2deg(np.hstack(lat)), np.rad2deg(np.hstack(lon)), np.hstack(alt)])
    v_ned = np.vstack(vel) @ P.T
    C = C_nb_from_euler(np.vstack(eul))
    rph = pyins.transform.mat_to_rph(P @ C @ P)
    t0 = time.perf_counter()
    traj, imu = pyins.sim.generate_imu(t, lla, rph, v_ned, sensor_type="increment")
    inc = pyins.strapdown.compute_increments_from_imu(imu, "increment")
    integ = pyins.strapdown.Integrator(traj.iloc[0], with_altitude=False)
    res = integ.integrate(inc)
    t_pyins = time.perf_counter() - t0
    lat_p = np.deg2rad(res["lat"].to_numpy()[1:][rate - 1 :: rate])
    lon_p = np.deg2rad(res["lon"].to_numpy()[1:][rate - 1 :: rate])
    pos_p = np.column_stack([lat_p, lon_p])

    def dist(a: np.ndarray, b: np.ndarray) -> float:
        rn, re = earth.principal_radii(b[:, 0])
        return float(
            np.max(np.hypot((a[:, 0] - b[:, 0]) * rn, (a[:, 1] - b[:, 1]) * re * np.cos(b[:, 0])))
        )

    n = int(seconds * rate)
    print(f"2 h x {rate} Hz vehicle trajectory ({n:,} samples), ideal IMU synthesis + integration")
    e_ours, e_pyins = dist(pos_ours, truth) * 1000, dist(pos_p, truth) * 1000
    print(f"  ours  {t_ours:7.2f} s   max position error vs truth {e_ours:8.2f} mm")
    print(f"  pyins {t_pyins:7.2f} s   max position error vs truth {e_pyins:8.2f} mm")
    speedup = t_pyins / t_ours
    print(
        f"  time ratio ours/pyins = {t_ours / t_pyins:.3f}  (pyins/ours = {speedup:.1f}x)  "
        f"target >= {TARGET_PYINS_SPEEDUP:.0f}x  {_ok(speedup >= TARGET_PYINS_SPEEDUP)}"
    )
    print(f"  peak RSS of this part {_rss_gb():.2f} GB")


PARTS = {"integrator": part_integrator, "scenario": part_scenario, "pyins": part_pyins}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--part", choices=["all", *PARTS], default="all")
    args = parser.parse_args()
    if args.part != "all":
        cpu = min(os.sched_getaffinity(0))
        os.sched_setaffinity(0, {cpu})
        PARTS[args.part]()
        return
    for name in PARTS:
        subprocess.run([sys.executable, __file__, "--part", name], check=True)


if __name__ == "__main__":
    main()
