"""The two flight-log formats' pieces with answers known from their specifications: a ULog
parameter message (``rinscal.io.ulog``), ArduPilot's board rotation and parameter changes
(``rinscal.io.dataflash``), and the compiled message copier both use
(``rinscal.io._gather``)."""

from __future__ import annotations

import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from rinscal.errors import LogError
from rinscal.io._gather import _gather
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


def test_the_message_copier_takes_each_whole_message_and_skips_the_cut_and_short() -> None:
    """Three ULog-style messages (uint16 size, type byte, payload): the second says it is
    shorter than the field copied, the third is cut by the end of the buffer."""
    msgs = [
        struct.pack("<HB", 6, ord("D")) + bytes(range(10, 16)),
        struct.pack("<HB", 2, ord("D")) + bytes([20, 21]),
        struct.pack("<HB", 6, ord("D")) + bytes([30, 31]),
    ]
    buf = np.frombuffer(b"".join(msgs), dtype=np.uint8)
    offsets = np.array([0, 9, 14], dtype=np.int64)
    out = np.zeros((3, 4), dtype=np.uint8)
    assert _gather(buf, offsets, 5, 4, out, True) == 1  # skip = 3 header + 2 payload bytes
    np.testing.assert_array_equal(out[0], [12, 13, 14, 15])
    out[:] = 0
    # unsized (DataFlash): the size field is not read, only the end of the buffer counts
    assert _gather(buf, offsets, 3, 2, out[:, :2], False) == 3
    np.testing.assert_array_equal(out[:, :2], [[10, 11], [20, 21], [30, 31]])


def test_the_log_options_and_the_calibration_workflow_load_no_numba() -> None:
    """numba (about half a second to import) is loaded by a flight-log reader or a rate
    kernel, not by importing what every command imports (compensate loads it on a thread
    while it reads)."""
    code = (
        "import sys, rinscal.io.flightinfo, rinscal.calibration.workflow; "
        "assert 'numba' not in sys.modules, 'numba loaded'; "
        "import rinscal.io.ulog; assert 'numba' in sys.modules"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
