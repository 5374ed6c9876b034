"""Thermal chamber and IMU simulator: chamber profiles, thermal network, IMU plant, protocols."""
