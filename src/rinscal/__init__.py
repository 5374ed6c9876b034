"""rinscal: thermal calibration of IMUs, proven in a single-axis rotational INS.

Implements, and goes beyond, Wang, Cheng, Du, "Thermal Modeling and Calibration Method in
Complex Temperature Field for Single-Axis Rotational Inertial Navigation System", Sensors
20(2), 2020.

Conventions (the contract every module keeps)
---------------------------------------------
Units
    SI inside the code: rad, rad/s, m/s², m, s. Temperatures in °C; temperature rates in
    °C/min where they are model features (as in the paper), °C/s inside ODEs. Degrees,
    deg/h, µg and nautical miles appear only at the edges (files, CLI, plots) and are
    converted by the named constants in :mod:`rinscal.units`.
Frames (after Groves)
    ``i`` inertial, ``e`` Earth-fixed, ``n`` navigation (East-North-Up, as in the paper),
    ``b`` body/carrier, ``r`` the rotating IMU frame on the turntable (coincides with ``b``
    when the encoder angle is zero; the turntable axis is body z). A vector ``v`` resolved
    in frame ``a`` is written ``v_a``; the rotation matrix taking frame ``b`` to ``a`` is
    ``C_ab`` (so ``v_a = C_ab @ v_b``). Body axes: x right, y forward, z up. Sensor errors,
    thermal ones included, live in ``r`` and are applied before any rotation.
Calibration log (see :mod:`rinscal.schema`)
    One table, one row per sample, several runs stacked: ``time_s`` (seconds since this
    run's power-on, strictly increasing within a run), ``run`` (name of one continuous
    recording), the six sensor channels ``gyro_x gyro_y gyro_z accel_x accel_y accel_z``
    (any consistent unit; simulated logs write deg/h and µg, or pulses), inner temperatures
    ``temp_<channel>`` or one shared ``temp_in`` [°C], optional ``temp_out`` (package
    surface) [°C] and ``chamber_temp`` [°C].
Naming
    Standard deviations end in ``_sd``; fitted attributes end in ``_`` (scikit-learn style).
Randomness
    Only through a seeded :class:`numpy.random.Generator` passed in; configs are frozen
    dataclasses; nothing random or mutable at import time.
"""

from rinscal._version import __version__

__all__ = ["__version__"]
