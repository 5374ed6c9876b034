"""The first pass's one-pass kernels (issue 39): the encoder's unwrap across pieces and the
per-second and short-block sums give the bits of the numpy expressions they replaced,
written out here independently (``numpy.unwrap`` on each piece joined to the one before,
``bincount`` of each product), whatever the wrap-around, the split into pieces, gaps, a
jittering clock or a table that is absent."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rinscal.nav.recorded.blocks import BLOCK_S, SUBS, BlockStats, TableUnwrap
from rinscal.schema import GAP_FACTOR, NavSamples


def _unwrap_pieces(pieces: list[np.ndarray]) -> np.ndarray:
    """numpy.unwrap of each piece, carried on from the one before (the pre-kernel code)."""
    raw, done, out = None, 0.0, []
    for a in pieces:
        if raw is None:
            u = np.unwrap(a)
        else:
            u = np.unwrap(np.concatenate([[raw], a]))
            u = u[1:] - u[0] + done
        raw, done = float(a[-1]), float(u[-1])
        out.append(u)
    return np.concatenate(out)


@settings(max_examples=120, deadline=None)
@given(
    seed=st.integers(0, 2**32 - 1),
    n=st.integers(2, 2000),
    step=st.sampled_from([0.01, 0.5, 2.0, 3.2, 6.0]),
    wrap=st.sampled_from(["pm180", "0-360", "none", "rounded"]),
    cuts=st.integers(0, 6),
)
def test_unwrap_across_pieces_is_numpys_to_the_bit(
    seed: int, n: int, step: float, wrap: str, cuts: int
) -> None:
    rng = np.random.default_rng(seed)
    angle = np.cumsum(rng.normal(scale=step, size=n)) + rng.uniform(-10.0, 10.0)
    if wrap == "pm180":
        a = (angle + np.pi) % (2 * np.pi) - np.pi
    elif wrap == "0-360":
        a = angle % (2 * np.pi)
    elif wrap == "rounded":  # steps of exactly half a turn occur
        a = np.round(angle / np.pi) * np.pi
    else:
        a = angle
    at = np.sort(rng.choice(np.arange(1, n), size=min(cuts, n - 1), replace=False))
    pieces = np.split(a, at)
    un = TableUnwrap()
    got = np.concatenate([un(p) for p in pieces])
    np.testing.assert_array_equal(got, _unwrap_pieces(pieces))
    # and it is an unwrap: no step of more than half a turn is left
    assert np.all(np.abs(np.diff(got)) <= np.pi + 1e-12)


def _reference(pieces: list[NavSamples]) -> dict[str, np.ndarray]:
    """The per-second sums with numpy alone, as the first pass summed them before its
    kernel: each piece's sums by ``bincount`` of each product in the samples' order (first
    differences across pieces), then a second split between pieces as the sum of its parts."""
    origin = float(pieces[0].t[0] - pieces[0].dt[0])
    parts: dict[str, list[np.ndarray]] = {}
    prev_w = prev_f = None
    for s in pieces:
        w, f = s.dtheta / s.dt[:, None], s.dv / s.dt[:, None]
        fm = np.sqrt(np.einsum("ij,ij->i", f, f))
        ids = np.floor((s.t - 0.5 * s.dt - origin) / BLOCK_S).astype(np.int64)
        lo = int(ids[0])
        k = ids - lo
        m = int(k[-1]) + 1
        dw = np.diff(w, axis=0, prepend=w[:1] if prev_w is None else prev_w)
        df = np.diff(f, axis=0, prepend=f[:1] if prev_f is None else prev_f)
        prev_w, prev_f = w[-1:], f[-1:]

        def bc(x: np.ndarray, k: np.ndarray = k, m: int = m) -> np.ndarray:
            return np.bincount(k, weights=x, minlength=m)

        for key, x in {
            "id": np.arange(lo, lo + m),
            "n": bc(np.ones_like(fm)),
            "fm": bc(fm),
            "f": np.stack([bc(f[:, j]) for j in range(3)], 1),
            "w": np.stack([bc(w[:, j]) for j in range(3)], 1),
            "df2": np.stack([bc(df[:, j] * df[:, j]) for j in range(3)], 1),
            "dw2": np.stack([bc(dw[:, j] * dw[:, j]) for j in range(3)], 1),
            "t1": np.array([s.t[k == b].max() if (k == b).any() else -np.inf for b in range(m)]),
        }.items():
            parts.setdefault(key, []).append(x)
    ids = np.concatenate(parts.pop("id"))
    u, inv = np.unique(ids, return_inverse=True)
    cat = {key: np.concatenate(v) for key, v in parts.items()}

    def merge(x: np.ndarray) -> np.ndarray:
        if x.ndim == 1:
            return np.bincount(inv, weights=x, minlength=u.size)
        return np.stack([np.bincount(inv, weights=x[:, j], minlength=u.size) for j in range(3)], 1)

    n = merge(cat["n"])
    t1 = np.full(u.size, -np.inf)
    np.maximum.at(t1, inv, cat["t1"])
    return {
        "n": n,
        "fmag_mean": merge(cat["fm"]) / n,
        "f_mean": merge(cat["f"]) / n[:, None],
        "w_mean": merge(cat["w"]) / n[:, None],
        "f_dvar": 0.5 * merge(cat["df2"]) / n[:, None],
        "w_dvar": 0.5 * merge(cat["dw2"]) / n[:, None],
        "t1": t1,
    }


@pytest.mark.parametrize("table", [True, False])
@pytest.mark.parametrize("seed", [0, 1])
def test_second_sums_are_numpys_to_the_bit(table: bool, seed: int) -> None:
    """A 100 Hz recording with a jittering clock and a gap, a table turning through the
    ±180° wrap, split into uneven pieces: every per-second sum is the numpy reference's."""
    rng = np.random.default_rng(seed)
    n = 9000
    dt = np.full(n, 0.01) + rng.uniform(-0.002, 0.002, n)
    dt[4000] = 0.5  # a gap
    t = 100.0 + np.cumsum(dt)
    w = np.array([1e-5, -2e-5, 3e-4]) + rng.normal(scale=1e-4, size=(n, 3))
    f = np.array([0.01, -0.02, 9.8]) + rng.normal(scale=0.01, size=(n, 3))
    angle = (np.cumsum(w[:, 2] * dt) + 3.0 + np.pi) % (2 * np.pi) - np.pi
    cuts = [0, 1234, 1235, 5000, 7777, n]
    pieces = [
        NavSamples(
            t=t[a:b],
            dt=dt[a:b],
            dtheta=w[a:b] * dt[a:b, None],
            dv=f[a:b] * dt[a:b, None],
            first_row=a + 1,
            table=angle[a:b] if table else None,
        )
        for a, b in itertools.pairwise(cuts)
    ]
    stats = BlockStats()
    for s in pieces:
        stats.add(s)
    blocks = stats.finish()
    ref = _reference(pieces)
    for key, want in ref.items():
        np.testing.assert_array_equal(getattr(blocks, key), want, err_msg=key)
    assert blocks.gaps is not None and blocks.gaps.sum() == 1
    assert blocks.dt < GAP_FACTOR * 0.01
    # the encoder's turn per second is the table's, unwrapped
    if table:
        total = float(np.sum(blocks.table_turn))
        assert total == pytest.approx(float(np.sum(w[1:, 2] * dt[1:])), abs=1e-9)
    # the short blocks: SUBS a second, their mean force that of the second
    assert blocks.f_dev is not None and np.all(np.isfinite(blocks.f_dev[blocks.n >= 2 * SUBS]))
    assert math.isfinite(float(blocks.fmag_sd.max()))
