"""Named unit conversions. Multiply a value in the unit on the left to get SI.

Every constant is ``<UNIT>_TO_<SI UNIT>``; divide by it to go back.
"""

import math

#: Standard gravity [m/s²] (CGPM 1901), the reference for g, mg and µg.
G0 = 9.80665
#: Degree to radian [rad/deg].
DEG_TO_RAD = math.pi / 180.0
#: Arc-second to radian [rad/arcsec].
ARCSEC_TO_RAD = DEG_TO_RAD / 3600.0
#: Hour to second [s/h].
HOUR_TO_S = 3600.0
#: Minute to second [s/min].
MIN_TO_S = 60.0
#: Degree per hour to radian per second [(rad/s)/(deg/h)].
DPH_TO_RPS = DEG_TO_RAD / HOUR_TO_S
#: Degree per second to radian per second [(rad/s)/(deg/s)].
DPS_TO_RPS = DEG_TO_RAD
#: Degree per root-hour (angle random walk) to rad/√s [(rad/√s)/(deg/√h)].
DPRH_TO_RPRS = DEG_TO_RAD / 60.0
#: Milli-g to m/s² [(m/s²)/mg].
MG_TO_MPS2 = 1e-3 * G0
#: Micro-g to m/s² [(m/s²)/µg].
UG_TO_MPS2 = 1e-6 * G0
#: Micro-g per root-hertz to m/s²/√Hz [(m/s²/√Hz)/(µg/√Hz)].
UG_PER_RTHZ_TO_SI = UG_TO_MPS2
#: Nautical mile to metre [m/nmi] (international, exact).
NMI_TO_M = 1852.0
#: Microsecond to second [s/µs].
US_TO_S = 1e-6
#: Millisecond to second [s/ms].
MS_TO_S = 1e-3
#: Celsius offset to kelvin [K].
CELSIUS_TO_KELVIN = 273.15

#: Unit names accepted for sensor columns at the edges, and their factor to SI.
SENSOR_UNITS: dict[str, float] = {
    "rad/s": 1.0,
    "deg/s": DPS_TO_RPS,
    "deg/h": DPH_TO_RPS,
    "m/s^2": 1.0,
    "mg": MG_TO_MPS2,
    "ug": UG_TO_MPS2,
    "g": G0,
}
#: Unit of a channel that counts pulses (its SI value is the IMU's own pulse weight).
PULSE_UNIT = "pulse"
#: Unit names of each sensor type (``"gyro"``, ``"accel"``), pulses included.
SENSOR_TYPE_UNITS: dict[str, tuple[str, ...]] = {
    "gyro": ("rad/s", "deg/s", "deg/h", PULSE_UNIT),
    "accel": ("m/s^2", "mg", "ug", "g", PULSE_UNIT),
}


def check_sensor_unit(sensor: str, unit: str, unit_to_si: float | None = None) -> None:
    """Refuse a unit that is not one of a sensor type's, or whose SI factor contradicts it.

    Parameters
    ----------
    sensor : {"gyro", "accel"}
        Sensor type of the channel.
    unit : str
        Unit name of the channel's output.
    unit_to_si : float, optional [SI per unit]
        The factor that goes with it (any positive value for ``"pulse"``).

    Raises
    ------
    ValueError
        Naming the unit and the units known for the sensor type.
    """
    known = SENSOR_TYPE_UNITS[sensor]
    if unit not in known:
        raise ValueError(
            f"unit {unit!r} is not one rinscal knows for {sensor} channels ({', '.join(known)})"
        )
    want = SENSOR_UNITS.get(unit)
    if (
        want is not None
        and unit_to_si is not None
        and not math.isclose(unit_to_si, want, rel_tol=1e-9)
    ):
        raise ValueError(f"unit_to_si {unit_to_si!r} is not the SI value of one {unit} ({want!r})")


#: How the reports write a unit name of the logs and model files (ASCII there).
_UNIT_WORDS = (("deg", "°"), ("ug", "µg"), ("^2", "²"), ("^3", "³"))


def unit_words(unit: str) -> str:
    """A log's unit name as the reports write it: ``deg/h`` → ``°/h``, ``ug`` → ``µg``,
    ``ug/g^2`` → ``µg/g²``, ``ppm/(deg/s)`` → ``ppm/(°/s)``; others unchanged."""
    for ascii_name, word in _UNIT_WORDS:
        unit = unit.replace(ascii_name, word)
    return unit
