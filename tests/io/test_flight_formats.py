"""The two flight-log formats' pieces with answers known from their specifications: a ULog
parameter message (``rinscal.io.ulog``) and ArduPilot's board rotation and parameter changes
(``rinscal.io.dataflash``)."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest

from rinscal.errors import LogError
from rinscal.io.dataflash import _in_force, _rotation
from rinscal.io.ulog import _ulog_param


def _param(key: str, value: bytes) -> bytes:
    """A ULog ``P`` message payload: key length, ``"<type> <name>"``, the value's bytes."""
    k = key.encode()
    return bytes([len(k)]) + k + value


def test_a_ulog_parameter_is_read_in_its_declared_type() -> None:
    assert _ulog_param(_param("float IMU_GYRO_RATEMAX", struct.pack("<f", 0.25))) == (
        "IMU_GYRO_RATEMAX",
        0.25,
    )
    assert _ulog_param(_param("int32_t SENS_BOARD_ROT", struct.pack("<i", -3))) == (
        "SENS_BOARD_ROT",
        -3.0,
    )
    assert _ulog_param(_param("char SYS_NAME", b"x")) is None  # text, not a number
    assert _ulog_param(_param("double LAT", b"\x00\x01")) is None  # cut short


def test_ardupilot_rotations_are_pymavlinks_except_the_one_it_has_wrong() -> None:
    pytest.importorskip("pymavlink")
    where = Path("flight.bin")
    assert _rotation(0, where) is None
    np.testing.assert_allclose(  # ROTATION_YAW_90: a yaw of +90°, Rz(90°)
        _rotation(2, where), [[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]], atol=1e-12
    )
    with pytest.raises(LogError, match="AHRS_ORIENTATION = 38"):
        _rotation(38, where)
    with pytest.raises(LogError, match="AHRS_ORIENTATION = 100 is not a rotation"):
        _rotation(100, where)


def test_parameters_change_at_their_time_and_hold_until_the_next_change() -> None:
    t = np.arange(10.0)  # [s]
    parts = _in_force({"G": 1.0}, [(6.0, "G", 3.0), (3.5, "G", 2.0)], t)
    assert [(s.start, s.stop, p["G"]) for s, p in parts] == [(0, 4, 1.0), (4, 6, 2.0), (6, 10, 3.0)]
