"""docs/sensor-model.md: its worked example runs and its table holds the numbers it computes."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tests.test_docs_api import python_blocks

DOC = Path(__file__).resolve().parents[1] / "docs" / "sensor-model.md"


def _run() -> dict[str, object]:
    namespace: dict[str, object] = {"__name__": "__sensor_model_md__"}
    for k, block in enumerate(python_blocks(DOC.read_text()), start=1):
        exec(compile(block, f"docs/sensor-model.md block {k}", "exec"), namespace)
    return namespace


def _row(text: str, label: str) -> list[float]:
    """The three numbers of a row of the worked example's table (− as a minus sign)."""
    line = next(ln for ln in text.splitlines() if ln.startswith(f"| {label}"))
    cells = [c.strip().replace("−", "-") for c in line.strip("|").split("|")[1:]]
    return [float(c) for c in cells]


def test_the_worked_example_runs_and_its_table_is_what_it_computes() -> None:
    ns = _run()
    text = DOC.read_text()
    assert len(python_blocks(text)) == 2
    np.testing.assert_allclose(_row(text, "output `y`"), ns["y_dps"], rtol=0, atol=5e-13)
    np.testing.assert_allclose(_row(text, "true rate `s`"), np.degrees(ns["s"]), rtol=1e-15)
    # the laws at 30 °C are the table's scale factors
    np.testing.assert_allclose(ns["gyro"].sf[0] * 1e6, _row(text, "scale factor"), rtol=1e-12)
    # the pulses per sample at 100 Hz and 1″ per pulse, as the text gives them
    per_sample = np.asarray(ns["y"]) / (np.pi / 648000 * 100.0)
    for v in per_sample:
        assert f"{abs(v):.4f}" in text
