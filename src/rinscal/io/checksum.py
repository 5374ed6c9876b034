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
import re
from collections.abc import Mapping
from typing import Any

__all__ = ["canonical_json", "checksum_problem", "payload_sha256"]

_HEX64 = re.compile(r"[0-9a-f]{64}")


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


def checksum_problem(digest: Any, payload: Any) -> str | None:
    """What is wrong with a file's ``sha256`` against the payload it covers, in words (None:
    nothing, the digest is the payload's).

    Both rinscal JSON files (model files, ``imu.json``) check theirs with this, and wrap the
    answer in their own error naming the file.
    """
    if not isinstance(digest, str) or not _HEX64.fullmatch(digest):
        return f"sha256 must be 64 lowercase hex digits (got {digest!r})"
    try:
        actual = payload_sha256(payload)
    except (ValueError, TypeError) as exc:
        return f"the content cannot be checksummed: {exc}"
    if actual != digest:
        return (
            f"checksum mismatch: the content's sha256 is {actual[:12]}..., the file says "
            f"{digest[:12]}...; the file was edited or corrupted after it was written"
        )
    return None
