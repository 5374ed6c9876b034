"""Causal compensation of a recording piece by piece, as the navigation computer runs a
thermal model (:class:`CausalModelCompensator`), behind the model file's IMU calibration when
it holds one (the file's one order: the inverse sensor model at the channel temperatures,
then the thermal bias)."""

from __future__ import annotations

import math
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from rinscal.errors import ConfigError
from rinscal.schema import CHANNELS, NavSamples
from rinscal.units import MIN_TO_S

__all__ = [
    "CausalModelCompensator",
    "PieceCompensator",
]


# --------------------------------------------------------------------------- compensation
class PieceCompensator(Protocol):
    """Causal compensation of a recording piece by piece: bias (n, 6) SI to subtract."""

    channels: tuple[str, ...]

    def __call__(self, s: NavSamples) -> NDArray[np.float64]: ...


class CausalModelCompensator:
    """A thermal model run as the navigation computer runs it, piece by piece.

    The thermometers are read once per ``update_s`` (the first sample whose interval's
    middle falls in a new tick: its temperature columns, dated at the tick); the
    temperature rate is the model's causal windowed slope over these readings (the
    compiled :class:`~rinscal.calibration.thermal.rate.CausalSlope` of ``compensate --causal``);
    the bias ``(f(T, Ṫ, ΔT) − r)`` in SI is held until the next reading. A reading with a
    NaN temperature keeps the last one. Channels the model lacks are not compensated.

    A model file that holds an IMU calibration (:attr:`FittedModel.imu_stage`) is
    applied in its one order: each sample's rates (increments over their interval) go
    through the inverse sensor model at the last thermometer reading
    (:meth:`~rinscal.calibration.imustage.ImuStage.inverse_si`, the step every compensator
    shares), then lose the thermal bias. What is returned stays "what to subtract": ``y −
    inverse(y) + bias``. Samples before the first complete reading are left as they are.

    Parameters
    ----------
    model : FittedModel
    policy : {"clamp", "fallback", "extrapolate", "error"}
    update_s : float [s]
        Thermometer reading interval (the simulator's is 1 s).
    """

    def __init__(self, model: Any, policy: str = "clamp", update_s: float = 1.0) -> None:
        # deferred: rate imports numba (~0.25 s); only a model run causally needs it
        from rinscal.calibration.thermal.rate import CausalSlope

        if not (math.isfinite(update_s) and update_s > 0):
            raise ConfigError(f"model update interval must be > 0 s, got {update_s}")
        idx = []
        for c in model.channels:
            if c not in CHANNELS:
                raise ConfigError(f"model channel {c!r} is not one of {CHANNELS}")
            idx.append(CHANNELS.index(c))
        self.model = model
        self.policy = policy
        self.update_s = float(update_s)
        self.channels = tuple(model.channels)
        self._idx = np.array(idx, dtype=np.int64)
        self._slope = CausalSlope(model.derivative_window_s, len(idx))
        self._tick = -(2**62)
        self._bias = np.zeros(6)
        self._last_temp: NDArray | None = None
        self._last_out: float = float("nan")
        self.readings = 0
        #: thermometer readings skipped because no thermometer had read yet
        self.skipped = 0
        #: the model uses the gradient ΔT (needs the outer temperature)
        self.needs_outer = bool(getattr(model, "use_gradient", False)) and any(
            getattr(model.models[c], "n_inputs", 3) >= 3 for c in model.channels
        )
        #: the model file's IMU calibration, applied first (None: the thermal model alone)
        self.stage = getattr(model, "imu_stage", None)
        if self.stage is not None and self.stage.needs_rate and len(idx) != 6:
            raise ConfigError(
                "a model whose IMU calibration has laws in the temperature rate needs all six "
                f"channels' thermal models to follow their temperatures; it has {self.channels}"
            )
        self._held_t = np.full(6, np.nan)  # last complete reading of all six thermometers
        self._held_r = np.zeros(6)  # and its rate [°C/min]

    def __call__(self, s: NavSamples) -> NDArray[np.float64]:
        if s.temps is None:
            raise ConfigError(
                f"a thermal model needs temperatures, and the recording has none for "
                f"{', '.join(self.channels)} (columns temp_<channel> or temp_in)"
            )
        tick = np.floor((s.t - 0.5 * s.dt) / self.update_s + 1e-9).astype(np.int64)
        new = np.flatnonzero(np.diff(tick, prepend=self._tick) != 0)
        out = np.empty((s.n, 6))
        seg = np.zeros(s.n, dtype=np.int64)
        held_t = held_r = None
        if new.size:
            temp = s.temps[new][:, self._idx].copy()
            all6 = s.temps[new].copy()
            t_out = None if s.temp_out is None else s.temp_out[new].copy()
            self._hold(temp, t_out)
            # no reading yet (a thermometer empty from the start): the model waits for one
            ok = np.isfinite(temp).all(axis=1)
            if self.needs_outer:
                if t_out is None:
                    raise ConfigError(
                        f"the model uses the gradient ΔT = T − temp_out for "
                        f"{', '.join(self.channels)}, and the recording has no outer "
                        "temperature (a temp_out column, or a mapping onto it)"
                    )
                ok &= np.isfinite(t_out)
            if not ok.all():
                self.skipped += int((~ok).sum())
                new, temp, all6 = new[ok], temp[ok], all6[ok]
                t_out = None if t_out is None else t_out[ok]
        if new.size:
            times = tick[new] * self.update_s
            rate = self._slope.update(times.astype(float), temp) * MIN_TO_S
            bias = np.zeros((new.size, 6))
            bias[:, self._idx] = self.model.predict_bias_si(temp, rate, t_out, policy=self.policy)
            # each sample takes the last reading at or before it (row 0: the one held before)
            seg[new] = 1
            np.cumsum(seg, out=seg)
            np.take(np.vstack([self._bias, bias]), seg, axis=0, out=out)
            self._bias = bias[-1]
            self.readings += new.size
            if self.stage is not None:
                all6[:, self._idx] = temp  # the held (forward-filled) readings
                rate6 = np.zeros_like(all6)
                rate6[:, self._idx] = rate
                held_t = np.vstack([self._held_t, all6])
                held_r = np.vstack([self._held_r, rate6])
                self._held_t, self._held_r = all6[-1].copy(), rate6[-1].copy()
        else:
            out[:] = self._bias
        if self.stage is not None:
            if held_t is None:
                held_t, held_r = self._held_t[None, :], self._held_r[None, :]
            out += self._imu_step(s, held_t[seg], held_r[seg])
        self._tick = int(tick[-1])
        return out

    def _imu_step(self, s: NavSamples, temp: NDArray, rate: NDArray) -> NDArray[np.float64]:
        """``y − inverse(y)`` per sample [SI]: what the IMU calibration takes away."""
        assert self.stage is not None
        y = np.column_stack([s.dtheta, s.dv]) / s.dt[:, None]
        ok = np.isfinite(temp).all(axis=1)  # before the first reading: nothing
        step = np.zeros_like(y)
        if ok.any():
            tdot = rate[ok] if self.stage.needs_rate else None
            step[ok] = y[ok] - self.stage.inverse_si(y[ok], temp[ok], tdot)
        return step

    def _hold(self, temp: NDArray, t_out: NDArray | None) -> None:
        """Replace NaN readings by the last finite one (forward fill across pieces)."""
        for j in range(temp.shape[1]):
            col = temp[:, j]
            last = np.nan if self._last_temp is None else self._last_temp[j]
            temp[:, j] = _ffill(col, last)
        self._last_temp = temp[-1].copy()
        if t_out is not None:
            t_out[:] = _ffill(t_out, self._last_out)
            self._last_out = float(t_out[-1])


def _ffill(x: NDArray, last: float) -> NDArray:
    ok = np.isfinite(x)
    if ok.all():
        return x
    idx = np.where(ok, np.arange(x.size), -1)
    np.maximum.accumulate(idx, out=idx)
    return np.where(idx >= 0, x[np.maximum(idx, 0)], last)
