"""An IMU's noise read below the simulator (:mod:`rinscal.imunoise`): what a recording's
navigation is told by ``imu=`` is the noise the simulator's plant of that IMU has."""

from __future__ import annotations

from importlib import resources
from pathlib import Path

import pytest

from rinscal.errors import ConfigError
from rinscal.imunoise import load_noise
from rinscal.presets import PRESETS
from rinscal.sim.config import load_imu


@pytest.mark.parametrize("name", PRESETS)
def test_a_preset_s_noise_is_its_plant_s(name: str) -> None:
    assert load_noise(name) == load_imu(name).noise


def test_a_toml_file_s_noise_is_its_plant_s_and_a_bad_key_is_named(tmp_path: Path) -> None:
    text = resources.files("rinscal.data").joinpath("navigation_grade.toml").read_text()
    line = next(ln for ln in text.splitlines() if ln.startswith("gyro_arw_deg_rth"))
    path = tmp_path / "imu.toml"
    path.write_text(text.replace(line, "gyro_arw_deg_rth = 0.0042"))
    assert load_noise(path).gyro_arw_deg_rth == 0.0042  # [deg/√h]
    assert load_noise(path) == load_imu(path).noise
    path.write_text(text.replace(line, f"{line}\ngyro_arw = 1.0"))
    with pytest.raises(
        ConfigError, match=r"imu\.toml: unknown key\(s\) \['gyro_arw'\] in \[noise\]"
    ):
        load_noise(path)
    with pytest.raises(ConfigError, match="neither a preset"):
        load_noise("no_such_imu")
