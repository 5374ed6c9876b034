"""Navigation: rotation schedules, trajectories, ideal IMU, strapdown, alignment.

Modules
-------
:mod:`~rinscal.nav.rotation`
    The rotating IMU frame ``r`` on the turntable (axis = body z, encoder angle φ) and its
    schedules: four-position, continuous, none (paper Eqs. 1-9).
:mod:`~rinscal.nav.trajectory`
    Carrier motions: quasi-static, swinging base (Table 9), land-vehicle route (5.2.2).
:mod:`~rinscal.nav.imu`
    Exact ideal-IMU synthesis of r-frame angle and velocity increments, chunk by chunk.
:mod:`~rinscal.nav.strapdown`
    The strapdown integrator (numba kernel in :mod:`~rinscal.nav._kernels`).
:mod:`~rinscal.nav.align`
    Inertial-frame coarse alignment and zero-velocity Kalman fine alignment.
:mod:`~rinscal.nav.aiding`
    Aiding as measurements: zero velocity, a known site, a GNSS track.
:mod:`~rinscal.nav.gnss_ins`
    The 15-state error-state Kalman filter over the strapdown, updated by measurements.
:mod:`~rinscal.nav.inmotion`
    In-motion alignment on a track (no heading given), then aided navigation.
:mod:`~rinscal.nav.scenario`
    Scenarios with the thermal plant alongside, compensation variants, position errors.
:mod:`~rinscal.nav.recorded`
    Navigating a recording: the two passes (window, causal compensation, free navigation).
:mod:`~rinscal.nav.recording`
    The library side of ``rinscal navigate --log``: a recording file in, results out.

Nothing is imported here, so importing :mod:`rinscal.nav` loads no numba kernel.
"""
