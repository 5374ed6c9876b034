"""Self-alignment at a cold start: inertial-frame coarse alignment, then a Kalman filter.

Coarse (analytic)
    The inertial-frame method (Gaiffe; Qin): with the IMU centre at rest on the Earth, the
    specific force integrated in the inertially frozen initial IMU frame ``r0``,
    ``V_r0(t) = ∫ C_r0r f^r dτ`` (C_r0r from the gyros alone), equals
    ``C_r0n0 V_n0(t)`` with ``V_n0(t) = ∫ C_n0n(τ) (0, 0, g) dτ`` known in closed form from
    the Earth rate. Solving Wahba's problem over many times gives ``C_n0r0`` and hence
    ``C_nr(t) = C_nn0(t) C_n0r0 C_r0r(t)``. Because the gyros follow every motion of the
    IMU, this works on a swinging base and while the turntable turns.
Fine (Kalman filter on zero velocity)
    Error states (ENU, ``C̃_nr = (I − [φ×]) C_nr``): attitude error φ (3), horizontal
    velocity error (2), gyro biases ε (3) and accelerometer biases ∇ (3) in ``r``::

        φ̇  = −ω_ie^n × φ + δω_en^n(δv) − C_nr ε
        δv̇ = (f^n × φ)_EN + (C_nr ∇)_EN − (2 ω_ie^n × δv)_EN
        ε̇  = −ε/τ_g + w_g,   ∇̇ = −∇/τ_a + w_a,   E[w w'] = (2σ²/τ) δ(t − t')

    with ``f^n = (0, 0, g)``: the bias errors are first-order Gauss-Markov processes, so a
    bias that drifts during the alignment is followed instead of being aliased into the
    attitude (see :class:`AlignConfig`; ``σ = 0`` gives random constants). The
    measurement is the INS horizontal velocity (the truth is zero, the IMU centre being
    fixed even when the base swings). Estimates are fed back after every update (closed
    loop); position is held at the known site. With the turntable rotating, the horizontal
    biases become observable and are estimated too.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from rinscal import _kernels, earth, units
from rinscal.errors import ConfigError
from rinscal.nav.strapdown import Strapdown, VerticalMode, quat_to_dcm, rotvec_to_dcm


@dataclass(frozen=True)
class AlignConfig:
    """Self-alignment settings.

    Parameters
    ----------
    coarse_s : float [s]
        Length of the inertial-frame coarse alignment.
    fine_s : float [s]
        Length of the Kalman-filter fine alignment that follows.
    kf_interval_s : float [s]
        Kalman filter update interval.
    estimate_biases : bool
        Estimate (and feed back) gyro and accelerometer biases in the fine alignment.
    gyro_bias_sd : float [rad/s]
        Prior standard deviation of each gyro bias.
    accel_bias_sd : float [m/s²]
        Prior standard deviation of each accelerometer bias.
    gyro_noise_density : float [rad/√s]
        Angle random walk used by the filter.
    accel_noise_density : float [m/s²/√Hz]
        Velocity random walk used by the filter.
    level_sd, heading_sd : float [rad]
        Prior standard deviation of the attitude error after the coarse stage.
    velocity_meas_sd : float [m/s]
        Standard deviation of the zero-velocity measurement.
    start_s : float [s]
        Time after power-on at which the alignment begins. The unit is on and warming
        before it, but nobody aligns yet: those samples are ignored. Free navigation
        starts at ``start_s + total_s``.
    gyro_bias_tau_s : float [s]
        Correlation time of the first-order Gauss-Markov model of each gyro bias state.
    gyro_bias_markov_sd : float [rad/s]
        Steady-state standard deviation of that Gauss-Markov process (its driving noise
        has the spectral density ``2 σ² / τ``); 0 makes the gyro biases random constants
        (no process noise, no decay: the filter before the Markov model).
    accel_bias_tau_s : float [s]
        Correlation time of the Gauss-Markov model of each accelerometer bias state.
    accel_bias_markov_sd : float [m/s²]
        Its steady-state standard deviation; 0 makes the accelerometer biases random
        constants.

    Notes
    -----
    Why Gauss-Markov bias states. A unit aligned at a cold start warms during the
    alignment, and a real unit may also step (a heater, a relay, a mode change). A filter
    whose bias states are random constants cannot follow such a change: with the table
    turning it pins the horizontal biases within minutes, so a later change is explained
    by the attitude states instead and the heading handed over is wrong. With random
    constants, a 20 µg accelerometer step 300 s into the 10 min alignment costs −58.5
    arcsec of heading and 0.42 nmi in 2 h (quasi-static, ideal IMU otherwise); the same
    step after the alignment costs 0.008 nmi. The states here are the *error* of the bias
    estimate (true bias minus the estimate being subtracted), modelled as first-order
    Gauss-Markov: ``F`` has ``−1/τ`` on their diagonal, ``Q`` the density ``2 σ² / τ``.
    The estimate itself is held between updates, not decayed: most of the bias (the
    turn-on offset) is constant.

    Why these defaults. For a 0.01 °/h FOG (0.001 °/√h ARW) and 10 µg/√Hz quartz
    accelerometers: ``σ`` is the size of the class, 0.003 °/h (its bias instability) and
    10 µg, and ``τ = 1 h`` the time scale of a warm-up (three quarters of it in the first
    two hours). They let a bias wander by 0.0015 °/h and 5 µg within a 9 min fine
    alignment (the built-in navigation-grade plant's thermal bias moves by about
    0.02 °/h and 5-7 µg between the first and the tenth minute after power-on; the paper's
    accelerometers by 250-340 µg). The price is precision: every change the filter allows
    for is one it must re-estimate, so a larger σ follows drifts and steps better and
    costs a little where the bias is steady. Measured at 10 Hz, 2 h (heading error at the
    navigation start, rms over seeds; mean maximum position error), random constants →
    these defaults:

    - the 20 µg step at 300 s, ideal IMU otherwise: −58.5″, 0.42 nmi → −9.5″, 0.06 nmi;
    - white noise and random constant biases only (12 seeds): 46″ → 49″;
    - quasi-static cold start, ``paper`` preset (10 seeds), uncompensated: 236″, 0.93 nmi
      → 192″, 0.72 nmi; true thermal bias subtracted: 64″, 0.41 nmi → 65″, 0.42 nmi;
    - the same, ``navigation_grade`` preset: uncompensated 55″, 0.63 nmi → 58″, 0.57 nmi;
      true thermal bias subtracted 52″, 0.32 nmi → 57″, 0.33 nmi;
    - vehicle, ``navigation_grade`` (6 seeds): uncompensated 59″, 0.78 nmi → 62″,
      0.75 nmi; true thermal bias subtracted 36″, 0.38 nmi → 46″, 0.41 nmi.

    Unmodelled transients are the weak point: with accelerometer lever arms of 4 cm left
    uncompensated (a plant version before the size-effect compensation was assumed) the
    filter followed the size effect of the turning table as bias changes, and every
    variant's heading got worse by a third.

    ``gyro_bias_markov_sd = accel_bias_markov_sd = 0`` gives back the random constants.
    """

    coarse_s: float = 60.0
    fine_s: float = 540.0
    kf_interval_s: float = 0.5
    estimate_biases: bool = True
    gyro_bias_sd: float = 0.02 * units.DPH_TO_RPS
    accel_bias_sd: float = 100.0 * units.UG_TO_MPS2
    gyro_noise_density: float = 0.001 * units.DPRH_TO_RPRS
    accel_noise_density: float = 10.0 * units.UG_TO_MPS2
    level_sd: float = 2e-4
    heading_sd: float = 1e-2
    velocity_meas_sd: float = 1e-3
    start_s: float = 0.0
    gyro_bias_tau_s: float = 3600.0
    gyro_bias_markov_sd: float = 0.003 * units.DPH_TO_RPS
    accel_bias_tau_s: float = 3600.0
    accel_bias_markov_sd: float = 10.0 * units.UG_TO_MPS2

    def __post_init__(self) -> None:
        for name in (
            "coarse_s",
            "kf_interval_s",
            "level_sd",
            "heading_sd",
            "velocity_meas_sd",
            "gyro_bias_tau_s",
            "accel_bias_tau_s",
        ):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ConfigError(f"alignment: {name} must be > 0, got {v}")
        for name in (
            "fine_s",
            "gyro_bias_sd",
            "accel_bias_sd",
            "gyro_noise_density",
            "accel_noise_density",
            "start_s",
            "gyro_bias_markov_sd",
            "accel_bias_markov_sd",
        ):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                raise ConfigError(f"alignment: {name} must be >= 0, got {v}")

    @property
    def total_s(self) -> float:
        """Coarse plus fine alignment time [s]."""
        return self.coarse_s + self.fine_s

    @property
    def end_s(self) -> float:
        """End of the alignment, i.e. start of free navigation, since power-on [s]."""
        return self.start_s + self.total_s


# --------------------------------------------------------------------------- coarse
def _earth_rotated_gravity_integral(
    lat: float, alt: float, t: NDArray[np.float64]
) -> NDArray[np.float64]:
    """V_n0(t) = ∫_0^t exp(τ[ω_ie^n×]) (0, 0, g) dτ, closed form, shape (len(t), 3)."""
    w = earth.rate_n(lat)
    om = float(np.linalg.norm(w))
    u = w / om
    f = np.array([0.0, 0.0, float(earth.gravity(lat, alt))])
    f_par = u * (u @ f)
    f_perp = f - f_par
    uxf = np.cross(u, f)
    t = np.asarray(t, dtype=float)[:, None]
    return f_par * t + np.sin(om * t) / om * f_perp + (1.0 - np.cos(om * t)) / om * uxf


def wahba(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """Rotation ``C`` minimising Σ |a_k − C b_k|² (SVD solution of Wahba's problem).

    Parameters
    ----------
    a, b : ndarray, shape (m, 3)
        Corresponding vectors in the two frames.

    Returns
    -------
    ndarray, shape (3, 3)
        ``C`` with ``a ≈ C b``.
    """
    B = a.T @ b
    U, _, Vt = np.linalg.svd(B)
    d = np.linalg.det(U) * np.linalg.det(Vt)
    return U @ np.diag([1.0, 1.0, d]) @ Vt


class InertialCoarseAlign:
    """Streaming inertial-frame coarse alignment at a known site.

    Parameters
    ----------
    lat : float [rad]
        Latitude of the site.
    alt : float [m]
        Height of the site.
    dt : float [s]
        Sample interval.
    """

    def __init__(self, lat: float, alt: float, dt: float) -> None:
        self.lat = float(lat)
        self.alt = float(alt)
        self.dt = float(dt)
        self.q = np.array([1.0, 0.0, 0.0, 0.0])
        self.vsum = np.zeros(3)
        self.prev = np.zeros(7)
        self.k = 0
        self._every = max(1, round(1.0 / dt))
        self._t: list[float] = []
        self._v: list[NDArray[np.float64]] = []

    def feed(self, dtheta: NDArray[np.float64], dv: NDArray[np.float64]) -> None:
        """Consume increments [rad], [m/s] (shape (n, 3))."""
        n = dtheta.shape[0]
        i = 0
        while i < n:
            j = min(n, i + self._every - (self.k % self._every))
            _kernels.inertial_accumulate(
                self.q,
                self.vsum,
                self.prev,
                np.ascontiguousarray(dtheta[i:j]),
                np.ascontiguousarray(dv[i:j]),
            )
            self.k += j - i
            if self.k % self._every == 0:
                self._t.append(self.k * self.dt)
                self._v.append(self.vsum.copy())
            i = j

    def solve(self) -> NDArray[np.float64]:
        """C_nr at the time of the last sample fed."""
        if len(self._t) < 2:
            raise ConfigError("coarse alignment: needs at least 2 s of data")
        t = np.asarray(self._t)
        v_r0 = np.asarray(self._v)
        v_n0 = _earth_rotated_gravity_integral(self.lat, self.alt, t)
        C_n0r0 = wahba(v_n0, v_r0)
        T = self.k * self.dt
        C_nn0 = rotvec_to_dcm(-earth.rate_n(self.lat) * T)
        return C_nn0 @ C_n0r0 @ quat_to_dcm(self.q)


# --------------------------------------------------------------------------- fine
@dataclass(frozen=True)
class AlignResult:
    """Outcome of the self-alignment.

    Attributes
    ----------
    C_nr : ndarray, shape (3, 3)
        Attitude of the IMU frame at the end of the alignment.
    gyro_bias : ndarray, shape (3,) [rad/s]
        Estimated gyro biases in ``r`` (zero if not estimated).
    accel_bias : ndarray, shape (3,) [m/s²]
        Estimated accelerometer biases in ``r``.
    attitude_sd : ndarray, shape (3,) [rad]
        Filter standard deviation of the attitude error (E, N, U) at the end.
    gyro_bias_sd : ndarray, shape (3,) [rad/s]
        Filter standard deviation of the gyro bias estimates.
    accel_bias_sd : ndarray, shape (3,) [m/s²]
        Filter standard deviation of the accelerometer bias estimates.
    C_nr_coarse : ndarray, shape (3, 3)
        Attitude at the end of the coarse stage.
    """

    C_nr: NDArray[np.float64]
    gyro_bias: NDArray[np.float64]
    accel_bias: NDArray[np.float64]
    attitude_sd: NDArray[np.float64]
    gyro_bias_sd: NDArray[np.float64]
    accel_bias_sd: NDArray[np.float64]
    C_nr_coarse: NDArray[np.float64]


class Aligner:
    """Coarse then fine self-alignment at a known site, fed chunk by chunk.

    Feed increments with :meth:`feed` until :attr:`done`; then :attr:`nav` is a strapdown
    integrator ready for free navigation (velocity zero, position at the site) and
    :attr:`gyro_bias`, :attr:`accel_bias` are the bias estimates to keep subtracting.

    Parameters
    ----------
    lat, lon : float [rad]
        Known site.
    alt : float [m]
        Known height.
    dt : float [s]
        Sample interval.
    config : AlignConfig
        Settings.
    vertical : {"hold", "damped", "free"}
        Vertical channel of the navigation that follows.
    k0 : int
        Index (since power-on) of the first sample fed, so that the navigation that
        follows counts samples from power-on (``round(config.start_s / dt)`` in a
        scenario). The aligner itself ignores nothing: feed it from ``k0`` on.
    """

    def __init__(
        self,
        lat: float,
        lon: float,
        alt: float,
        dt: float,
        config: AlignConfig,
        vertical: VerticalMode = "hold",
        k0: int = 0,
    ) -> None:
        self.lat, self.lon, self.alt = float(lat), float(lon), float(alt)
        self.dt = float(dt)
        self.config = config
        self.vertical = vertical
        if k0 < 0:
            raise ConfigError(f"alignment: k0 must be >= 0, got {k0}")
        self.k0 = int(k0)
        self.n_coarse = round(config.coarse_s / dt)
        self.n_fine = round(config.fine_s / dt)
        self.n_block = max(1, round(config.kf_interval_s / dt))
        self.k = 0
        self.coarse = InertialCoarseAlign(lat, alt, dt)
        self.nav: Strapdown | None = None
        self.gyro_bias = np.zeros(3)
        self.accel_bias = np.zeros(3)
        self.C_nr_coarse: NDArray[np.float64] | None = None
        self._result: AlignResult | None = None
        self._F0: NDArray[np.float64] | None = None  # the filter's constant dynamics
        self._Qc: NDArray[np.float64] | None = None
        self._init_filter()

    @property
    def n_total(self) -> int:
        """Samples the alignment consumes."""
        return self.n_coarse + self.n_fine

    @property
    def done(self) -> bool:
        return self.k >= self.n_total

    def _init_filter(self) -> None:
        c = self.config
        self.nx = 11
        p = np.array(
            [c.level_sd, c.level_sd, c.heading_sd, 0.01, 0.01]
            + [c.gyro_bias_sd] * 3
            + [c.accel_bias_sd] * 3
        )
        if not c.estimate_biases:
            p[5:] = 0.0
        self.P = np.diag(p**2)
        self.x = np.zeros(self.nx)

    def feed(self, dtheta: NDArray[np.float64], dv: NDArray[np.float64]) -> int:
        """Consume up to the rest of the alignment from these increments.

        Returns
        -------
        int
            Number of samples consumed (the rest belong to navigation).
        """
        n = dtheta.shape[0]
        used = 0
        while used < n and not self.done:
            if self.k < self.n_coarse:
                m = min(n - used, self.n_coarse - self.k)
                self.coarse.feed(dtheta[used : used + m], dv[used : used + m])
                self.k += m
                used += m
                if self.k == self.n_coarse:
                    self._start_fine()
            else:
                if self.nav is None:
                    self._start_fine()
                into = (self.k - self.n_coarse) % self.n_block
                m = min(n - used, self.n_block - into, self.n_total - self.k)
                self._propagate(dtheta[used : used + m], dv[used : used + m])
                self.k += m
                used += m
                if (self.k - self.n_coarse) % self.n_block == 0 or self.done:
                    self._update()
        if self.done and self.nav is not None and self._result is None:
            self.nav.reset(lat=self.lat, lon=self.lon, alt=self.alt, v_n=np.zeros(3))
            self._result = self._snapshot()
        return used

    def _start_fine(self) -> None:
        C_nr = self.coarse.solve()
        self.C_nr_coarse = C_nr
        self.nav = Strapdown(
            self.lat, self.lon, self.alt, np.zeros(3), C_nr, self.dt, self.vertical
        )
        self.nav.k = self.k0 + self.k
        self.nav.set_reference(self.alt, 0.0)
        self._C_start = C_nr
        self._block_t = 0.0

    def _propagate(self, dtheta: NDArray[np.float64], dv: NDArray[np.float64]) -> None:
        assert self.nav is not None
        dt = self.dt
        self.nav.run(dtheta - self.gyro_bias * dt, dv - self.accel_bias * dt)
        self._block_t += dtheta.shape[0] * dt

    def _update(self) -> None:
        """Propagate the covariance over the block, update with zero velocity, feed back."""
        assert self.nav is not None
        c = self.config
        T = self._block_t
        if T <= 0:
            return
        C_end = self.nav.C_nr
        C = 0.5 * (self._C_start + C_end)
        if self._F0 is None:
            self._F0, self._Qc = self._dynamics()
        F = self._F0.copy()
        if c.estimate_biases:  # the attitude's and velocity's errors from the biases, in n
            F[0:3, 5:8] = -C
            F[3:5, 8:11] = C[0:2, :]
        v = self.nav.v_n
        self.P, x = _kernels.kf_zero_velocity_update(
            self.P, F, self._Qc, T, float(v[0]), float(v[1]), c.velocity_meas_sd**2
        )
        # feedback
        self.nav.correct(phi_n=x[0:3], dv_n=np.array([x[3], x[4], 0.0]))
        if c.estimate_biases:
            self.gyro_bias += x[5:8]
            self.accel_bias += x[8:11]
        self.nav.reset(lat=self.lat, lon=self.lon, alt=self.alt)
        self._C_start = self.nav.C_nr
        self._block_t = 0.0

    def _dynamics(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The filter's continuous dynamics ``F`` (11, 11) but the attitude-dependent blocks
        (zero), and its white-noise densities ``Qc`` (11,): the same at every block of a
        static site."""
        c = self.config
        lat, alt = self.lat, self.alt
        rn, re = earth.principal_radii(lat)
        rn, re = float(rn) + alt, float(re) + alt
        g = float(earth.gravity(lat, alt))
        OmN = earth.RATE * math.cos(lat)
        OmU = earth.RATE * math.sin(lat)
        F = np.zeros((11, 11))
        # attitude
        F[0, 1] = OmU
        F[0, 2] = -OmN
        F[1, 0] = -OmU
        F[2, 0] = OmN
        F[0, 4] = -1.0 / rn
        F[1, 3] = 1.0 / re
        F[2, 3] = math.tan(lat) / re
        # velocity
        F[3, 1] = -g
        F[4, 0] = g
        F[3, 4] = 2 * OmU
        F[4, 3] = -2 * OmU
        Qc = np.zeros(11)
        Qc[0:3] = c.gyro_noise_density**2
        Qc[3:5] = c.accel_noise_density**2
        if c.estimate_biases:
            # first-order Gauss-Markov bias errors: ḃ = −b/τ + w, E[w w] = 2σ²/τ
            if c.gyro_bias_markov_sd > 0:
                F[5:8, 5:8] = -np.eye(3) / c.gyro_bias_tau_s
                Qc[5:8] = 2.0 * c.gyro_bias_markov_sd**2 / c.gyro_bias_tau_s
            if c.accel_bias_markov_sd > 0:
                F[8:11, 8:11] = -np.eye(3) / c.accel_bias_tau_s
                Qc[8:11] = 2.0 * c.accel_bias_markov_sd**2 / c.accel_bias_tau_s
        return F, Qc

    def result(self) -> AlignResult:
        """The alignment outcome (once :attr:`done`)."""
        if self._result is None:
            raise ConfigError("alignment: not finished yet")
        return self._result

    def _snapshot(self) -> AlignResult:
        assert self.nav is not None and self.C_nr_coarse is not None
        return AlignResult(
            C_nr=self.nav.C_nr,
            gyro_bias=self.gyro_bias.copy(),
            accel_bias=self.accel_bias.copy(),
            attitude_sd=np.sqrt(np.diag(self.P)[0:3]),
            gyro_bias_sd=np.sqrt(np.diag(self.P)[5:8]),
            accel_bias_sd=np.sqrt(np.diag(self.P)[8:11]),
            C_nr_coarse=self.C_nr_coarse,
        )


def feed_and_hand_over(variant: Any, dtheta: NDArray[np.float64], dv: NDArray[np.float64]) -> int:
    """Feed a navigation variant's aligner; once it is done, hand its strapdown and bias
    estimates over to the variant.

    Parameters
    ----------
    variant : object
        With attributes ``aligner`` (an :class:`Aligner`), ``nav``, ``gyro_bias`` and
        ``accel_bias`` (set here when the alignment ends).
    dtheta, dv : ndarray, shape (n, 3) [rad, m/s]
        Compensated increments from where the aligner stands.

    Returns
    -------
    int
        Samples the alignment consumed (the rest are navigation's).
    """
    used = variant.aligner.feed(dtheta, dv)
    if variant.aligner.done:
        variant.nav = variant.aligner.nav
        variant.gyro_bias = variant.aligner.gyro_bias.copy()
        variant.accel_bias = variant.aligner.accel_bias.copy()
    return int(used)


def align_from_noise(
    gyro_density: float,
    accel_density: float,
    gyro_bias_rw: float,
    accel_bias_rw: float,
    total_s: float = 600.0,
    coarse_s: float = 60.0,
    start_s: float = 0.0,
    *,
    gyro_bias_tau_s: float | None = None,
    gyro_bias_markov_sd: float | None = None,
    accel_bias_tau_s: float | None = None,
    accel_bias_markov_sd: float | None = None,
) -> AlignConfig:
    """Alignment settings from the sensor noise itself (what
    :func:`rinscal.sim.scenario.align_for` derives from a plant's).

    Parameters
    ----------
    gyro_density : float [rad/√s]
        Gyro angle random walk (white-noise density).
    accel_density : float [m/s²/√Hz]
        Accelerometer velocity random walk.
    gyro_bias_rw : float [rad/s/√s]
        Gyro bias random walk (0: none known); floors the bias states' process noise.
    accel_bias_rw : float [m/s²/√s]
        Accelerometer bias random walk (0: none known).
    total_s, coarse_s, start_s, gyro_bias_tau_s, ... :
        As for :func:`rinscal.sim.scenario.align_for`.
    """
    if not (math.isfinite(total_s) and total_s > 0):
        raise ConfigError(f"alignment time must be > 0 s, got {total_s}")
    coarse = min(coarse_s, total_s / 3)
    d = AlignConfig()
    tau_g = d.gyro_bias_tau_s if gyro_bias_tau_s is None else gyro_bias_tau_s
    tau_a = d.accel_bias_tau_s if accel_bias_tau_s is None else accel_bias_tau_s

    def floor(sd: float, q: float, tau: float) -> float:
        return sd if not (math.isfinite(tau) and tau > 0) else max(sd, q * math.sqrt(tau / 2))

    sd_g = (
        floor(d.gyro_bias_markov_sd, gyro_bias_rw, tau_g)
        if gyro_bias_markov_sd is None
        else gyro_bias_markov_sd
    )
    sd_a = (
        floor(d.accel_bias_markov_sd, accel_bias_rw, tau_a)
        if accel_bias_markov_sd is None
        else accel_bias_markov_sd
    )
    return AlignConfig(
        coarse_s=coarse,
        fine_s=total_s - coarse,
        gyro_noise_density=gyro_density,
        accel_noise_density=accel_density,
        start_s=start_s,
        gyro_bias_tau_s=tau_g,
        gyro_bias_markov_sd=sd_g,
        accel_bias_tau_s=tau_a,
        accel_bias_markov_sd=sd_a,
    )


__all__ = [
    "AlignConfig",
    "AlignResult",
    "Aligner",
    "InertialCoarseAlign",
    "align_from_noise",
    "feed_and_hand_over",
    "wahba",
]
