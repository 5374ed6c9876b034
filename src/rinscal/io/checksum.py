"""The checksum of rinscal's JSON files (model files, ``imu.json``): SHA-256 of a canonical
JSON text, so that an edit anywhere in what it covers is found on reading.

The canonical text is ``json.dumps(payload, sort_keys=True, separators=(",", ":"),
ensure_ascii=True, allow_nan=False)``: key order and whitespace do not count, every value
does. This module imports the standard library only (a model file is loaded with numpy
alone).
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from typing import Any

__all__ = ["canonical_json", "payload_sha256"]


def canonical_json(payload: Any) -> bytes:
    """The canonical JSON text of ``payload`` (ASCII bytes).

    Raises
    ------
    ValueError
        A NaN or an infinity in it; TypeError for a value JSON cannot hold.
    """
    return json.dumps(
        payload, sort_keys=True, separators=(",", ":"), ensure_ascii=True, allow_nan=False
    ).encode("ascii")


def payload_sha256(payload: Mapping[str, Any]) -> str:
    """SHA-256 hex digest (64 lowercase hex digits) of the canonical JSON of a payload."""
    return hashlib.sha256(canonical_json(payload)).hexdigest()
