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
