"""Navigation: rotation schedules, strapdown, alignment, aiding, results, recordings.

Modules
-------
:mod:`~rinscal.nav.rotation`
    The rotating IMU frame ``r`` on the turntable (axis = body z, encoder angle φ) and its
    schedules: four-position, continuous, none (paper Eqs. 1-9).
:mod:`~rinscal.nav.attitude`
    Euler angles to ``C_nb`` and back, vectorised; small-angle attitude errors.
:mod:`~rinscal.nav.strapdown`
    The strapdown integrator (numba kernel in :mod:`rinscal._kernels`).
:mod:`~rinscal.nav.align`
    Inertial-frame coarse alignment and zero-velocity Kalman fine alignment.
:mod:`~rinscal.nav.aiding`
    Aiding as measurements: zero velocity, a known site, a GNSS track.
:mod:`~rinscal.nav.gnss_ins`
    The 15-state error-state Kalman filter over the strapdown, updated by measurements.
:mod:`~rinscal.nav.inmotion`
    In-motion alignment on a track (no heading given), then aided navigation.
:mod:`~rinscal.nav.result`
    The outcome of a navigation (simulated or recorded) and its error series.
:mod:`~rinscal.nav.recorded`
    Navigating a recording: the two passes (window, causal compensation, free navigation).
:mod:`~rinscal.nav.recording`
    The library side of ``rinscal navigate --log``: a recording file in, results out.

Simulated scenarios (trajectories, the ideal IMU, the thermal plant) are in
:mod:`rinscal.sim`, above this package: nothing here imports it. Nothing is imported here,
so importing :mod:`rinscal.nav` loads no numba kernel.
"""
