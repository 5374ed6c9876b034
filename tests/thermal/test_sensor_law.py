"""The plant's scale factor, asymmetry, quadratic term and misalignment: the law in
temperature (:func:`rinscal.thermal.sensor.sensor_law`), and the physical soak output
pinned to what it was before those terms existed."""

from __future__ import annotations

from dataclasses import fields, replace

import numpy as np
import pytest

from rinscal.schema import CHANNELS
from rinscal.thermal.config import ImuConfig
from rinscal.thermal.protocols import protocol_runs, simulate_run

# Recorded from main's code before the nonlinear terms were added (commit a422584):
# `simulate_run` of soak_+14C, 0.05 h at 1 Hz, rng seed 11, physical units.
PINNED = {
    "navigation_grade": {
        "first": [-0.08123024806355543, 12.855383321030867, 7.745407919942573,
                  29.90491426219985, -38.086556611819375, 998109.4561839753],
        "last": [-0.002872573688821256, 12.86581699762533, 7.975150815284521,
                 9.795957513181897, -52.465556889486685, 998276.8022916478],
        "sum": [1.3096459351136704, 2299.3285410880717, 1435.5231797588744,
                2390.027050394, -10101.872622273097, 179677683.95145917],
    },
    "paper": {
        "first": [12.695270123525905, 0.1330853030639891, 7.768680573656789,
                  183.39251244570283, 510.2953016036504, 997388.4706312958],
        "last": [12.752156813711839, 0.09425077084886321, 7.971893320054862,
                 -821.8126847416188, -343.4056174929548, 997712.4748388137],
        "sum": [2297.032908946315, 6.901068350121846, 1433.839335005055,
                -107255.79436873524, -34453.19722219671, 179554891.39255595],
    },
}  # fmt: skip

#: Keys of ChannelThermal that hold the slopes of the nonlinear scale-factor terms.
_NEW_SLOPES = ("sf_asym_ppm_per_c", "sf_quad_per_c")


def _without_new_slopes(cfg: ImuConfig) -> ImuConfig:
    names = {f.name for f in fields(cfg.thermal[0])}
    zero = {k: 0.0 for k in _NEW_SLOPES if k in names}
    return replace(cfg, thermal=tuple(replace(c, **zero) for c in cfg.thermal))


def _soak_output(cfg: ImuConfig) -> np.ndarray:
    spec = protocol_runs("soak", hours=0.05)[2]
    run = simulate_run(spec, cfg, rate_hz=1.0, rng=np.random.default_rng(11))
    return run.log[list(CHANNELS)].to_numpy()


@pytest.mark.parametrize("name", sorted(PINNED))
def test_physical_soak_output_is_pinned(name: str) -> None:
    x = _soak_output(_without_new_slopes(ImuConfig.preset(name)))
    pin = PINNED[name]
    # bit for bit on the machine they were recorded on; 1e-13 leaves room for another libm
    np.testing.assert_allclose(x[0], pin["first"], rtol=1e-13, atol=0)
    np.testing.assert_allclose(x[-1], pin["last"], rtol=1e-13, atol=0)
    np.testing.assert_allclose(x.sum(axis=0), pin["sum"], rtol=1e-13, atol=0)
