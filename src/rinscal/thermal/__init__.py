"""Thermal chamber and IMU simulator: chamber profiles, thermal network, IMU plant, protocols.

Modules
-------
:mod:`~rinscal.thermal.presets`
    Names of the built-in IMU presets.
:mod:`~rinscal.thermal.field`
    Chamber profiles and the lumped thermal network of the RINS.
:mod:`~rinscal.thermal.polynomial`
    The polynomial thermal law of a channel.
:mod:`~rinscal.thermal.mechanistic`
    The mechanistic thermal law of a channel.
:mod:`~rinscal.thermal.config`
    The IMU's configuration, from a preset or a TOML file.
:mod:`~rinscal.thermal.plant`
    The plant: the true thermal bias, signal errors, offsets and noise on a thermal field.
:mod:`~rinscal.thermal.protocols`
    The paper's thermal-chamber protocols, simulated into calibration logs.
"""
