"""The held-out table of docs/plant.md "The mechanistic presets": every figure measured.

Run from the repository root (a few minutes on one core; ``--neural`` adds the network)::

    python docs/scripts/mechanistic_heldout.py [--neural] [--auto]

For each preset, the soak protocol (7 × 3 h at 1 Hz, seed 1) trains every method, as
``rinscal simulate soak --rate 1 --seed 1`` then ``rinscal fit --method M`` would; the
``repeat`` protocol (one 3 h cold start at 25 °C, seed 2) is held out. The entry is the
fraction of the thermal swing the method leaves: RMS of (modelled − true) thermal bias about
the run's mean over RMS of the true thermal bias about the run's mean (the truth file's
``bias_<channel>``, everything the plant adds thermally), per channel; "worst accel" is the
largest of the three accelerometers.
"""

from __future__ import annotations

import argparse
import sys

import pandas as pd

from rinscal.experiments.paper.calibration import fit_all, heldout_table
from rinscal.sim.config import load_imu
from rinscal.sim.protocols import simulate_protocol

PRESETS = ("paper", "paper_mechanistic", "navigation_grade", "navigation_grade_mechanistic")
METHODS = ("poly-t", "sectional", "regression")


def heldout_fractions(
    preset: str,
    methods: tuple[str, ...] = METHODS,
    hours: float | None = None,
    rate_hz: float = 1.0,
    seeds: tuple[int, int] = (1, 2),
) -> pd.DataFrame:
    """Fraction of the thermal swing each method leaves on ``repeat``, trained on ``soak``.

    Returns a frame indexed by channel with one column per method (and ``swing``, the RMS of
    the true bias about the run's mean, in the log's unit)."""
    cfg = load_imu(preset)
    train, _, meta = simulate_protocol("soak", hours, rate_hz, seeds[0], cfg)
    test, truth, _ = simulate_protocol("repeat", hours, rate_hz, seeds[1], cfg)
    models = fit_all(train, meta, methods)
    tab = heldout_table(train, test, truth, meta, models=models, methods=methods)
    wide = tab.pivot_table(index="channel", columns="method", values="rms", sort=False)
    swing = wide.pop("uncompensated")
    out = wide.div(swing, axis=0)
    out["swing"] = swing
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--neural", action="store_true", help="add the neural method (slow)")
    ap.add_argument("--auto", action="store_true", help="add the auto method")
    ap.add_argument("--preset", action="append", choices=PRESETS, help="default: all four")
    args = ap.parse_args(argv)
    methods = METHODS + (("neural",) if args.neural else ()) + (("auto",) if args.auto else ())
    rows = []
    for preset in args.preset or PRESETS:
        frac = heldout_fractions(preset, methods)
        print(f"\n{preset}: fraction of the thermal swing left on repeat [%]")
        print((100 * frac[list(methods)]).round(2).to_string())
        acc = frac.loc[[c for c in frac.index if c.startswith("accel")]]
        rows.append(
            "| "
            + " | ".join([preset] + [f"{100 * acc[m].max():.1f}" for m in methods])
            + " | "
            + " / ".join(f"{100 * frac.loc[c, 'regression']:.1f}" for c in frac.index)
            + " |"
        )
    print("\n| preset | " + " | ".join(methods) + " | regression, all six (gx gy gz ax ay az) |")
    print("|---|" + "---|" * (len(methods) + 1))
    print("\n".join(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
