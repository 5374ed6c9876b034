"""Properties of thermal compensation and model files.

- compensation never drops, adds or reorders rows, and never touches other columns;
- a model file round trip gives bit-identical predictions, for any finite parameters;
- every corruption tried (truncation, a changed digit, a wrong schema version, a deleted
  key) gives a ModelFileError, unless it left the file's content unchanged.
"""

from __future__ import annotations

import copy
import functools
import json
import math

import numpy as np
import pandas as pd
from hypothesis import HealthCheck, assume, example, given, settings
from hypothesis import strategies as st

from rinscal.calibration.compensate import FLAG_COLUMN, compensate
from rinscal.calibration.modelfile import (
    READABLE_VERSIONS,
    ChannelModel,
    ThermalModelFile,
    payload_sha256,
)
from rinscal.calibration.thermal.model import ThermalModel
from rinscal.errors import ModelFileError
from rinscal.schema import CHANNELS
from rinscal.units import SENSOR_TYPE_UNITS, SENSOR_UNITS

METRICS = {
    "rms_train": 1.0,
    "rms_train_about_run_mean": 1.0,
    "n_train": 10.0,
    "n_outliers": 0.0,
    "n_runs": 2.0,
}


def _train_log() -> pd.DataFrame:
    rng = np.random.default_rng(0)
    frames = []
    for k in range(3):
        t = np.arange(1.0, 301.0)
        temp = 10.0 + 10 * k + 8 * (1 - np.exp(-t / 100))
        cols: dict[str, object] = {
            "time_s": t,
            "run": f"r{k}",
            "temp_in": temp,
            "temp_out": temp - 1 + 0.5 * np.exp(-t / 60),
        }
        for j, c in enumerate(CHANNELS):
            cols[c] = 100 * j + 0.3 * temp + 0.01 * temp**2 + rng.normal(0, 0.01, t.size)
        frames.append(pd.DataFrame(cols))
    return pd.concat(frames, ignore_index=True)


@functools.cache
def _model(method: str) -> ThermalModelFile:
    params = {"max_samples": 500, "n_init": 1, "max_iter": 100, "refine_max_nfev": 5}
    return (
        ThermalModel(method, estimator_params=params if method == "neural" else None)
        .fit(_train_log())
        .to_file()
    )


@st.composite
def logs(draw) -> pd.DataFrame:
    n_runs = draw(st.integers(1, 3))
    frames = []
    for k in range(n_runs):
        n = draw(st.integers(2, 40))
        steps = draw(st.lists(st.floats(0.01, 30.0), min_size=n, max_size=n))
        t = np.cumsum(steps)
        base = draw(st.floats(-20, 70))
        slope = draw(st.floats(-0.05, 0.05))
        cols: dict[str, object] = {"time_s": t, "run": f"run{k}"}
        temp = base + slope * t
        cols["temp_in"] = temp
        cols["temp_out"] = temp - draw(st.floats(-3, 3))
        for c in CHANNELS:
            vals = draw(
                st.lists(
                    st.one_of(st.floats(-1e6, 1e6), st.just(float("nan"))),
                    min_size=n,
                    max_size=n,
                )
            )
            cols[c] = np.asarray(vals, dtype=float)
        cols["extra"] = [f"x{i}" for i in range(n)]
        frames.append(pd.DataFrame(cols))
    log = pd.concat(frames, ignore_index=True)
    if draw(st.booleans()):  # interleave the runs, each run keeping its own order
        labels = log["run"].to_numpy()
        slots = draw(st.permutations(list(labels)))
        pos = {r: iter(np.flatnonzero(labels == r)) for r in dict.fromkeys(labels)}
        log = log.iloc[[next(pos[r]) for r in slots]]
    offset = draw(st.integers(-5, 5))
    log.index = np.arange(len(log)) * 3 + offset
    return log


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    log=logs(),
    method=st.sampled_from(["poly-t", "sectional", "regression", "neural"]),
    policy=st.sampled_from(["clamp", "extrapolate"]),
)
def test_compensation_keeps_every_row_in_order(log, method, policy) -> None:
    before = log.copy()
    out = compensate(log, _model(method), policy=policy)
    pd.testing.assert_frame_equal(log, before)
    assert len(out) == len(log)
    pd.testing.assert_index_equal(out.index, log.index)
    assert list(out.columns) == [*log.columns, FLAG_COLUMN]
    for c in ("time_s", "run", "temp_in", "temp_out", "extra"):
        pd.testing.assert_series_equal(out[c], log[c])
    for c in CHANNELS:
        np.testing.assert_array_equal(out[c].isna(), log[c].isna())


finite = st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False)
positive = st.floats(1e-3, 1e3)


@st.composite
def channel_params(draw, method: str) -> dict:
    if method == "poly-t":
        return {
            "method": method,
            "t_ref": draw(finite),
            "coef": draw(st.lists(finite, min_size=1, max_size=4)),
        }
    if method == "regression":
        orders = draw(st.lists(st.integers(0, 4), min_size=3, max_size=3))
        return {
            "method": method,
            "orders": orders,
            "center": draw(st.lists(finite, min_size=3, max_size=3)),
            "scale": draw(st.lists(positive, min_size=3, max_size=3)),
            "intercept": draw(finite),
            "coef": [draw(st.lists(finite, min_size=o, max_size=o)) for o in orders],
        }
    if method == "sectional":
        k = draw(st.integers(1, 4))
        edges = sorted(set(draw(st.lists(finite, min_size=k - 1, max_size=k - 1))))
        k = len(edges) + 1
        orders = draw(st.lists(st.integers(0, 3), min_size=2, max_size=2))
        return {
            "method": method,
            "orders": orders,
            "edges": edges,
            "center": [draw(st.lists(finite, min_size=2, max_size=2)) for _ in range(k)],
            "scale": [draw(st.lists(positive, min_size=2, max_size=2)) for _ in range(k)],
            "intercept": draw(st.lists(finite, min_size=k, max_size=k)),
            "coef": [
                [draw(st.lists(finite, min_size=o, max_size=o)) for o in orders] for _ in range(k)
            ],
        }
    n = draw(st.integers(1, 4))
    return {
        "method": method,
        "x_mean": draw(st.lists(finite, min_size=3, max_size=3)),
        "x_scale": draw(st.lists(positive, min_size=3, max_size=3)),
        "W": [draw(st.lists(st.floats(-5, 5), min_size=3, max_size=3)) for _ in range(n)],
        "b": draw(st.lists(st.floats(-5, 5), min_size=n, max_size=n)),
        "v": draw(st.lists(finite, min_size=n, max_size=n)),
        "b_out": draw(finite),
        "y_mean": draw(finite),
        "y_scale": draw(positive),
    }


@st.composite
def model_files(draw) -> ThermalModelFile:
    method = draw(st.sampled_from(["poly-t", "sectional", "regression", "neural"]))
    channels = tuple(draw(st.lists(st.sampled_from(CHANNELS), min_size=1, max_size=6, unique=True)))
    models = {}
    for c in channels:
        params = draw(channel_params(method))
        k = {"poly-t": 1, "sectional": 2}.get(method, 3)
        lo = np.array(draw(st.lists(finite, min_size=k, max_size=k)))
        # a unit of the channel's sensor type with its own SI value, or pulses (any weight)
        unit = draw(st.sampled_from([None, *SENSOR_TYPE_UNITS[c.partition("_")[0]]]))
        named = SENSOR_UNITS.get(unit or "")
        models[c] = ChannelModel(
            params=params,
            train_range=np.column_stack([lo, lo + 10.0]),
            unit=unit,
            unit_to_si=draw(st.one_of(st.none(), positive if named is None else st.just(named))),
            static_reference=draw(st.one_of(st.none(), finite)),
            segment_edges=draw(st.one_of(st.none(), st.just(np.array([3.5, 10.5])))),
            metrics=METRICS,
        )
    return ThermalModelFile(
        method=method,
        channels=channels,
        models=models,
        derivative_window_s=draw(positive),
        derivative_kind=draw(st.sampled_from(["centred", "causal"])),
        use_gradient=True,
        source={"runs": ["a"]},
    )


@settings(max_examples=60, deadline=None)
@given(mf=model_files(), seed=st.integers(0, 2**32 - 1))
def test_round_trip_gives_identical_predictions(mf, seed) -> None:
    back = ThermalModelFile.loads(mf.dumps())
    rng = np.random.default_rng(seed)
    x = np.column_stack([rng.uniform(-50, 100, 64), rng.normal(0, 2, 64), rng.normal(0, 3, 64)])
    for c in mf.channels:
        with np.errstate(all="ignore"):
            a, fa = mf.predict_channel(c, x)
            b, fb = back.predict_channel(c, x)
        np.testing.assert_array_equal(a, b)
        np.testing.assert_array_equal(fa, fb)
    assert back.dumps() == mf.dumps()


_TEXT = _model("sectional").dumps()
_DOC = json.loads(_TEXT)


def _loads_or_same(text: str) -> None:
    """Loading must fail with ModelFileError unless the content is unchanged."""
    try:
        doc = json.loads(text)
    except ValueError:
        doc = None
    try:
        ThermalModelFile.loads(text)
    except ModelFileError:
        return
    assert doc == _DOC, "a corrupted model file was accepted"


@settings(max_examples=150, deadline=None)
@given(cut=st.integers(0, len(_TEXT) - 1))
def test_truncated_file_is_refused(cut) -> None:
    _loads_or_same(_TEXT[:cut])


@settings(max_examples=150, deadline=None)
@given(data=st.data())
def test_changed_digit_is_refused(data) -> None:
    positions = [i for i, ch in enumerate(_TEXT) if ch.isdigit()]
    i = data.draw(st.sampled_from(positions))
    new = data.draw(st.sampled_from([d for d in "0123456789" if d != _TEXT[i]]))
    _loads_or_same(_TEXT[:i] + new + _TEXT[i + 1 :])


@settings(max_examples=30, deadline=None)
@given(version=st.one_of(st.integers(), st.text(max_size=3), st.none(), st.floats()))
@example(version=float("inf"))
@example(version=float("nan"))
@example(version=1.0)
@example(version=True)
@example(version="1")
def test_wrong_schema_version_is_refused(version) -> None:
    assume(version not in READABLE_VERSIONS or isinstance(version, (float, bool)))
    doc = copy.deepcopy(_DOC)
    doc["schema_version"] = version
    text = json.dumps(doc)  # inf and nan become Infinity and NaN, which JSON does not have
    try:
        ThermalModelFile.loads(text)
    except ModelFileError as exc:
        # refused for the version, or (inf, nan) as invalid JSON before the version is read
        finite = not isinstance(version, float) or math.isfinite(version)
        assert "schema_version" in str(exc) if finite else "non-finite" in str(exc), str(exc)
    else:
        raise AssertionError(f"schema_version {version!r} accepted")


def _key_paths(obj, prefix=()):
    if isinstance(obj, dict):
        for k, v in obj.items():
            if prefix[:1] == ("source",) or prefix[-1:] == ("source",):
                continue  # free-form provenance: checksummed, not validated
            yield (*prefix, k)
            yield from _key_paths(v, (*prefix, k))
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            yield from _key_paths(v, (*prefix, i))


_PATHS = [p for p in _key_paths(_DOC) if "source" not in p[:2]]


@settings(max_examples=120, deadline=None)
@given(path=st.sampled_from(_PATHS), fix_checksum=st.booleans())
def test_deleted_key_is_refused(path, fix_checksum) -> None:
    doc = copy.deepcopy(_DOC)
    node = doc
    for k in path[:-1]:
        node = node[k]
    del node[path[-1]]
    if fix_checksum and path != ("sha256",) and isinstance(doc.get("payload"), dict):
        doc["sha256"] = payload_sha256(doc["payload"])
    try:
        ThermalModelFile.loads(json.dumps(doc))
    except ModelFileError:
        return
    raise AssertionError(f"deleting {'/'.join(map(str, path))} was accepted")
