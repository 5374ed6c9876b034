"""What a flight log holds and how to read one: the parts the ULog and DataFlash readers share.

:class:`FlightLogOptions` (which IMU instance, how PX4's accelerometer is joined),
:class:`ImuInstance`, :class:`FlightLogInfo` and :class:`FlightLog`, and the helpers both
readers use: the memory-mapped file, its magic number, the increasing-time check and the
canonical frame (the compiled message copier is :mod:`rinscal.io._gather`, apart: numba is
loaded by a reader, not by every command that names the options). The readers are
:mod:`rinscal.io.ulog` and :mod:`rinscal.io.dataflash`; :mod:`rinscal.io.flightlog` picks one
by suffix.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
import pandas as pd

from rinscal.errors import LogError
from rinscal.schema import RUN

__all__ = [
    "FLIGHT_FORMATS",
    "FLIGHT_UNITS",
    "FlightLog",
    "FlightLogInfo",
    "FlightLogOptions",
    "ImuInstance",
]

#: Flight-log formats by suffix.
FLIGHT_FORMATS: dict[str, str] = {".ulg": "ulog", ".bin": "dataflash"}
#: Units of the channels of a flight log.
FLIGHT_UNITS: dict[str, str] = {"gyro": "rad/s", "accel": "m/s^2"}


@dataclass(frozen=True)
class FlightLogOptions:
    """How to read a flight log.

    Attributes
    ----------
    instance : int, "all" or None
        The IMU instance (0-based, PX4 ``multi_id``, ArduPilot ``IMU.I``); ``"all"``: every
        instance, one run each; None: the only one (an error naming them when there are
        several).
    join : {"interpolate", "nearest"}
        How PX4's accelerometer is put on the gyro's sample times.
    run : str, optional
        Run name of a single instance (default: the file's stem); with several instances
        each run is ``<name>/imu<N>``.
    """

    instance: int | Literal["all"] | None = None
    join: Literal["interpolate", "nearest"] = "interpolate"
    run: str | None = None

    def __post_init__(self) -> None:
        if self.join not in ("interpolate", "nearest"):
            raise LogError(f"join must be 'interpolate' or 'nearest', got {self.join!r}")
        if self.instance is not None and self.instance != "all":
            if isinstance(self.instance, bool) or not isinstance(self.instance, int):
                raise LogError(f"instance must be an integer >= 0 or 'all', got {self.instance!r}")
            if self.instance < 0:
                raise LogError(f"instance must be >= 0, got {self.instance}")


@dataclass(frozen=True)
class ImuInstance:
    """One IMU of a flight log: its instance, device ids and active thermal correction."""

    index: int
    gyro_id: int | None
    accel_id: int | None
    samples: int
    #: What the autopilot's own thermal correction does on this instance (text), or None.
    correction: str | None = None

    def label(self) -> str:
        """``"0 (gyro 2424842, accel 2424842, 7,200 samples)"``."""
        return (
            f"{self.index} (gyro {self.gyro_id}, accel {self.accel_id}, {self.samples:,} samples)"
        )


@dataclass(frozen=True)
class FlightLogInfo:
    """What a flight log holds, without its samples.

    See :func:`rinscal.io.flightlog.scan_flight_log`.
    """

    path: Path
    autopilot: Literal["px4", "ardupilot"]
    instances: tuple[ImuInstance, ...]
    params: dict[str, float]
    #: Parameters changed while logging: (time since boot [s], name, value).
    changed: tuple[tuple[float, str, float], ...] = ()
    notes: tuple[str, ...] = ()

    def instance(self, index: int) -> ImuInstance:
        """The instance ``index``, or a LogError listing the instances there are."""
        for inst in self.instances:
            if inst.index == index:
                return inst
        raise LogError(
            f"{self.path}: no IMU instance {index}; the log has "
            + ("; ".join(i.label() for i in self.instances) or "none")
        )

    def selected(self, options: FlightLogOptions) -> tuple[ImuInstance, ...]:
        """The instances ``options`` selects (a LogError when the choice is ambiguous)."""
        if options.instance == "all":
            return self.instances
        if options.instance is None:
            if len(self.instances) == 1:
                return self.instances
            raise LogError(
                f"{self.path}: {len(self.instances)} IMU instances: "
                + "; ".join(i.label() for i in self.instances)
                + "; choose one with instance=N (or instance=all: one run per instance)"
            )
        return (self.instance(int(options.instance)),)

    def meta(self, options: FlightLogOptions) -> dict[str, Any]:
        """Log metadata for the model file: units, autopilot, instance, device ids."""
        meta: dict[str, Any] = {
            "units": dict(FLIGHT_UNITS),
            "autopilot": self.autopilot,
            "log": self.path.name,
        }
        chosen = self.selected(options)
        if len(chosen) == 1:
            inst = chosen[0]
            meta["instance"] = inst.index
            ids = {k: v for k, v in (("gyro", inst.gyro_id), ("accel", inst.accel_id)) if v}
            if ids:
                meta["device_ids"] = ids
            if inst.correction:
                meta["autopilot_correction"] = inst.correction
        return meta


@dataclass(frozen=True)
class FlightLog:
    """A flight log read: its info and the canonical log of the selected instances."""

    info: FlightLogInfo
    frame: pd.DataFrame
    notes: tuple[str, ...] = field(default=())


def _open_buffer(p: Path) -> np.ndarray:
    size = p.stat().st_size
    if size == 0:
        return np.zeros(0, dtype=np.uint8)
    return np.memmap(p, dtype=np.uint8, mode="r")


def _check_magic(p: Path, magic: bytes, what: str, hint: str) -> None:
    with p.open("rb") as fh:
        head = fh.read(len(magic))
    if head != magic:
        found = "an empty file" if not head else f"starts with {head[:8]!r}"
        raise LogError(f"{p}: not a {what} ({found}; a {what} starts with {magic!r}){hint}")


#: Share of samples whose time does not increase above which a stream is refused, not cut.
_MAX_OUT_OF_ORDER = 0.01


def _increasing(t: np.ndarray, what: str) -> np.ndarray:
    """Samples whose time is later than every earlier sample's.

    A lone sample stamped far ahead (a glitch) would hide every later one; it is dropped
    first, when it is later than the next sample while its neighbours are in order. More
    than 1 % of the samples out of order is refused (LogError naming ``what``).
    """
    keep = np.ones(t.size, dtype=bool)
    if t.size > 2:  # isolated spikes: t[i] > t[i+1] although t[i-1] < t[i+1]
        spike = (t[1:-1] > t[2:]) & (t[:-2] < t[2:])
        keep[1:-1] = ~spike
    if t.size > 1:
        tk = t[keep]
        ok = np.ones(tk.size, dtype=bool)
        ok[1:] = tk[1:] > np.maximum.accumulate(tk)[:-1]
        keep[np.flatnonzero(keep)[~ok]] = False
    bad = int((~keep).sum())
    if bad > _MAX_OUT_OF_ORDER * t.size:
        first = int(np.flatnonzero(~keep)[0])
        raise LogError(
            f"{what}: {bad} of {t.size} sample times do not increase (first at sample "
            f"{first + 1}, {t[first]} µs after {t[first - 1] if first else 0} µs); the "
            "timestamps are damaged"
        )
    return keep


def _frame(cols: Mapping[str, np.ndarray], run: str) -> pd.DataFrame:
    """A canonical frame: ``time_s``, ``run``, then the numeric columns as float64.

    The numbers are written once into one column-major block that pandas takes as it is
    (building the frame from separate columns would copy them all again).
    """
    names = list(cols)
    n = len(cols[names[0]])
    block = np.empty((len(names), n))
    for k, name in enumerate(names):
        block[k] = cols[name]
    frame = pd.DataFrame(block.T, columns=names, copy=False)
    frame.insert(1, RUN, run)
    return frame
