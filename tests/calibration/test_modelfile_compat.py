"""A model file written before model files held an IMU calibration (schema version 2) still
loads and compensates exactly as it did when it was written (``tests/data/modelfile_v2``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from rinscal.calibration.modelfile import ThermalModelFile
from rinscal.calibration.workflow import compensate_file
from rinscal.schema import CHANNELS

DATA = Path(__file__).resolve().parents[1] / "data" / "modelfile_v2"


def test_a_version_2_file_still_loads() -> None:
    mf = ThermalModelFile.load(DATA / "model_v2.json")
    assert mf.method == "regression" and mf.channels == CHANNELS
    assert getattr(mf, "imu_calibration", None) is None  # it had none
    assert mf.models["accel_z"].unit == "ug"


@pytest.mark.parametrize(
    ("expected", "causal", "policy"),
    [("compensated.csv", False, "clamp"), ("compensated_causal.csv", True, "extrapolate")],
)
def test_a_version_2_file_compensates_as_it_did(expected, causal, policy, tmp_path) -> None:
    out = tmp_path / "out.csv"
    compensate_file(DATA / "log.csv", DATA / "model_v2.json", out, policy=policy, causal=causal)
    got, want = pd.read_csv(out), pd.read_csv(DATA / expected)
    assert list(got.columns) == list(want.columns)
    for c in CHANNELS:  # written with 17 significant digits: equal to the last bit or two
        np.testing.assert_allclose(got[c], want[c], rtol=1e-15, atol=0, err_msg=c)
    assert (got["out_of_range"] == want["out_of_range"]).all()
