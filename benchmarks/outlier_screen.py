"""The outlier screen of issue 39 against the running median it replaced: which samples each
flags, and what ``fit --method auto`` then chooses, held out (docs/calibration.md, "The
outlier screen").

::

    rinscal simulate soak --rate 100 --hours 3 --out /tmp/soak.parquet
    python benchmarks/outlier_screen.py /tmp/soak.parquet \\
        --real tests/data/real/tofupilot_imu_thermal_cycle.tsv \\
        --map examples/tofupilot_mapping.toml

For each log and channel it prints, as a Markdown table: the samples flagged by the running
median (``OutlierConfig(kind="running")``, the screen before issue 39) and by the default
(``"decimated"``), those flagged by one and not the other, and ``auto``'s choice with each
screen and, as a control, with the running median on the log without its first sample; then
the held-out RMS of both screens' choices scored on each screen's rows (looked up in the same
selection table), and that of no compensation for scale. A simulated log is read run by run
(as ``rinscal fit`` reads it); a foreign one through its mapping, whole.
"""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from rinscal.calibration.thermal.features import build_features
from rinscal.calibration.thermal.model import ThermalFitter
from rinscal.calibration.thermal.outliers import OutlierConfig
from rinscal.io.foreign import foreign_meta
from rinscal.io.mapping import read_mapping
from rinscal.io.streaming import iter_log_source
from rinscal.io.tables import read_log

KINDS = ("running", "decimated")


def _flags(logs: Any) -> dict[str, dict[str, np.ndarray]]:
    """Per screen and channel, the flagged rows (indices into the whole log)."""
    out: dict[str, dict[str, list[np.ndarray]]] = {k: {} for k in KINDS}
    first = 0
    for log in logs():
        for kind in KINDS:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                f = build_features(log, outliers=OutlierConfig(kind=kind), with_rate=False)
            for j, c in enumerate(f.channels):
                out[kind].setdefault(c, []).append(first + np.flatnonzero(~f.inlier[:, j]))
        first += len(log)
    return {k: {c: np.concatenate(v) for c, v in d.items()} for k, d in out.items()}


def _selections(logs: Any, meta: dict[str, Any], whole: bool, kind: str, skip: int = 0) -> Any:
    """Per channel, ``auto``'s selection record with one screen (``skip``: the log without
    its first rows)."""

    def runs() -> Any:
        for k, log in enumerate(logs()):
            yield (log.iloc[skip:].reset_index(drop=True) if k == 0 and skip else log), 0

    fitter = ThermalFitter("auto", outliers=OutlierConfig(kind=kind))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if whole:
            fitter.fit(next(runs())[0], meta)
        else:
            fitter.fit_runs(runs(), meta)
    return fitter.selections_


def _heldout(sel: dict[str, Any], name: str) -> float:
    row = next(r for r in sel["table"] if r["name"] == name)
    return float("nan") if row["heldout_rms"] is None else float(row["heldout_rms"])


def compare(label: str, logs: Any, meta: dict[str, Any], whole: bool) -> list[str]:
    """Markdown rows comparing the two screens on one log."""
    flags = _flags(logs)
    sels = {k: _selections(logs, meta, whole, k) for k in KINDS}
    control = _selections(logs, meta, whole, "running", skip=1)
    rows = []
    for c in flags["running"]:
        a, b = flags["running"][c], flags["decimated"][c]
        old, new = sels["running"][c]["chosen"], sels["decimated"][c]["chosen"]
        scores = [
            f"{_heldout(sels[k][c], old):.4g} / {_heldout(sels[k][c], new):.4g}" for k in KINDS
        ]
        none = _heldout(sels["running"][c], "none")
        rows.append(
            f"| {label} | {c} | {a.size:,} | {b.size:,} | {np.setdiff1d(a, b).size:,} | "
            f"{np.setdiff1d(b, a).size:,} | {old} | {new} | {control[c]['chosen']} | "
            f"{scores[0]} | {scores[1]} | {none:.4g} |"
        )
    return rows


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("soak", type=Path, help="a simulated calibration log (Parquet or CSV)")
    ap.add_argument("--real", type=Path, help="a foreign log, read through --map")
    ap.add_argument("--map", type=Path, help="the foreign log's column mapping (TOML)")
    args = ap.parse_args()
    print(
        "| log | channel | flagged, running | flagged, decimated | running only | "
        "decimated only | auto, running | auto, decimated | auto, running, first sample "
        "dropped | held-out RMS of the running / decimated choice, running rows | the same, "
        "decimated rows | held-out RMS of none |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    meta = foreign_meta(args.soak, None)

    def soak_runs() -> Any:
        return (src.log for src in iter_log_source(args.soak))

    for row in compare(args.soak.name, soak_runs, meta, whole=False):
        print(row, flush=True)
    if args.real is not None:
        mapping = read_mapping(args.map) if args.map is not None else None
        log = read_log(args.real, mapping)
        meta = foreign_meta(args.real, mapping)
        for row in compare(args.real.name, lambda: iter([log]), meta, whole=True):
            print(row, flush=True)


if __name__ == "__main__":
    main()
