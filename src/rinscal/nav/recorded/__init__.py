"""Navigate a recording: alignment window, causal compensation, free navigation.

The recording arrives as :class:`rinscal.schema.NavSamples` pieces (SI increments in the
IMU frame r, read by :mod:`rinscal.io.navopen`); nothing here reads a file. Two passes over the
pieces:

1. :class:`~rinscal.nav.recorded.blocks.BlockStats` sums every second of the recording: the
   specific force magnitude ``|f|`` (its mean and spread), the mean rate and force vectors,
   the spread of first differences (white noise), the encoder's turn, and the largest
   deviation of its 0.1 s means. From these :mod:`~rinscal.nav.recorded.motion` and
   :mod:`~rinscal.nav.recorded.window` find the alignment window (``find_window``),
   :mod:`~rinscal.nav.recorded.noise` the filter's sensor noise if nobody gave it (from the
   window's Allan deviation, ``estimate_noise_allan``), whether the units are
   plausible (``check_at_rest``) and what the turntable did (``seen_schedule``).
2. :func:`~rinscal.nav.recorded.navigate.navigate_recording` runs the variants
   (uncompensated, one per model) side by side: every variant's compensator sees every
   sample from the first on (its temperature history is causal), the aligner the window,
   the strapdown everything after it.

What "quiet" means is told in :mod:`~rinscal.nav.recorded.motion`.

Modules
-------
:mod:`~rinscal.nav.recorded.frame`
    The recorded-navigation log's columns written from a simulated chunk.
:mod:`~rinscal.nav.recorded.blocks`
    The first pass: per-second sums.
:mod:`~rinscal.nav.recorded.kind`
    What the recording is: at rest, moving, a calibration log (said before the window).
:mod:`~rinscal.nav.recorded.motion`
    Which seconds are quiet, judged on what quantisation cannot hide; where it moved.
:mod:`~rinscal.nav.recorded.window`
    The alignment window, the first-difference noise, the checks, the turntable's schedule.
:mod:`~rinscal.nav.recorded.noise`
    The filter's noise from the window's Allan deviation (IEEE 952 terms, bounds).
:mod:`~rinscal.nav.recorded.compensation`
    Causal thermal compensation piece by piece.
:mod:`~rinscal.nav.recorded.navigate`
    The second pass: the variants navigated side by side against the reference.
"""
