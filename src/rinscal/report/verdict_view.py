"""The verdict that opens both reports, its paragraph, the CLI's lines and ``claims.csv``.

Each takes the claims frame of the one rule (:mod:`rinscal.experiments.verdict`; rows made
by :func:`rinscal.experiments.paper.claims.paired_claims` for the reproduction and
:func:`rinscal.experiments.study.compare.study_claims` for a study) and, for the table,
the mean maximum position error of each method per plant and group of runs [nmi].
Nothing here computes a statistic; :func:`write_claims_csv` is the only I/O.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import pandas as pd

from rinscal.experiments.paper.claims import PAPER_PAIRS
from rinscal.experiments.verdict import (
    CLAIMS_COLUMNS,
    CONFIDENCE,
    HOLDS,
    REVERSED,
    TOO_FEW,
    UNRESOLVED,
    change_words,
    too_few,
)
from rinscal.io.atomic import write_atomic

__all__ = [
    "REFERENCES",
    "claim_words",
    "claims_lines",
    "claims_view",
    "verdict_paragraph",
    "verdict_table",
    "write_claims_csv",
]

#: The references of the verdict table's columns, with their headers.
REFERENCES = {
    "sectional": "vs method 1",
    "none": "vs none",
    "poly-t": "vs cubic in T",
}
#: Short names of the variants in the verdict table and paragraph.
_NAMES = {
    "none": "no compensation",
    "poly-t": "cubic in T",
    "sectional": "method 1",
    "regression": "method 2",
    "neural": "method 3",
    "true": "oracle",
    "regression+sf": "method 2 + scale factor/axes",
    "regression-no-dT": "method 2 without ΔT",
}


def _name(v: str) -> str:
    return _NAMES.get(v, v)


def _sg(x: float, nd: int) -> str:
    """``+0.12`` / ``−0.12`` (a true minus sign), ``+0.00`` for a small positive bound;
    ``0.00`` for zero (to rounding of the sums, 1e-12)."""
    return f"{0.0:.{nd}f}" if abs(x) < 1e-12 else f"{x:+.{nd}f}".replace("-", "−")


def _mean_cell(mean: float, lo: float, hi: float) -> str:
    """``0.48 [0.31, 0.65]``, or ``0.48 (no interval)`` below the rule's minimum n."""
    if not math.isfinite(mean):
        return ""
    m = f"{mean:.2f}"
    if math.isfinite(lo) and math.isfinite(hi):
        return f"{m} [{lo:.2f}, {hi:.2f}]".replace("-", "−")
    return f"{m} (no interval)"


def _where(plant: str, group: str, plants: int) -> str:
    return f"{plant} · {group}" if plants > 1 else str(group)


def verdict_table(means: pd.DataFrame, claims: pd.DataFrame, what: str = "runs") -> pd.DataFrame:
    """The verdict table: per plant, group and method, the maximum position error's mean
    with its 95 % interval [nmi] and the verdict on "method better than" method 1, no
    compensation and the cubic in T, with the paired mean difference [nmi].

    Parameters
    ----------
    means : DataFrame
        ``plant, group, method, n, mean, lo, hi`` [nmi] (the oracle is left out).
    claims : DataFrame
        The claims frame (``plant, group, method, reference, n, mean_nmi, verdict``).
    what : str
        What ``n`` counts (``"runs"``, ``"units"``).
    """
    plants = means["plant"].nunique() if not means.empty else 0
    key = claims.set_index(["plant", "group", "method", "reference"]) if len(claims) else None
    rows = []
    last = None
    for _, r in means.iterrows():
        if r["method"] == "true":
            continue
        where = _where(r["plant"], r["group"], plants)
        row = {
            # a group's name on its first row only
            "runs" if what == "runs" else "plant · scenario": "" if where == last else where,
            "method": _name(r["method"]),
            f"n ({what})": int(r["n"]),
            f"max error [nmi]: mean [{CONFIDENCE:.0%} interval]": _mean_cell(
                r["mean"], r["lo"], r["hi"]
            ),
        }
        for ref, head in REFERENCES.items():
            k = (r["plant"], r["group"], r["method"], ref)
            if key is None or k not in key.index:
                row[head] = ""
                continue
            c = key.loc[k]
            d = f" ({_sg(float(c['mean_nmi']), 2)})" if math.isfinite(c["mean_nmi"]) else ""
            row[head] = f"{c['verdict']}{d}"
        rows.append(row)
        last = where
    return pd.DataFrame(rows)


def claim_words(c: pd.Series, what: str) -> str:
    """``holds: −0.12 nmi [−0.20, −0.05], 38 % less`` for one claim row."""
    v = str(c["verdict"])
    if v == TOO_FEW:
        return too_few(int(c["n"]), what if what != "runs" else "")
    ci = f"{_sg(c['mean_nmi'], 2)} nmi [{_sg(c['ci_low_nmi'], 2)}, {_sg(c['ci_high_nmi'], 2)}]"
    change = change_words(c["mean_reference_nmi"], c["mean_method_nmi"])
    return f"{v}: {ci}" + (f", mean error {change}" if change else "")


def _group_sentence(g: pd.DataFrame, what: str) -> str:
    """The paper's comparisons of one plant and group in words, then which methods beat no
    compensation and the cubic in T."""
    c = g.set_index(["method", "reference"])
    parts = []
    for m, ref in PAPER_PAIRS:
        if (m, ref) in c.index:
            parts.append(
                f"{_name(m)} better than {_name(ref)}: {claim_words(c.loc[(m, ref)], what)}"
            )
    for ref in ("none", "poly-t"):
        h = g[g["reference"] == ref]
        if h.empty:
            continue
        by = {v: [_name(m) for m, x in zip(h["method"], h["verdict"], strict=True) if x == v]
              for v in (HOLDS, REVERSED, UNRESOLVED, TOO_FEW)}  # fmt: skip
        bits = [f"{v} for {', '.join(ms)}" for v, ms in by.items() if ms]
        parts.append(f"against {_name(ref)}: " + "; ".join(bits))
    n = int(g["n"].max())
    return f"On {g['plant'].iloc[0]}, {g['group'].iloc[0]} (n = {n} {what}): " + "; ".join(parts)


def verdict_paragraph(claims: pd.DataFrame, what: str = "runs", detail: int = 2) -> str:
    """One paragraph from the claims frame: the paper's comparisons and the methods against
    no compensation and the cubic in T for the first ``detail`` plant · group pairs, then
    how many claims of every group hold, are reversed, unresolved or lack runs."""
    if claims.empty:
        return "No claim could be tested: no navigation run has finished."
    groups = list(claims.groupby(["plant", "group"], sort=False))
    sentences = [_group_sentence(g, what) for _, g in groups[:detail]]
    k = claims["verdict"].value_counts()
    tally = (
        f"Over all {len(claims)} claims of {len(groups)} group(s) (the table, claims.csv): "
        f"{int(k.get(HOLDS, 0))} hold, {int(k.get(REVERSED, 0))} are reversed, "
        f"{int(k.get(UNRESOLVED, 0))} show no resolved difference, "
        f"{int(k.get(TOO_FEW, 0))} have not enough {what} for an interval."
    )
    head = (
        "Each claim reads 'method better than reference', tested on the paired difference "
        f"method − reference [nmi] and its {CONFIDENCE:.0%} Student-t interval "
        f"(negative: the method has less error). "
    )
    return head + ". ".join(sentences) + ". " + tally


def claims_view(claims: pd.DataFrame, what: str = "runs") -> pd.DataFrame:
    """Claims as a table: where, the claim, ``n``, the paired mean difference method −
    reference [nmi] with its interval, the count where the method is better, the change of
    the mean error (a description) and the verdict."""
    plants = claims["plant"].nunique() if not claims.empty else 0
    return pd.DataFrame(
        {
            "runs" if what == "runs" else "plant · scenario": [
                _where(p, g, plants) for p, g in zip(claims["plant"], claims["group"], strict=True)
            ],
            "claim": claims["claim"],
            f"n ({what})": claims["n"].astype(int),
            "Δ mean [nmi]": [_sg(x, 3) for x in claims["mean_nmi"]],
            f"{CONFIDENCE:.0%} interval [nmi]": [
                f"[{_sg(lo, 3)}, {_sg(hi, 3)}]" if math.isfinite(lo) and math.isfinite(hi) else ""
                for lo, hi in zip(claims["ci_low_nmi"], claims["ci_high_nmi"], strict=True)
            ],
            "better in": [
                f"{int(k)} of {int(n)}" for k, n in zip(claims["better"], claims["n"], strict=True)
            ],
            "mean error": [
                change_words(a, b)
                for a, b in zip(
                    claims["mean_reference_nmi"], claims["mean_method_nmi"], strict=True
                )
            ],
            "verdict": [
                too_few(int(n), "" if what == "runs" else what) if v == TOO_FEW else v
                for v, n in zip(claims["verdict"], claims["n"], strict=True)
            ],
        }
    )


def claims_lines(claims: pd.DataFrame, what: str = "runs") -> list[str]:
    """One line per claim for a console: ``plant · group: claim — verdict: Δ [interval]``."""
    return [
        f"{c['plant']} · {c['group']}: {c['claim']} — {claim_words(c, what)}"
        for _, c in claims.iterrows()
    ]


def write_claims_csv(path: Path, claims: pd.DataFrame) -> None:
    """Write ``claims.csv`` atomically: exactly :data:`CLAIMS_COLUMNS`, in that order."""
    cols: Sequence[str] = list(CLAIMS_COLUMNS)
    df = claims.reindex(columns=cols)
    write_atomic(path, lambda tmp: df.to_csv(tmp, index=False))
