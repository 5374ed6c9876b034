"""The field calibration against the chamber's method 2 on held-out parked cold starts.

Run from the repository root (about 2 minutes per plant on one core)::

    python docs/scripts/field_heldout.py [--imu paper] [--rate 10] \
        [--out docs/results/field-heldout-paper.csv]

For one plant: the chamber calibration (Table 3's soak, 7 × 3 h at 10 Hz, ``fit --method
regression``: the paper's method 2) and the field calibration (7 parked starts at Table 3's
ambients, 4 h each, ``calibrate-field --method regression``: method 2's form); then six
held-out parked starts at other ambients (4, 11, 18, 25, 32, 39 °C, other seeds). On each
held-out start and channel, from the end of its first rotation period on (rows every 10 s),
the RMS about the start's mean of

* ``none``: the truth's own thermal variation (no compensation),
* ``chamber``: the chamber model's predicted bias minus the truth,
* ``field``: the field model's predicted bias minus the truth,

the truth being the truth file's total equivalent error on the static base (``static_*``),
both models driven by the start's own thermometers. The turn-on offset is not thermal (the
RMS is about each start's mean). Printed and written as a table: per channel and variant,
the mean over the held-out starts with its 95 % Student-t interval.
"""

from __future__ import annotations

import argparse
import tempfile
import warnings
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import stats

import rinscal
from rinscal import units
from rinscal.calibration.thermal.features import build_features
from rinscal.nav.fieldcal import calibrate_field, series_log
from rinscal.schema import CHANNELS

HELD_OUT_C = (4.0, 11.0, 18.0, 25.0, 32.0, 39.0)


def _predicted(model: rinscal.FittedModel, log: pd.DataFrame) -> np.ndarray:
    """Each channel's predicted bias [SI] on a calibration log's rows."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        feats = build_features(log)
    out = np.empty((len(log), len(CHANNELS)))
    tout = log["temp_out"].to_numpy() if "temp_out" in log.columns else None
    for j, c in enumerate(CHANNELS):
        x = model.feature_matrix(c, feats.temp[:, j], feats.rate[:, j], tout)
        f, _ = model.predict_channel(c, x, policy="clamp")
        cm = model.models[c]
        out[:, j] = (f - (cm.static_reference or 0.0)) * cm.unit_to_si
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--imu", default="paper")
    ap.add_argument("--rate", type=float, default=10.0, help="parked starts' rate [Hz]")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        log, _, meta = rinscal.simulate("soak", hours=3.0, rate_hz=10.0, seed=0, imu=args.imu)
        chamber = rinscal.fit(log, "regression", meta=meta).model
        train = rinscal.simulate_field_starts(
            d / "train", runs=7, hours=4.0, rate_hz=args.rate, imu=args.imu, seed=1
        )
        field = calibrate_field([str(p) for p in train], method="regression").model
        held = rinscal.simulate_field_starts(
            d / "held", runs=len(HELD_OUT_C), ambient_c=HELD_OUT_C, hours=4.0,
            rate_hz=args.rate, imu=args.imu, seed=2,
        )  # fmt: skip
        est = calibrate_field([str(p) for p in held])  # the held-out starts' thermometers
        rows = []
        for p in held:
            s = est.series[p.stem]
            hl, _ = series_log({p.stem: s})
            after = hl["time_s"].to_numpy() >= s.first_period_s  # as the docstring says
            truth = pd.read_parquet(p.with_name(p.stem + ".truth.parquet"))
            k = np.searchsorted(truth["time_s"].to_numpy(), hl["time_s"].to_numpy())
            want = truth[[f"static_{c}" for c in CHANNELS]].to_numpy()[k]
            for name, pred in (
                ("none", np.zeros_like(want)),
                ("chamber", _predicted(chamber, hl)),
                ("field", _predicted(field, hl)),
            ):
                e = (pred - want)[after]  # the features from every row, judged after
                e -= e.mean(axis=0)
                for j, c in enumerate(CHANNELS):
                    rows.append({"start": p.stem, "channel": c, "variant": name,
                                 "rms": float(np.sqrt(np.mean(e[:, j] ** 2)))})  # fmt: skip
    df = pd.DataFrame(rows)
    scale = {
        c: (1 / units.DPH_TO_RPS if c.startswith("gyro") else 1 / units.UG_TO_MPS2)
        for c in CHANNELS
    }
    out = []
    for (c, v), g in df.groupby(["channel", "variant"], sort=False):
        x = g["rms"].to_numpy() * scale[c]
        half = stats.t.ppf(0.975, x.size - 1) * x.std(ddof=1) / np.sqrt(x.size)
        out.append({"channel": c, "unit": "deg/h" if c.startswith("gyro") else "ug",
                    "variant": v, "mean_rms": x.mean(), "ci_low": x.mean() - half,
                    "ci_high": x.mean() + half, "n_starts": x.size})  # fmt: skip
    table = pd.DataFrame(out)
    pd.set_option("display.width", 160)
    print(f"{args.imu}: RMS about each held-out start's mean, mean over {len(HELD_OUT_C)} starts")
    print(table.to_string(index=False, float_format=lambda v: f"{v:.4g}"))
    if args.out is not None:
        table.to_csv(args.out, index=False)


if __name__ == "__main__":
    main()
