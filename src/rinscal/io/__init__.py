"""Reading and writing logs: calibration tables, flight-controller logs, navigation recordings.

Modules
-------
:mod:`~rinscal.io.atomic`
    Atomic writing: a temporary file beside the destination, then :func:`os.replace`.
:mod:`~rinscal.io.mapping`
    ``ColumnMapping``: how a foreign log, calibration log or navigation recording, is read
    (other names, units, separator, counts, axes); one file format, one meaning per key.
:mod:`~rinscal.io.tables`
    Read and write whole calibration logs (CSV, TSV, Parquet); ``SourceLog``.
:mod:`~rinscal.io.streaming`
    Read a log run by run (``iter_log_source``, ``by_runs``) and write one run by run
    (``LogStreamWriter``): memory bounded by the longest run.
:mod:`~rinscal.io.metadata`
    Sidecar metadata ``<log>.meta.json``.
:mod:`~rinscal.io.params`
    The IMU parameter table (truth and estimate of an IMU calibration).
:mod:`~rinscal.io.imucal`
    ``read_imu_calibration``: an IMU calibration from a calibrate-imu file, a bare one, or
    a thermal model file that holds one.
:mod:`~rinscal.io.foreign`
    Open a log through one ``ReadOptions`` (a mapping file and options over it): mapping or
    flight-log options, and metadata.
:mod:`~rinscal.io.flightinfo`
    Flight-log options, IMU instances and info; helpers shared by the two readers.
:mod:`~rinscal.io.ulog`
    PX4 ULog (``.ulg``) reader.
:mod:`~rinscal.io.dataflash`
    ArduPilot DataFlash (``.bin``) reader.
:mod:`~rinscal.io.flightlog`
    Scan or read a flight log (either kind) as a calibration log.
:mod:`~rinscal.io.navmapping`
    Old names (``NavMapping``, ``read_nav_mapping``) of the one mapping, for one release.
:mod:`~rinscal.io.track`
    A reference track: a table or NMEA GGA sentences.
:mod:`~rinscal.io.navlog`
    ``NavLog``: a recorded-navigation log read in pieces of SI increments.
:mod:`~rinscal.io.navopen`
    ``open_nav_log``: a recorded-navigation log's format; its header, mapping, metadata and
    units.
"""
