"""The navigation errors against a truth (``rinscal.nav.result.error_frame``): a known
position offset gives its metres on the principal radii, a known attitude its angles, and a
heading across ±180° wraps."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rinscal import earth, units
from rinscal.nav.attitude import C_nb_from_euler
from rinscal.nav.result import error_frame
from rinscal.nav.strapdown import dcm_to_quat


def _rows(lat: float, heading_true: float, heading_ins: float, dn: float, de: float):
    truth = np.array([[10.0, lat, 0.2, 50.0, 1.0, 2.0, 0.0, heading_true, 0.01, -0.02, 0.0]])
    rn, re = earth.principal_radii(np.array([lat]))
    q = dcm_to_quat(C_nb_from_euler(np.array([heading_ins, 0.01, -0.02])))
    ins = np.array(
        [
            [
                lat + dn / (rn[0] + 50.0),
                0.2 + de / ((re[0] + 50.0) * math.cos(lat)),
                53.0,
                1.5,
                2.0,
                -0.1,
                *q,
            ]
        ]
    )
    return truth, ins


def test_a_known_offset_and_heading_error_come_back() -> None:
    lat = 34.0 * units.DEG_TO_RAD
    truth, ins = _rows(lat, 0.3, 0.3 + 100 * units.ARCSEC_TO_RAD, dn=300.0, de=-400.0)
    e = error_frame(truth, ins).iloc[0]
    assert e["north_m"] == pytest.approx(300.0, rel=1e-9)
    assert e["east_m"] == pytest.approx(-400.0, rel=1e-9)
    assert e["horizontal_m"] == pytest.approx(500.0, rel=1e-9)
    assert e["horizontal_nmi"] == pytest.approx(500.0 / 1852.0, rel=1e-9)
    assert e["up_m"] == pytest.approx(3.0)
    assert e["v_e_err"] == pytest.approx(0.5) and e["v_n_err"] == pytest.approx(0.0)
    heading = [c for c in e.index if "heading" in c]
    assert heading, list(e.index)
    assert e[heading[0]] == pytest.approx(100 * units.ARCSEC_TO_RAD, rel=1e-6)


def test_a_heading_error_across_180_degrees_wraps() -> None:
    lat = 10.0 * units.DEG_TO_RAD
    truth, ins = _rows(lat, math.radians(179.0), math.radians(-179.0), 0.0, 0.0)
    e = error_frame(truth, ins).iloc[0]
    heading = next(c for c in e.index if "heading" in c)
    assert e[heading] == pytest.approx(math.radians(2.0), rel=1e-6)
    assert e["horizontal_m"] == pytest.approx(0.0, abs=1e-6)
