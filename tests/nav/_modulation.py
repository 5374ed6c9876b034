"""Cycle means over the four-position sequence, by quadrature of its moves (test helper).

Written out from the positions, dwell, cruise rate and acceleration alone, independently of
:class:`rinscal.nav.rotation.RotationSchedule`, so that tests can check the schedule and what
navigation makes of it against it.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from scipy.integrate import quad

D2R = math.pi / 180.0
#: the default sequence of the paper (Section 2.1): positions [deg], dwell [s], rate [deg/s],
#: acceleration [deg/s²]
POSITIONS_DEG = (-135.0, 45.0, 135.0, -45.0)
DWELL_S, RATE_DPS, ACCEL_DPS2 = 60.0, 10.0, 10.0


def _move_angle(
    t: float, p: float, sgn: float, d: float, a: float, peak: float, ta: float, tc: float
) -> float:
    """Angle at ``t`` into a move from ``p`` by ``sgn·d``: accelerate at ``a`` for ``ta`` up
    to ``peak``, cruise for ``tc``, decelerate for ``ta``."""
    if t < ta:
        x = 0.5 * a * t * t
    elif t < ta + tc:
        x = 0.5 * a * ta * ta + peak * (t - ta)
    else:
        x = d - 0.5 * a * (2 * ta + tc - t) ** 2
    return p + sgn * x


def cycle_mean(
    g: Callable[[float], float],
    positions_deg: tuple[float, ...] = POSITIONS_DEG,
    dwell_s: float = DWELL_S,
    rate_dps: float = RATE_DPS,
    accel_dps2: float = ACCEL_DPS2,
) -> tuple[float, float]:
    """Mean of ``g(φ)`` over one cycle of the four-position sequence, and the cycle length.

    Each position is held ``dwell_s``; each move goes by the plain difference to the next
    position with a trapezoidal rate: ``accel`` up to ``rate`` (or a triangle when the move is
    too short), cruise, ``accel`` down. Moves are integrated by adaptive quadrature.
    """
    pos = [p * D2R for p in positions_deg]
    w, a = rate_dps * D2R, accel_dps2 * D2R
    total = cycle = 0.0
    for i, p in enumerate(pos):
        q = pos[(i + 1) % len(pos)]
        total += g(p) * dwell_s
        cycle += dwell_s
        d = abs(q - p)
        peak = min(w, math.sqrt(d * a))
        ta, tc = peak / a, d / peak - peak / a
        prof = (p, math.copysign(1.0, q - p), d, a, peak, ta, tc)
        val, _ = quad(
            lambda t, prof=prof: g(_move_angle(t, *prof)),
            0.0,
            2 * ta + tc,
            points=[ta, ta + tc],
            epsabs=1e-13,
            epsrel=1e-12,
        )
        total += val
        cycle += 2 * ta + tc
    return total / cycle, cycle
