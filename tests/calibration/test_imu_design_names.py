"""The names of each channel's regression coefficients (``rinscal.calibration.imu.design``):
the row of the linear matrix after the bias, the nonlinear terms last."""

from __future__ import annotations

from rinscal.calibration.imu.design import channel_parameters


def test_a_linear_channel_has_its_bias_and_its_row_of_the_matrix() -> None:
    assert channel_parameters("accel", 1, nonlinear=False) == [
        "accel_bias_y",
        "accel_K_yx",
        "accel_K_yy",
        "accel_K_yz",
    ]


def test_a_nonlinear_gyro_adds_asymmetry_then_the_quadratic_term() -> None:
    names = channel_parameters("gyro", 2, nonlinear=True)
    assert names[-2:] == ["gyro_sf_asym_z", "gyro_sf_quad_z"] and len(names) == 6
    assert channel_parameters("accel", 2, nonlinear=True)[-1] == "accel_sf_quad_z"
    assert "accel_sf_asym_z" not in channel_parameters("accel", 2, nonlinear=True)
