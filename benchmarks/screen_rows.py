"""The field's held-out fits at several ``SCREEN_ROWS``: ``fit`` (``auto``) run once per value
and log, each channel's choice (chosen / T-only fallback) and the PX4 and ArduPilot held-out
RMS printed as a Markdown table (docs/calibration.md, "The field's held-out fits").

::

    rinscal simulate soak --rate 100 --hours 3 --out /tmp/soak.parquet
    rinscal simulate soak --rate 100 --hours 3 --imu paper_mechanistic --seed 1 \\
        --out /tmp/soak_mech.parquet
    python benchmarks/screen_rows.py /tmp/soak.parquet /tmp/soak_mech.parquet \\
        --real tests/data/real/tofupilot_imu_thermal_cycle.tsv \\
        --map examples/tofupilot_mapping.toml --rows 200000,100000,50000,25000

Each fit runs in a process of its own (``python -c``, the module constant set before
``rinscal fit`` runs), as the command does; the model files go to a temporary folder.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Any

RUN = (
    "import sys; import rinscal.calibration.selection.auto as a; "
    "a.SCREEN_ROWS = int(sys.argv[1]); sys.argv = ['rinscal', *sys.argv[2:]]; "
    "from rinscal.cli.commands import main; main()"
)


def selections(path: Path) -> dict[str, dict[str, Any]]:
    """Each channel's ``selection`` record of a model file."""
    models = json.loads(path.read_text())["payload"]["channel_models"]
    return {c: m["selection"] for c, m in models.items()}


def cell(sel: dict[str, Any]) -> str:
    rms = {r["name"]: r["heldout_rms"] for r in sel["table"]}

    def f(name: str) -> str:
        v = rms.get(name)
        return "—" if v is None else f"{v:.5g}"

    return f"{sel['chosen']} / {sel['fallback']} ({f('ardupilot')}, {f('px4')})"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("logs", nargs="*", type=Path, help="rinscal logs (simulated soaks)")
    ap.add_argument("--real", type=Path, help="a foreign log, read through --map")
    ap.add_argument("--map", type=Path, help="the foreign log's mapping")
    ap.add_argument("--rows", default="200000,25000", help="SCREEN_ROWS values, comma separated")
    args = ap.parse_args(argv)
    rows = [int(v) for v in args.rows.split(",")]
    runs = [(p, []) for p in args.logs]
    if args.real is not None:
        runs.append((args.real, ["--map", str(args.map)]))
    print("| log | channel | " + " | ".join(f"SCREEN_ROWS {r}" for r in rows) + " |")
    print("|---|---|" + "---|" * len(rows))
    with tempfile.TemporaryDirectory() as tmp:
        for log, extra in runs:
            sels = []
            for r in rows:
                out = Path(tmp) / f"{log.stem}_{r}.json"
                cmd = [sys.executable, "-c", RUN, str(r), "fit", str(log), *extra]
                subprocess.run([*cmd, "--out", str(out)], check=True, capture_output=True)
                sels.append(selections(out))
            for c in sels[0]:
                print(f"| {log.name} | {c} | " + " | ".join(cell(s[c]) for s in sels) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
