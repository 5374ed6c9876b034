"""The simulator: thermal chamber, thermal network, IMU plant, protocols, carrier motions,
the ideal IMU and navigation scenarios.

Only the experiments, the reports, the command line and the top-level API import it:
navigating or compensating a recording loads none of its modules (``tests/test_layout.py``
holds both).

Modules
-------
:mod:`~rinscal.sim.field`
    Chamber profiles and the lumped thermal network of the RINS.
:mod:`~rinscal.sim.polynomial`
    The polynomial thermal law of a channel.
:mod:`~rinscal.sim.mechanistic`
    The mechanistic thermal law of a channel.
:mod:`~rinscal.sim.config`
    The IMU's configuration, from a preset (names in :mod:`rinscal.presets`) or a TOML file.
:mod:`~rinscal.sim.plant`
    The plant: the true thermal bias, signal errors, offsets and noise on a thermal field.
:mod:`~rinscal.sim.sensor`
    The sensor law of the plant (scale factors, misalignments, nonlinear drift).
:mod:`~rinscal.sim.protocols`
    The paper's thermal-chamber protocols, simulated into calibration logs.
:mod:`~rinscal.sim.multiposition`
    Multi-position turntable calibration runs, simulated.
:mod:`~rinscal.sim.trajectory`
    Carrier motions: quasi-static, swinging base (Table 9), land-vehicle route (5.2.2).
:mod:`~rinscal.sim.disturbance`
    A disturbed start (people on board, doors) for the cold-start scenarios.
:mod:`~rinscal.sim.ideal_imu`
    Exact ideal-IMU synthesis of r-frame angle and velocity increments, chunk by chunk.
:mod:`~rinscal.sim.scenario_config`
    What a navigation scenario runs (:class:`~rinscal.sim.scenario_config.ScenarioConfig`).
:mod:`~rinscal.sim.sensors`
    The thermal plant of a navigation scenario and its compensators.
:mod:`~rinscal.sim.scenario`
    Scenarios with the thermal plant alongside, compensation variants, position errors.
:mod:`~rinscal.sim.workflow`
    The library side of ``rinscal navigate --scenario``.
"""
