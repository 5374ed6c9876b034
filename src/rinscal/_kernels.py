"""Numba kernels of navigation and the simulator (private; compiled once and cached on disk).

Everything here works on plain float64 arrays and scalars in SI units, ENU navigation
frame, r (rotating IMU) frame increments. The public wrappers live in
:mod:`rinscal.nav.strapdown`, :mod:`rinscal.sim.ideal_imu`, :mod:`rinscal.nav.rotation`,
:mod:`rinscal.sim.trajectory` and :mod:`rinscal.nav.align`.

State vector of the strapdown integrator (``STATE_SIZE`` float64)::

    0 lat [rad]   1 lon [rad]   2 alt [m]
    3 vE  4 vN  5 vU [m/s]
    6..9  quaternion of C_nr (scalar first, v_n = q ⊗ v_r ⊗ q*)
    10..12 previous angle increment [rad]    13..15 previous velocity increment [m/s]
    16 previous-increment flag (0: none yet)
    17 vertical-loop acceleration-error state [m/s²] (damped mode)
    18..20 velocity change of the previous step in n [m/s] (mid-interval extrapolation)
"""

from __future__ import annotations

import math

import numba
import numpy as np
from numpy.typing import NDArray

from rinscal import earth

# Constants copied into the compiled code (numba freezes module globals at compile time).
_A = earth.A
_E2 = earth.E2
_F = earth.F
_GE = earth.GE
_K = earth.K_SOMIGLIANA
_M = earth.M_RATIO
_RATE = earth.RATE

STATE_SIZE = 21
#: Vertical-channel modes of :func:`strapdown`.
VERTICAL_HOLD, VERTICAL_DAMPED, VERTICAL_FREE = 0, 1, 2
#: Columns of the integrator's output rows: lat, lon, alt, vE, vN, vU, q0..q3.
OUT_SIZE = 10

#: Gauss-Legendre nodes on [-1, 1] and weights (4 points, exact to degree 7).
GL_X = np.array([-0.8611363115940526, -0.3399810435848563, 0.3399810435848563, 0.8611363115940526])
GL_W = np.array([0.3478548451374538, 0.6521451548625461, 0.6521451548625461, 0.3478548451374538])

_jit = numba.njit(cache=True, fastmath=False, nogil=True)


# --------------------------------------------------------------------------- corrections
@_jit
def less_rates(
    dtheta: NDArray[np.float64],
    dv: NDArray[np.float64],
    rates: NDArray[np.float64],
    dt: NDArray[np.float64],
    out_theta: NDArray[np.float64],
    out_v: NDArray[np.float64],
) -> None:  # pragma: no cover - numba
    """Increments less rates over each sample's interval, in one pass (no temporaries):
    ``out_theta[i] = dtheta[i] − rates[r, :3] · dt[i]``, ``out_v[i] = dv[i] − rates[r, 3:] ·
    dt[i]`` [rad, m/s], ``r = i`` (a rate per sample, ``rates`` (n, 6)) or 0 (one rate for
    all, (1, 6)) [rad/s, m/s²]. The product, then the difference, each rounded as numpy's
    ``dtheta - rates[:, :3] * dt[:, None]`` rounds them (no fused multiply-add)."""
    one = rates.shape[0] == 1
    for i in range(dtheta.shape[0]):
        r = 0 if one else i
        h = dt[i]
        for j in range(3):
            out_theta[i, j] = dtheta[i, j] - rates[r, j] * h
            out_v[i, j] = dv[i, j] - rates[r, 3 + j] * h


# --------------------------------------------------------------------------- encoder angle
@_jit
def unwrap_angle(
    a: NDArray[np.float64],
    prev_raw: float,
    prev_unwrapped: float,
    first: bool,
    out: NDArray[np.float64],
) -> None:  # pragma: no cover - numba
    """A wrapped angle made continuous [rad], into ``out``: a step of more than half a turn
    between two readings is taken as the wrap. ``first``: ``a`` is the start (as
    ``numpy.unwrap(a)``); else it follows the reading ``prev_raw`` [rad], unwrapped to
    ``prev_unwrapped`` [rad] (as ``unwrap([prev_raw, *a])[1:] − prev_raw + prev_unwrapped``).

    Rounded as numpy's ``unwrap`` rounds it (the step taken modulo a turn as numpy's ``mod``
    takes it, the corrections summed in order): the same bits, in one pass.
    """
    period = 2.0 * np.pi
    high = period / 2.0
    low = -high
    prev = a[0] if first else prev_raw
    c = 0.0
    for i in range(a.shape[0]):
        x = a[i]
        if first and i == 0:
            out[0] = x
            continue
        dd = x - prev
        prev = x
        if not abs(dd) < high:
            r = np.fmod(dd - low, period)
            if r != 0.0:
                if (period < 0.0) != (r < 0.0):
                    r += period
            else:
                r = math.copysign(0.0, period)
            ddmod = r + low
            if ddmod == low and dd > 0.0:
                ddmod = high
            c += ddmod - dd
        else:
            c += 0.0
        out[i] = x + c if first else ((x + c) - prev_raw) + prev_unwrapped


# --------------------------------------------------------------------------- per-second sums
#: Columns of :func:`piece_sums`'s per-second sums: samples, Σ|f|, Σ|f|², Σf (3), Σω (3),
#: Σ(Δf)² (3), Σ(Δω)² (3), Σ encoder turn, Σ gap flags.
SECOND_SUMS = 17
#: Columns of its short blocks' sums: samples, Σf (3), Σω_x, Σω_y, Σω_z beyond the encoder,
#: Σψ.
SUB_SUMS = 8


@_jit
def piece_sums(
    t: NDArray[np.float64],
    dt: NDArray[np.float64],
    dtheta: NDArray[np.float64],
    dv: NDArray[np.float64],
    origin: float,
    block_s: float,
    lo: int,
    subs: int,
    prev_w: NDArray[np.float64],
    prev_f: NDArray[np.float64],
    turn: NDArray[np.float64],
    table: bool,
    first_table: bool,
    psi: NDArray[np.float64],
    gap_limit: float,
    sums: NDArray[np.float64],
    sub: NDArray[np.float64],
    t0: NDArray[np.float64],
    t1: NDArray[np.float64],
) -> None:  # pragma: no cover - numba
    """One piece's per-second and short-block sums of the first pass, in one pass over its
    samples and without temporaries.

    Sample ``i`` (interval ``dt[i]`` [s] ending at ``t[i]`` [s]) falls in block
    ``floor((t − dt/2 − origin) / block_s) − lo`` (row of ``sums`` (m, :data:`SECOND_SUMS`), zeros
    on entry) and in its ``subs`` short blocks by the fraction of the second (row of ``sub``
    (m·subs, :data:`SUB_SUMS`), zeros on entry). With the rate ``w = dtheta/dt`` [rad/s] and
    the force ``f = dv/dt`` [m/s²], a block gets the sample's count (1), ``|f|``, ``|f|²``,
    ``f`` and ``w`` (3 each), the squares of their first differences (3 each; the first
    sample's against ``prev_w``, ``prev_f``, the piece before's last), the encoder's
    ``turn`` [rad] and a gap flag (``dt`` above ``gap_limit`` [s]); a short block the count,
    ``f``, ``w_x``, ``w_y``, ``w_z`` less the encoder's turn rate (``table``; the first
    reading's turn unknown, ``first_table``: the next one's) and the table angle ``psi``
    [rad]. ``t0``/``t1`` (m; +inf/−inf on entry) get each block's first interval start and
    last sample time [s].

    Every value is rounded as numpy rounds the same expressions element by element
    (``|f|`` as ``sqrt(einsum("ij,ij->i", f, f))``, which adds x², z², then y²; the index as
    ``floor`` then ``astype``), and
    each sum adds the samples in their order, a square rounded first, as numpy's
    ``bincount(k, weights=x)`` does: the sums of the numpy code this replaced, to the bit.
    """
    m = sums.shape[0]
    n = t.shape[0]
    for i in range(n):
        h = dt[i]
        y = (t[i] - 0.5 * h - origin) / block_s
        fy = np.floor(y)
        b = np.int64(fy) - lo
        if b < 0 or b >= m:
            raise ValueError("piece_sums: a block index outside the output")
        kb = np.int64((y - fy) * subs)
        kb = b * subs + (kb if kb < subs - 1 else subs - 1)
        fx_ = dv[i, 0] / h
        fy_ = dv[i, 1] / h
        fz_ = dv[i, 2] / h
        wx = dtheta[i, 0] / h
        wy = dtheta[i, 1] / h
        wz = dtheta[i, 2] / h
        if i == 0:
            px, py, pz = prev_f[0], prev_f[1], prev_f[2]
            qx, qy, qz = prev_w[0], prev_w[1], prev_w[2]
        else:
            g = dt[i - 1]
            px, py, pz = dv[i - 1, 0] / g, dv[i - 1, 1] / g, dv[i - 1, 2] / g
            qx, qy, qz = dtheta[i - 1, 0] / g, dtheta[i - 1, 1] / g, dtheta[i - 1, 2] / g
        fm = np.sqrt((fx_ * fx_ + fz_ * fz_) + fy_ * fy_)  # einsum's order (see above)
        if sums[b, 0] == 0.0:
            t0[b] = t[i] - h
        t1[b] = t[i]
        sums[b, 0] += 1.0
        sums[b, 1] += fm
        sums[b, 2] += fm * fm
        sums[b, 3] += fx_
        sums[b, 4] += fy_
        sums[b, 5] += fz_
        sums[b, 6] += wx
        sums[b, 7] += wy
        sums[b, 8] += wz
        d = fx_ - px
        sums[b, 9] += d * d
        d = fy_ - py
        sums[b, 10] += d * d
        d = fz_ - pz
        sums[b, 11] += d * d
        d = wx - qx
        sums[b, 12] += d * d
        d = wy - qy
        sums[b, 13] += d * d
        d = wz - qz
        sums[b, 14] += d * d
        sums[b, 15] += turn[i]
        sums[b, 16] += 0.0 if h <= gap_limit else 1.0
        if table:
            if i == 0 and first_table and n > 1:
                wz = wz - turn[1] / dt[1]
            else:
                wz = wz - turn[i] / h
        sub[kb, 0] += 1.0
        sub[kb, 1] += fx_
        sub[kb, 2] += fy_
        sub[kb, 3] += fz_
        sub[kb, 4] += wx
        sub[kb, 5] += wy
        sub[kb, 6] += wz
        sub[kb, 7] += psi[i]


# --------------------------------------------------------------------------- model domain
#: Least and greatest float a float64 → int64 cast keeps (beyond, NaN and ±inf: INT64_MIN).
_I64_LO = -9.223372036854775808e18


@_jit
def _cell(x: float, lo: float, hi: float, bins: int) -> int:  # pragma: no cover - numba
    """The cell of ``x`` among ``bins`` over ``[lo, hi]``: ``floor((x − lo) / width)``
    clipped into ``0 .. bins − 1`` (``width`` 1 where ``hi ≤ lo``), as numpy's passes give
    it: a value the cast to int64 cannot hold (NaN, ±inf, beyond 2⁶³) gives the least int64,
    which the clip makes cell 0."""
    width = (hi - lo) / bins if hi > lo else 1.0
    z = np.floor((x - lo) / width)
    if not _I64_LO <= z < -_I64_LO:  # NaN fails both
        return 0
    j = np.int64(z)
    if j < 0:
        return 0
    return bins - 1 if j > bins - 1 else j


@_jit
def flat_cells(
    c0: NDArray[np.float64],
    c1: NDArray[np.float64],
    c2: NDArray[np.float64],
    k: int,
    lo: NDArray[np.float64],
    hi: NDArray[np.float64],
    bins: NDArray[np.int64],
    out: NDArray[np.int64],
) -> None:  # pragma: no cover - numba
    """Row-major flat cell number of each sample of the first ``k`` of the inputs ``c0``,
    ``c1``, ``c2`` (n each) on the grid of ``bins`` cells over ``[lo, hi]`` per input
    (:func:`_cell` each), into ``out`` (n), in one pass: the numbers of
    :func:`rinscal.calibration._domain._flat_cells`'s numpy passes to the bit."""
    for i in range(out.shape[0]):
        flat = 0
        for v in range(k):
            x = c0[i] if v == 0 else (c1[i] if v == 1 else c2[i])
            flat = flat * bins[v] + _cell(x, lo[v], hi[v], bins[v])
        out[i] = flat


@_jit
def inside_cells(
    c0: NDArray[np.float64],
    c1: NDArray[np.float64],
    c2: NDArray[np.float64],
    k: int,
    lo: NDArray[np.float64],
    hi: NDArray[np.float64],
    bins: NDArray[np.int64],
    grid: NDArray[np.bool_],
    out: NDArray[np.bool_],
) -> None:  # pragma: no cover - numba
    """Whether each sample lies in a joint domain, in one pass: its flat cell (as
    :func:`flat_cells`) is occupied in ``grid`` (flat, row-major) and every input lies within
    ``[lo − w, hi + w]``, ``w = (hi − lo) / bins`` (0 where ``hi ≤ lo``); ``out`` (n). The
    answers of :func:`rinscal.calibration._domain.inside_domain`'s numpy passes."""
    for i in range(out.shape[0]):
        flat = 0
        box = True
        for v in range(k):
            x = c0[i] if v == 0 else (c1[i] if v == 1 else c2[i])
            flat = flat * bins[v] + _cell(x, lo[v], hi[v], bins[v])
            w = (hi[v] - lo[v]) / bins[v] if hi[v] > lo[v] else 0.0
            box = box and (x >= lo[v] - w) and (x <= hi[v] + w)
        out[i] = grid[flat] and box


# --------------------------------------------------------------------------- alignment filter
@_jit
def kf_zero_velocity_update(
    P: NDArray[np.float64],
    F: NDArray[np.float64],
    Qc: NDArray[np.float64],
    T: float,
    v_e: float,
    v_n: float,
    r_var: float,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """One block of the fine-alignment Kalman filter: propagate the covariance ``P`` over
    ``T`` [s] with the continuous dynamics ``F`` and white-noise densities ``Qc``
    (second-order transition matrix, trapezoidal process noise), then update with the
    measured horizontal velocity ``(v_e, v_n)`` [m/s] (truth zero) of variance ``r_var``
    [m²/s²] on states 3 and 4 (Joseph form).

    Returns
    -------
    P : ndarray (n, n)
        The updated covariance.
    x : ndarray (n,)
        The state correction.
    """
    n = P.shape[0]
    Phi = np.eye(n) + F * T + 0.5 * (F @ F) * (T * T)
    Q = np.diag(Qc * T)
    Q = 0.5 * (Phi @ Q @ Phi.T + Q)
    P = Phi @ P @ Phi.T + Q
    s00 = P[3, 3] + r_var
    s01 = P[3, 4]
    s10 = P[4, 3]
    s11 = P[4, 4] + r_var
    det = s00 * s11 - s01 * s10
    i00, i01, i10, i11 = s11 / det, -s01 / det, -s10 / det, s00 / det
    K = np.empty((n, 2))
    for i in range(n):
        K[i, 0] = P[i, 3] * i00 + P[i, 4] * i10
        K[i, 1] = P[i, 3] * i01 + P[i, 4] * i11
    x = K[:, 0] * v_e + K[:, 1] * v_n
    IKH = np.eye(n)
    for i in range(n):
        IKH[i, 3] -= K[i, 0]
        IKH[i, 4] -= K[i, 1]
    P = IKH @ P @ IKH.T + r_var * (K @ K.T)
    return P, x


# --------------------------------------------------------------------------- small helpers
@_jit
def gravity_scalar(lat: float, alt: float) -> float:
    """Normal gravity magnitude, same formula as :func:`rinscal.earth.gravity` [m/s²]."""
    s2 = math.sin(lat) ** 2
    g0 = _GE * (1.0 + _K * s2) / math.sqrt(1.0 - _E2 * s2)
    return g0 * (1.0 - 2.0 / _A * (1.0 + _F + _M - 2.0 * _F * s2) * alt + 3.0 * alt * alt / _A**2)


@_jit
def _exp_half(n2: float) -> tuple[float, float]:
    """cos(|x|/2) and sin(|x|/2)/|x| from |x|² (series below 1e-4 rad²)."""
    if n2 < 1e-4:
        c = 1.0 - n2 / 8.0 + n2 * n2 / 384.0 - n2 * n2 * n2 / 46080.0
        s = 0.5 - n2 / 48.0 + n2 * n2 / 3840.0 - n2 * n2 * n2 / 645120.0
    else:
        n = math.sqrt(n2)
        c = math.cos(0.5 * n)
        s = math.sin(0.5 * n) / n
    return c, s


@_jit
def quat_from_rotvec(x: float, y: float, z: float) -> tuple[float, float, float, float]:
    """Quaternion of the rotation vector (x, y, z) [rad]."""
    c, s = _exp_half(x * x + y * y + z * z)
    return c, s * x, s * y, s * z


@_jit
def quat_mul(
    a0: float, a1: float, a2: float, a3: float, b0: float, b1: float, b2: float, b3: float
) -> tuple[float, float, float, float]:
    """Hamilton product a ⊗ b."""
    return (
        a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3,
        a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
        a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1,
        a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0,
    )


@_jit
def quat_rotate(
    q0: float, q1: float, q2: float, q3: float, x: float, y: float, z: float
) -> tuple[float, float, float]:
    """q ⊗ v ⊗ q* for a unit quaternion q."""
    # t = 2 u × v ; v' = v + q0 t + u × t
    tx = 2.0 * (q2 * z - q3 * y)
    ty = 2.0 * (q3 * x - q1 * z)
    tz = 2.0 * (q1 * y - q2 * x)
    return (
        x + q0 * tx + (q2 * tz - q3 * ty),
        y + q0 * ty + (q3 * tx - q1 * tz),
        z + q0 * tz + (q1 * ty - q2 * tx),
    )


@_jit
def _third_order(
    t0: float,
    t1: float,
    t2: float,
    w0: float,
    w1: float,
    w2: float,
    u0: float,
    u1: float,
    u2: float,
) -> tuple[float, float, float]:
    """Add (1/6) Δθ × (Δθ × Δv): the second-order rotation term of the specific-force integral.

    For a constant rate and specific force in r, ∫exp([ωτ×]) f dτ = f·dt + ½ ω×f dt²
    + (1/6) ω×(ω×f) dt³; the last term matters when the IMU spins (turntable moves, turns).
    """
    c0 = t1 * w2 - t2 * w1
    c1 = t2 * w0 - t0 * w2
    c2 = t0 * w1 - t1 * w0
    return (
        u0 + (t1 * c2 - t2 * c1) / 6.0,
        u1 + (t2 * c0 - t0 * c2) / 6.0,
        u2 + (t0 * c1 - t1 * c0) / 6.0,
    )


@_jit
def _coning_sculling(
    t0: float,
    t1: float,
    t2: float,
    w0: float,
    w1: float,
    w2: float,
    pt0: float,
    pt1: float,
    pt2: float,
    pv0: float,
    pv1: float,
    pv2: float,
) -> tuple[float, float, float, float, float, float]:
    """Two-sample coning and sculling (previous-sample form) with rotation compensation.

    From the increments Δθ = (t0, t1, t2) [rad], Δv = (w0, w1, w2) [m/s] and those of the
    previous interval (pt, pv): the rotation vector of r over the interval,
    ``φ = Δθ + (1/12) Δθ_prev × Δθ``, and the velocity increment in r(k-1),
    ``Δv + ½ Δθ × Δv + (1/12) (Δθ_prev × Δv + Δv_prev × Δθ)``, returned as
    (φ0, φ1, φ2, u0, u1, u2).
    """
    r0 = t0 + (pt1 * t2 - pt2 * t1) / 12.0
    r1 = t1 + (pt2 * t0 - pt0 * t2) / 12.0
    r2 = t2 + (pt0 * t1 - pt1 * t0) / 12.0
    u0 = w0 + 0.5 * (t1 * w2 - t2 * w1) + ((pt1 * w2 - pt2 * w1) + (pv1 * t2 - pv2 * t1)) / 12.0
    u1 = w1 + 0.5 * (t2 * w0 - t0 * w2) + ((pt2 * w0 - pt0 * w2) + (pv2 * t0 - pv0 * t2)) / 12.0
    u2 = w2 + 0.5 * (t0 * w1 - t1 * w0) + ((pt0 * w1 - pt1 * w0) + (pv0 * t1 - pv1 * t0)) / 12.0
    return r0, r1, r2, u0, u1, u2


@_jit
def _quat_normalize(
    q0: float, q1: float, q2: float, q3: float
) -> tuple[float, float, float, float]:
    """q / |q|."""
    qn = 1.0 / math.sqrt(q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
    return q0 * qn, q1 * qn, q2 * qn, q3 * qn


# --------------------------------------------------------------------------- strapdown
@_jit
def strapdown(
    state: np.ndarray,
    dtheta: np.ndarray,
    dv: np.ndarray,
    dt: float,
    alt_ref: np.ndarray,
    vu_ref: np.ndarray,
    vmode: int,
    k_loop: np.ndarray,
    out: np.ndarray,
    out_every: int,
    k0: int,
    rot3: bool,
) -> int:
    """Integrate ``n`` angle and velocity increments in place (Savage-style, ENU).

    Two-sample coning and sculling (previous-sample form), rotation compensation with its
    second-order term, exact
    exponential attitude updates of body and navigation frames, Coriolis and transport rate
    at the mid-interval velocity, normal gravity, trapezoidal position update.

    Parameters
    ----------
    state : ndarray, shape (STATE_SIZE,)
        Integrator state, updated in place.
    dtheta, dv : ndarray, shape (n, 3) [rad], [m/s]
        r-frame angle and velocity increments over each interval of length ``dt``.
    dt : float [s]
        Sample interval.
    alt_ref, vu_ref : ndarray, shape (n,) or (1,) [m], [m/s]
        Reference altitude and vertical velocity at the end of each interval (hold and
        damped modes); a length-1 array is used for every step.
    vmode : int
        ``VERTICAL_HOLD``, ``VERTICAL_DAMPED`` or ``VERTICAL_FREE``.
    k_loop : ndarray, shape (3,)
        Gains (k1 [1/s], k2 [1/s²], k3 [1/s³]) of the third-order damping loop.
    out : ndarray, shape (m, OUT_SIZE)
        Receives the state after every ``out_every``-th global step.
    out_every : int
        Output decimation.
    k0 : int
        Global index of the first step of this call (steps are numbered from 1 at its end).
    rot3 : bool
        Include the second-order rotation term (1/6) Δθ × (Δθ × Δv) of the specific-force
        integral (False gives the classical two-sample algorithm, as in pyins).

    Returns
    -------
    int
        Number of rows written to ``out``.
    """
    n = dtheta.shape[0]
    n_ref = alt_ref.shape[0]
    lat = state[0]
    lon = state[1]
    alt = state[2]
    vE = state[3]
    vN = state[4]
    vU = state[5]
    q0 = state[6]
    q1 = state[7]
    q2 = state[8]
    q3 = state[9]
    pt0 = state[10]
    pt1 = state[11]
    pt2 = state[12]
    pv0 = state[13]
    pv1 = state[14]
    pv2 = state[15]
    have_prev = state[16] != 0.0
    acc_err = state[17]
    dvp0 = state[18]
    dvp1 = state[19]
    dvp2 = state[20]
    k1 = k_loop[0]
    k2 = k_loop[1]
    k3 = k_loop[2]
    n_out = 0
    lat_cached = 1e300
    sinL = 0.0
    cosL = 1.0
    for i in range(n):
        t0 = dtheta[i, 0]
        t1 = dtheta[i, 1]
        t2 = dtheta[i, 2]
        w0 = dv[i, 0]
        w1 = dv[i, 1]
        w2 = dv[i, 2]
        if not have_prev:
            pt0 = t0
            pt1 = t1
            pt2 = t2
            pv0 = w0
            pv1 = w1
            pv2 = w2
            have_prev = True
        # coning (rotation vector of r over the interval), rotation compensation + sculling
        # (velocity increment in r(k-1))
        r0, r1, r2, u0, u1, u2 = _coning_sculling(
            t0, t1, t2, w0, w1, w2, pt0, pt1, pt2, pv0, pv1, pv2
        )
        if rot3:
            u0, u1, u2 = _third_order(t0, t1, t2, w0, w1, w2, u0, u1, u2)
        pt0 = t0
        pt1 = t1
        pt2 = t2
        pv0 = w0
        pv1 = w1
        pv2 = w2

        # Earth quantities at the start of the interval
        if lat != lat_cached:
            sinL = math.sin(lat)
            cosL = math.cos(lat)
            lat_cached = lat
        s2 = sinL * sinL
        x = 1.0 - _E2 * s2
        sx = math.sqrt(x)
        Re = _A / sx
        Rn = Re * (1.0 - _E2) / x
        g = _GE * (1.0 + _K * s2) / sx
        g = g * (1.0 - 2.0 / _A * (1.0 + _F + _M - 2.0 * _F * s2) * alt + 3.0 * alt * alt / _A**2)
        ReH = Re + alt
        RnH = Rn + alt
        OmN = _RATE * cosL
        OmU = _RATE * sinL
        tanL = sinL / cosL

        # mid-interval velocity, extrapolated from the previous step's change
        mE = vE + 0.5 * dvp0
        mN = vN + 0.5 * dvp1
        mU = vU + 0.5 * dvp2
        # ω_in^n = ω_ie^n + ω_en^n at mid-interval
        wE = -mN / RnH
        wN = OmN + mE / ReH
        wU = OmU + mE * tanL / ReH
        zE = wE * dt
        zN = wN * dt
        zU = wU * dt

        # specific-force increment to n: C_n(k-1)r(k-1) u, then [I - ½ ζ×]
        a0, a1, a2 = quat_rotate(q0, q1, q2, q3, u0, u1, u2)
        fE = a0 - 0.5 * (zN * a2 - zU * a1)
        fN = a1 - 0.5 * (zU * a0 - zE * a2)
        fU = a2 - 0.5 * (zE * a1 - zN * a0)
        # Coriolis + transport: (2 ω_ie + ω_en) × v_mid
        cE = wE
        cN = wN + OmN
        cU = wU + OmU
        dE = fE - (cN * mU - cU * mN) * dt
        dN = fN - (cU * mE - cE * mU) * dt
        dU = fU - (cE * mN - cN * mE) * dt - g * dt

        vE_new = vE + dE
        vN_new = vN + dN
        j = i if n_ref > 1 else 0
        if vmode == 0:
            vU_new = vu_ref[j]
            alt_new = alt_ref[j]
        elif vmode == 1:
            e = alt - alt_ref[j]
            vU_new = vU + dU - (k2 * e + acc_err) * dt
            acc_err += k3 * e * dt
            alt_new = alt + (0.5 * (vU + vU_new) - k1 * e) * dt
        else:
            vU_new = vU + dU
            alt_new = alt + 0.5 * (vU + vU_new) * dt
        dvp0 = vE_new - vE
        dvp1 = vN_new - vN
        dvp2 = vU_new - vU

        # position (trapezoid; radii at the start, cos at mid-latitude)
        dlat = 0.5 * (vN + vN_new) * dt / (Rn + 0.5 * (alt + alt_new))
        cos_mid = cosL - sinL * 0.5 * dlat
        lon += 0.5 * (vE + vE_new) * dt / ((Re + 0.5 * (alt + alt_new)) * cos_mid)
        lat += dlat
        alt = alt_new
        vE = vE_new
        vN = vN_new
        vU = vU_new

        # attitude: q ← q(−ζ) ⊗ q ⊗ q(φ)
        b0, b1, b2, b3 = quat_from_rotvec(r0, r1, r2)
        c0, c1, c2, c3 = quat_mul(q0, q1, q2, q3, b0, b1, b2, b3)
        n0, n1, n2, n3 = quat_from_rotvec(-zE, -zN, -zU)
        q0, q1, q2, q3 = quat_mul(n0, n1, n2, n3, c0, c1, c2, c3)
        q0, q1, q2, q3 = _quat_normalize(q0, q1, q2, q3)

        if out_every > 0 and (k0 + i + 1) % out_every == 0:
            out[n_out, 0] = lat
            out[n_out, 1] = lon
            out[n_out, 2] = alt
            out[n_out, 3] = vE
            out[n_out, 4] = vN
            out[n_out, 5] = vU
            out[n_out, 6] = q0
            out[n_out, 7] = q1
            out[n_out, 8] = q2
            out[n_out, 9] = q3
            n_out += 1

    state[0] = lat
    state[1] = lon
    state[2] = alt
    state[3] = vE
    state[4] = vN
    state[5] = vU
    state[6] = q0
    state[7] = q1
    state[8] = q2
    state[9] = q3
    state[10] = pt0
    state[11] = pt1
    state[12] = pt2
    state[13] = pv0
    state[14] = pv1
    state[15] = pv2
    state[16] = 1.0 if have_prev else 0.0
    state[17] = acc_err
    state[18] = dvp0
    state[19] = dvp1
    state[20] = dvp2
    return n_out


# --------------------------------------------------------------------------- schedules
@_jit
def schedule_locate(
    t: float, starts: np.ndarray, period: float, t_start: float
) -> tuple[int, float, float]:
    """Segment index, local time and cycle number of time ``t`` [s].

    ``period <= 0`` means a single, non-repeating set of segments (the last one extends
    forever). Before ``t_start`` the table sits at the start of segment 0.
    """
    if t < t_start:
        return 0, 0.0, 0.0
    tc = t - t_start
    cyc = 0.0
    if period > 0.0:
        cyc = math.floor(tc / period)
        tc = tc - cyc * period
        if tc >= period:  # rounding
            tc -= period
            cyc += 1.0
        if tc < 0.0:
            tc = 0.0
    m = starts.shape[0]
    k = 0
    while k + 1 < m and starts[k + 1] <= tc:
        k += 1
    return k, tc - starts[k], cyc


@_jit
def schedule_angle(
    t: float,
    starts: np.ndarray,
    coefs: np.ndarray,
    period: float,
    offset: float,
    t_start: float,
) -> tuple[float, float, float]:
    """Encoder angle [rad], rate [rad/s] and acceleration [rad/s²] at ``t`` [s]."""
    k, tau, cyc = schedule_locate(t, starts, period, t_start)
    c0 = coefs[k, 0]
    c1 = coefs[k, 1]
    c2 = coefs[k, 2]
    if t < t_start:
        return c0, 0.0, 0.0
    return cyc * offset + c0 + tau * (c1 + tau * c2), c1 + 2.0 * c2 * tau, 2.0 * c2


@_jit
def schedule_eval_many(
    t: np.ndarray,
    starts: np.ndarray,
    coefs: np.ndarray,
    period: float,
    offset: float,
    t_start: float,
    phi: np.ndarray,
    rate: np.ndarray,
    acc: np.ndarray,
) -> None:
    """:func:`schedule_angle` at every element of ``t`` (outputs filled in place)."""
    for i in range(t.shape[0]):
        phi[i], rate[i], acc[i] = schedule_angle(t[i], starts, coefs, period, offset, t_start)


@_jit
def schedule_next_break(t: float, starts: np.ndarray, period: float, t_start: float) -> float:
    """First break point of the schedule strictly after ``t`` (+1 ns) [s]."""
    eps = 1e-9
    if t < t_start - eps:
        return t_start
    tc = t - t_start
    cyc = 0.0
    if period > 0.0:
        cyc = math.floor(tc / period)
        tc = tc - cyc * period
    m = starts.shape[0]
    for k in range(m):
        if starts[k] > tc + eps:
            return t_start + cyc * period + starts[k]
    if period > 0.0:
        return t_start + (cyc + 1.0) * period
    return 1e300


@_jit
def _lagrange4(xi: float, xs: np.ndarray) -> tuple[float, float, float, float]:
    """Lagrange basis through the four points ``xs`` evaluated at ``xi``."""
    l0 = (
        (xi - xs[1])
        * (xi - xs[2])
        * (xi - xs[3])
        / ((xs[0] - xs[1]) * (xs[0] - xs[2]) * (xs[0] - xs[3]))
    )
    l1 = (
        (xi - xs[0])
        * (xi - xs[2])
        * (xi - xs[3])
        / ((xs[1] - xs[0]) * (xs[1] - xs[2]) * (xs[1] - xs[3]))
    )
    l2 = (
        (xi - xs[0])
        * (xi - xs[1])
        * (xi - xs[3])
        / ((xs[2] - xs[0]) * (xs[2] - xs[1]) * (xs[2] - xs[3]))
    )
    l3 = (
        (xi - xs[0])
        * (xi - xs[1])
        * (xi - xs[2])
        / ((xs[3] - xs[0]) * (xs[3] - xs[1]) * (xs[3] - xs[2]))
    )
    return l0, l1, l2, l3


@_jit
def _lagrange_sum(
    l0: float, l1: float, l2: float, l3: float, a: np.ndarray, i: int, c: int
) -> float:
    """``Σ_m l_m a[i, m, c]``: component ``c`` of row ``i`` of ``a`` (n, 4, 3) interpolated.

    The weights ``l0 .. l3`` come from :func:`_lagrange4`.
    """
    return l0 * a[i, 0, c] + l1 * a[i, 1, c] + l2 * a[i, 2, c] + l3 * a[i, 3, c]


@_jit
def rotate_increments(
    t_edges: np.ndarray,
    w_b: np.ndarray,
    f_b: np.ndarray,
    starts: np.ndarray,
    coefs: np.ndarray,
    period: float,
    offset: float,
    t_start: float,
    const: bool,
    dtheta: np.ndarray,
    dv: np.ndarray,
    phi_end: np.ndarray,
) -> None:
    """r-frame increments of a body-frame motion seen through the turntable.

    ``ω_ir^r = C_rb(φ) ω_ib^b + φ̇ z`` and ``f^r = C_rb(φ) f^b`` (IMU centre on the axis),
    integrated exactly over each interval by 4-point Gauss-Legendre quadrature, the interval
    split at every break point of the schedule; dwell pieces are integrated in closed form.

    Parameters
    ----------
    t_edges : ndarray, shape (n+1,) [s]
        Interval edges.
    w_b, f_b : ndarray, shape (n, 4, 3) or (1, 4, 3)
        Body angular rate ω_ib^b [rad/s] and specific force f^b [m/s²] at the four
        Gauss-Legendre nodes of each interval.
    starts, coefs, period, offset, t_start
        The schedule (see :class:`rinscal.nav.rotation.RotationSchedule`).
    const : bool
        The body signals are constant: only ``w_b[0, 0]`` and ``f_b[0, 0]`` are used.
    dtheta, dv : ndarray, shape (n, 3)
        Output increments [rad], [m/s].
    phi_end : ndarray, shape (n,)
        Output encoder angle at the end of each interval [rad].
    """
    n = t_edges.shape[0] - 1
    xs = np.empty(4)
    phi_c = math.nan
    cp_c = 1.0
    sp_c = 0.0
    for i in range(n):
        ta = t_edges[i]
        tb = t_edges[i + 1]
        ii = 0 if const else i
        h = 0.5 * (tb - ta)
        mid = 0.5 * (ta + tb)
        for m in range(4):
            xs[m] = mid + h * GL_X[m]
        s0 = 0.0
        s1 = 0.0
        s2 = 0.0
        v0 = 0.0
        v1 = 0.0
        v2 = 0.0
        a = ta
        while a < tb:
            b = schedule_next_break(a, starts, period, t_start)
            if b > tb or b <= a:
                b = tb
            k, _tau_mid, _cyc = schedule_locate(0.5 * (a + b), starts, period, t_start)
            c1 = coefs[k, 1]
            c2 = coefs[k, 2]
            if 0.5 * (a + b) < t_start:
                c1 = 0.0
                c2 = 0.0
            if c1 == 0.0 and c2 == 0.0 and const:
                phi, _, _ = schedule_angle(0.5 * (a + b), starts, coefs, period, offset, t_start)
                cp = math.cos(phi)
                sp = math.sin(phi)
                L = b - a
                wx = w_b[0, 0, 0]
                wy = w_b[0, 0, 1]
                fx = f_b[0, 0, 0]
                fy = f_b[0, 0, 1]
                s0 += (cp * wx + sp * wy) * L
                s1 += (-sp * wx + cp * wy) * L
                s2 += w_b[0, 0, 2] * L
                v0 += (cp * fx + sp * fy) * L
                v1 += (-sp * fx + cp * fy) * L
                v2 += f_b[0, 0, 2] * L
            else:
                hp = 0.5 * (b - a)
                mp = 0.5 * (a + b)
                whole = a == ta and b == tb
                for m in range(4):
                    tn = mp + hp * GL_X[m]
                    wgt = GL_W[m] * hp
                    phi, _rate, _ = schedule_angle(tn, starts, coefs, period, offset, t_start)
                    if phi != phi_c:  # the table at rest: one cos and sin for the piece
                        cp_c = math.cos(phi)
                        sp_c = math.sin(phi)
                        phi_c = phi
                    cp = cp_c
                    sp = sp_c
                    if const:
                        wx = w_b[0, 0, 0]
                        wy = w_b[0, 0, 1]
                        wz = w_b[0, 0, 2]
                        fx = f_b[0, 0, 0]
                        fy = f_b[0, 0, 1]
                        fz = f_b[0, 0, 2]
                    elif whole:
                        wx = w_b[ii, m, 0]
                        wy = w_b[ii, m, 1]
                        wz = w_b[ii, m, 2]
                        fx = f_b[ii, m, 0]
                        fy = f_b[ii, m, 1]
                        fz = f_b[ii, m, 2]
                    else:
                        l0, l1, l2, l3 = _lagrange4(tn, xs)
                        wx = _lagrange_sum(l0, l1, l2, l3, w_b, ii, 0)
                        wy = _lagrange_sum(l0, l1, l2, l3, w_b, ii, 1)
                        wz = _lagrange_sum(l0, l1, l2, l3, w_b, ii, 2)
                        fx = _lagrange_sum(l0, l1, l2, l3, f_b, ii, 0)
                        fy = _lagrange_sum(l0, l1, l2, l3, f_b, ii, 1)
                        fz = _lagrange_sum(l0, l1, l2, l3, f_b, ii, 2)
                    s0 += wgt * (cp * wx + sp * wy)
                    s1 += wgt * (-sp * wx + cp * wy)
                    s2 += wgt * wz
                    v0 += wgt * (cp * fx + sp * fy)
                    v1 += wgt * (-sp * fx + cp * fy)
                    v2 += wgt * fz
            a = b
        phi_a, _, _ = schedule_angle(ta, starts, coefs, period, offset, t_start)
        phi_b, _, _ = schedule_angle(tb, starts, coefs, period, offset, t_start)
        dtheta[i, 0] = s0
        dtheta[i, 1] = s1
        dtheta[i, 2] = s2 + (phi_b - phi_a)
        dv[i, 0] = v0
        dv[i, 1] = v1
        dv[i, 2] = v2
        phi_end[i] = phi_b


# --------------------------------------------------------------------------- ideal-IMU synthesis
_TWO_PI = 2.0 * math.pi
#: Position of the Gauss-Legendre nodes within their interval, as a fraction (0, 1).
GL_FRAC = 0.5 * (1.0 + GL_X)


@_jit
def _step_value(t: float, x0: float, table: np.ndarray, k: int) -> tuple[float, float, float, int]:
    """Value, first and second derivative of a smooth-step channel at ``t`` [s].

    ``table`` (m, 4) holds per step its start [s], duration [s], change Δ and the sum of the
    changes before it (see :class:`rinscal.sim.trajectory.StepChannel`); ``x0`` is the value
    before the first step. ``k`` is a guess of the step index (the last step starting at or
    before ``t``, −1 if none), returned updated: sorted times cost no search.
    """
    m = table.shape[0]
    if not (-1 <= k < m and (k < 0 or table[k, 0] <= t) and (k + 1 >= m or t < table[k + 1, 0])):
        lo = 0
        hi = m
        while lo < hi:
            mid = (lo + hi) // 2
            if table[mid, 0] <= t:
                lo = mid + 1
            else:
                hi = mid
        k = lo - 1
    if k < 0:
        return x0, 0.0, 0.0, k
    d = table[k, 1]
    dl = table[k, 2]
    x = x0 + table[k, 3]
    u = (t - table[k, 0]) / d
    if u < 1.0:
        a = _TWO_PI * u
        sa = math.sin(a)
        return (
            x + dl * (u - sa / _TWO_PI),
            dl / d * (1.0 - math.cos(a)),
            dl / d**2 * _TWO_PI * sa,
            k,
        )
    return x + dl, 0.0, 0.0, k


@_jit
def step_channel_eval(
    t: np.ndarray, x0: float, table: np.ndarray, x: np.ndarray, xd: np.ndarray, xdd: np.ndarray
) -> None:
    """:func:`_step_value` at every element of the 1-D ``t`` [s] (outputs filled in place)."""
    k = -1
    for i in range(t.shape[0]):
        x[i], xd[i], xdd[i], k = _step_value(t[i], x0, table, k)


@_jit
def vehicle_kinematics(
    t: np.ndarray,
    speed0: float,
    speed: np.ndarray,
    heading0: float,
    heading: np.ndarray,
    grade0: float,
    grade: np.ndarray,
    v_n: np.ndarray,
    a_n: np.ndarray,
    euler: np.ndarray,
    euler_rate: np.ndarray,
) -> None:
    """Kinematics of :class:`rinscal.sim.trajectory.VehicleMotion` at the 1-D times ``t`` [s].

    Speed [m/s], heading [rad] and grade [rad] are smooth-step channels (value before the
    first step and table, see :func:`_step_value`); the body y axis points along the
    velocity, pitch is the grade, roll is zero. Fills ``v_n`` [m/s], ``a_n`` [m/s²],
    ``euler`` [rad] and ``euler_rate`` [rad/s], each (len(t), 3), in place.
    """
    ks = -1
    kh = -1
    kg = -1
    h_c = math.nan
    p_c = math.nan
    ch = 1.0
    sh = 0.0
    cp = 1.0
    sp = 0.0
    for i in range(t.shape[0]):
        ti = t[i]
        s, sd, _, ks = _step_value(ti, speed0, speed, ks)
        h, hd, _, kh = _step_value(ti, heading0, heading, kh)
        p, pd, _, kg = _step_value(ti, grade0, grade, kg)
        if h != h_c:
            ch = math.cos(h)
            sh = math.sin(h)
            h_c = h
        if p != p_c:
            cp = math.cos(p)
            sp = math.sin(p)
            p_c = p
        v_n[i, 0] = s * cp * sh
        v_n[i, 1] = s * cp * ch
        v_n[i, 2] = s * sp
        a_n[i, 0] = sd * cp * sh + s * (-sp * pd * sh + cp * ch * hd)
        a_n[i, 1] = sd * cp * ch + s * (-sp * pd * ch - cp * sh * hd)
        a_n[i, 2] = sd * sp + s * cp * pd
        euler[i, 0] = h
        euler[i, 1] = p
        euler[i, 2] = 0.0
        euler_rate[i, 0] = hd
        euler_rate[i, 1] = pd
        euler_rate[i, 2] = 0.0


@_jit
def _sin_cos_near(a: float, sa: float, ca: float, d: float) -> tuple[float, float]:
    """sin and cos of ``a + d`` [rad] from ``sa = sin a``, ``ca = cos a`` (angle addition).

    For ``|d| <= 1e-3`` rad the series of sin d and cos d are cut after their d⁵ and d⁴
    terms (error below 1e-20); larger ``d`` calls sin and cos.
    """
    if abs(d) > 1e-3:
        return math.sin(a + d), math.cos(a + d)
    d2 = d * d
    sd = d * (1.0 - d2 / 6.0 * (1.0 - d2 / 20.0))
    cd = 1.0 - d2 / 2.0 * (1.0 - d2 / 12.0)
    return sa * cd + ca * sd, ca * cd - sa * sd


@_jit
def moving_body_signals(
    t_edges: np.ndarray,
    v_n: np.ndarray,
    a_n: np.ndarray,
    euler: np.ndarray,
    euler_rate: np.ndarray,
    lat0: float,
    lon0: float,
    alt0: float,
    w_b: np.ndarray,
    f_b: np.ndarray,
    lat_e: np.ndarray,
    lon_e: np.ndarray,
    alt_e: np.ndarray,
) -> None:
    """Position by quadrature of the velocity, then the ideal body signals at every node.

    Position (the chunk's latitude by a two-pass fixed point on the meridian radius: the
    first pass takes ``R_N`` at the chunk's start latitude, the second at the first pass's
    node latitudes; the node positions are linear between the edges)::

        h' = ∫ v_U,   L' = ∫ v_N / (R_N(L) + h),   λ' = ∫ v_E / ((R_E(L) + h) cos L)

    and then, at each node, the inverse mechanisation (ENU, Groves Ch. 5)::

        ω_ib^b = ω_nb^b(Euler, Euler rates) + C_bn (ω_ie^n + ω_en^n)
        f^b    = C_bn (v̇ + (2 ω_ie^n + ω_en^n) × v − g^n)

    Parameters
    ----------
    t_edges : ndarray, shape (n+1,) [s]
        Interval edges.
    v_n, a_n, euler, euler_rate : ndarray, shape (n, 4, 3)
        ENU velocity [m/s], its derivative [m/s²], heading, pitch, roll [rad] and their rates
        [rad/s] at the four Gauss-Legendre nodes of each interval.
    lat0, lon0, alt0 : float [rad, rad, m]
        Position at ``t_edges[0]``.
    w_b, f_b : ndarray, shape (n, 4, 3)
        Output ω_ib^b [rad/s] and f^b [m/s²] at the nodes.
    lat_e, lon_e, alt_e : ndarray, shape (n+1,)
        Output position at the edges [rad, rad, m].
    """
    n = t_edges.shape[0] - 1
    s2 = math.sin(lat0) ** 2
    x = 1.0 - _E2 * s2
    rn0 = _A * (1.0 - _E2) / (x * math.sqrt(x))
    lat_e[0] = lat0
    lon_e[0] = lon0
    alt_e[0] = alt0
    s_alt = 0.0
    s_lat1 = 0.0
    s_lat = 0.0
    s_lon = 0.0
    e0_c = math.nan
    e1_c = math.nan
    e2_c = math.nan
    ch = 1.0
    sh = 0.0
    cp = 1.0
    sp = 0.0
    cr = 1.0
    sr = 0.0
    for i in range(n):
        h = 0.5 * (t_edges[i + 1] - t_edges[i])
        # altitude
        d_alt = 0.0
        for m in range(4):
            d_alt += GL_W[m] * h * v_n[i, m, 2]
        alt_a = alt0 + s_alt
        # latitude, first pass: R_N at the chunk's start latitude
        d_lat1 = 0.0
        for m in range(4):
            d_lat1 += GL_W[m] * h * v_n[i, m, 1] / (rn0 + (alt_a + GL_FRAC[m] * d_alt))
        lat_a1 = lat0 + s_lat1
        s_lat1 += d_lat1
        # second pass: R_N at the first pass's node latitudes (sines and cosines of the
        # node latitudes by angle addition from those of the interval's start)
        lat_a = lat0 + s_lat
        sA = math.sin(lat_a)
        cA = math.cos(lat_a)
        d_lat = 0.0
        for m in range(4):
            sL, _ = _sin_cos_near(lat_a, sA, cA, (lat_a1 - lat_a) + GL_FRAC[m] * d_lat1)
            s2 = sL * sL
            x = 1.0 - _E2 * s2
            rn = _A * (1.0 - _E2) / (x * math.sqrt(x))
            d_lat += GL_W[m] * h * v_n[i, m, 1] / (rn + (alt_a + GL_FRAC[m] * d_alt))
        # longitude and the body signals at the final node positions
        d_lon = 0.0
        for m in range(4):
            alt = alt_a + GL_FRAC[m] * d_alt
            sL, cL = _sin_cos_near(lat_a, sA, cA, GL_FRAC[m] * d_lat)
            s2 = sL * sL
            x = 1.0 - _E2 * s2
            sx = math.sqrt(x)
            ReH = _A / sx + alt
            RnH = _A * (1.0 - _E2) / (x * sx) + alt
            vE = v_n[i, m, 0]
            vN = v_n[i, m, 1]
            vU = v_n[i, m, 2]
            d_lon += GL_W[m] * h * vE / (ReH * cL)
            g = _GE * (1.0 + _K * s2) / sx
            g = g * (1.0 - 2.0 / _A * (1.0 + _F + _M - 2.0 * _F * s2) * alt + 3.0 * alt**2 / _A**2)
            # Earth rate and transport rate (ENU)
            OmN = _RATE * cL
            OmU = _RATE * sL
            tE = -vN / RnH
            tN = vE / ReH
            tU = vE * (sL / cL) / ReH
            # attitude C_nb = Rz(−ψ) Rx(θ) Ry(γ) (trig only when an angle changes)
            e0 = euler[i, m, 0]
            e1 = euler[i, m, 1]
            e2 = euler[i, m, 2]
            if e0 != e0_c:
                ch = math.cos(e0)
                sh = math.sin(e0)
                e0_c = e0
            if e1 != e1_c:
                cp = math.cos(e1)
                sp = math.sin(e1)
                e1_c = e1
            if e2 != e2_c:
                cr = math.cos(e2)
                sr = math.sin(e2)
                e2_c = e2
            c00 = ch * cr + sh * sp * sr
            c01 = sh * cp
            c02 = ch * sr - sh * sp * cr
            c10 = -sh * cr + ch * sp * sr
            c11 = ch * cp
            c12 = -sh * sr - ch * sp * cr
            c20 = -cp * sr
            c21 = sp
            c22 = cp * cr
            # ω_ib^b = ω_nb^b + C_bn ω_in^n
            hd = euler_rate[i, m, 0]
            pd = euler_rate[i, m, 1]
            rd = euler_rate[i, m, 2]
            wE = tE
            wN = OmN + tN
            wU = OmU + tU
            w_b[i, m, 0] = (pd * cr + hd * sr * cp) + (c00 * wE + c10 * wN + c20 * wU)
            w_b[i, m, 1] = (rd - hd * sp) + (c01 * wE + c11 * wN + c21 * wU)
            w_b[i, m, 2] = (pd * sr - hd * cr * cp) + (c02 * wE + c12 * wN + c22 * wU)
            # f^n = v̇ + (2 ω_ie + ω_en) × v − g^n, then f^b = C_bn f^n
            kE = tE
            kN = 2.0 * OmN + tN
            kU = 2.0 * OmU + tU
            fE = a_n[i, m, 0] + (kN * vU - kU * vN)
            fN = a_n[i, m, 1] + (kU * vE - kE * vU)
            fU = a_n[i, m, 2] + (kE * vN - kN * vE) + g
            f_b[i, m, 0] = c00 * fE + c10 * fN + c20 * fU
            f_b[i, m, 1] = c01 * fE + c11 * fN + c21 * fU
            f_b[i, m, 2] = c02 * fE + c12 * fN + c22 * fU
        s_lat += d_lat
        s_lon += d_lon
        s_alt += d_alt
        lat_e[i + 1] = lat0 + s_lat
        lon_e[i + 1] = lon0 + s_lon
        alt_e[i + 1] = alt0 + s_alt


# --------------------------------------------------------------------------- coarse alignment
@_jit
def inertial_accumulate(
    q: np.ndarray, vsum: np.ndarray, prev: np.ndarray, dtheta: np.ndarray, dv: np.ndarray
) -> None:
    """Accumulate attitude of r relative to its initial (inertially frozen) orientation.

    ``q`` (4,) is C_{r0 r} updated in place by coning-corrected increments; ``vsum`` (3,)
    accumulates ∫ C_{r0 r} f^r dt with rotation compensation and sculling; ``prev`` (7,)
    holds the previous increments and a flag.
    """
    q0 = q[0]
    q1 = q[1]
    q2 = q[2]
    q3 = q[3]
    pt0 = prev[0]
    pt1 = prev[1]
    pt2 = prev[2]
    pv0 = prev[3]
    pv1 = prev[4]
    pv2 = prev[5]
    have = prev[6] != 0.0
    for i in range(dtheta.shape[0]):
        t0 = dtheta[i, 0]
        t1 = dtheta[i, 1]
        t2 = dtheta[i, 2]
        w0 = dv[i, 0]
        w1 = dv[i, 1]
        w2 = dv[i, 2]
        if not have:
            pt0, pt1, pt2, pv0, pv1, pv2 = t0, t1, t2, w0, w1, w2
            have = True
        r0, r1, r2, u0, u1, u2 = _coning_sculling(
            t0, t1, t2, w0, w1, w2, pt0, pt1, pt2, pv0, pv1, pv2
        )
        u0, u1, u2 = _third_order(t0, t1, t2, w0, w1, w2, u0, u1, u2)
        pt0, pt1, pt2, pv0, pv1, pv2 = t0, t1, t2, w0, w1, w2
        a0, a1, a2 = quat_rotate(q0, q1, q2, q3, u0, u1, u2)
        vsum[0] += a0
        vsum[1] += a1
        vsum[2] += a2
        b0, b1, b2, b3 = quat_from_rotvec(r0, r1, r2)
        q0, q1, q2, q3 = quat_mul(q0, q1, q2, q3, b0, b1, b2, b3)
        q0, q1, q2, q3 = _quat_normalize(q0, q1, q2, q3)
    q[0] = q0
    q[1] = q1
    q[2] = q2
    q[3] = q3
    prev[0] = pt0
    prev[1] = pt1
    prev[2] = pt2
    prev[3] = pv0
    prev[4] = pv1
    prev[5] = pv2
    prev[6] = 1.0 if have else 0.0
