"""IMU calibration on a two-axis turntable: scale factors, misalignments, nonlinear terms and
biases at each chamber set point from static positions (gravity and Earth rate) and rate
tests, then each parameter as a law in temperature (``rinscal calibrate-imu``).

The log (written by ``rinscal simulate multiposition`` or by a real turntable) is a canonical
calibration log plus the table's commanded columns ``table_outer_deg, table_inner_deg`` (the
angles at the end of each sample interval, not wrapped) and ``table_outer_rate_dps,
table_inner_rate_dps`` (the rates during it); one run per set point (``cal_+20C``) or one run
along a ramp (``cal_ramp``, the sequence repeated). Its metadata gives the units and their
factor to SI, the site (``latitude_deg``, ``heading_deg`` the azimuth of the outer axis,
``altitude_m``) and ``set_points_c``. The sensor-error model and its parameters are those of
:mod:`rinscal.sensormodel`; the geometry that of :mod:`rinscal.turntable`.

Modules
-------
:mod:`~rinscal.calibration.imu.segments`
    Static positions and whole-revolution rate segments from the turntable's columns.
:mod:`~rinscal.calibration.imu.design`
    Segment means, each channel's regressors, observability (rank) with named parameters.
:mod:`~rinscal.calibration.imu.estimate`
    Weighted least squares at one temperature, motion checks, parameters and their sds.
:mod:`~rinscal.calibration.imu.laws`
    Each parameter's law in temperature (and rate), chosen on held-out temperatures.
:mod:`~rinscal.calibration.imu.workflow`
    :func:`~rinscal.calibration.imu.workflow.calibrate_imu`, the whole fit.
"""
