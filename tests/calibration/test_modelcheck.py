"""The model file's field checks (``rinscal.calibration._modelcheck``): exact keys and finite
numbers, each refusal naming the field."""

from __future__ import annotations

import math

import pytest

from rinscal.calibration._modelcheck import exact, finite


def test_exact_names_missing_and_unexpected_keys_with_their_path() -> None:
    exact({"a": 1, "b": 2}, ("a", "b"), "model")
    with pytest.raises(ValueError, match=r"missing key\(s\) model\.b$"):
        exact({"a": 1}, ("a", "b"), "model")
    with pytest.raises(ValueError, match=r"unexpected key\(s\) model\.c, model\.d"):
        exact({"a": 1, "d": 0, "c": 0}, ("a",), "model")
    with pytest.raises(ValueError, match="model must be a JSON object"):
        exact([1], ("a",), "model")


@pytest.mark.parametrize("bad", [math.nan, math.inf, "1.0", True, [1.0]])
def test_finite_refuses_what_is_not_a_finite_number(bad) -> None:
    with pytest.raises(ValueError, match="window_s must be a finite number or null"):
        finite(bad, "window_s")


def test_finite_accepts_numbers_and_null_where_allowed() -> None:
    assert finite(3, "n") == 3.0 and isinstance(finite(3, "n"), float)
    assert finite(None, "n") is None
    with pytest.raises(ValueError, match="must be a finite number, got None"):
        finite(None, "n", allow_none=False)
    with pytest.raises(ValueError, match="window_s must be positive, got 0"):
        finite(0, "window_s", positive=True)
