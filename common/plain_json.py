"""Turn caller data into strict, repr-exact JSON, naming the field that cannot be stored.

Floats are written with Python's ``repr`` (the shortest text that parses back to the same float64),
so every float reads back bit-exact. NaN and infinity are refused: they are not JSON.
"""
from __future__ import annotations

import json
import math
from typing import Any

import numpy as np


def to_plain(value: Any, name: str) -> Any:
    """Return ``value`` as JSON types (dict, list, str, int, float, bool, None).

    numpy arrays become (nested) lists, numpy scalars Python scalars, tuples lists.

    Raises
    ------
    ValueError
        When a float is not finite or a value has no JSON form; the message names the field
        (``name`` with its dict keys and list indices appended).
    """
    if value is None or isinstance(value, (bool, str)):
        return value
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        number = float(value)
        if not math.isfinite(number):
            raise ValueError(f"{name} must be finite, got {number!r}")
        return number
    if isinstance(value, np.ndarray):
        if value.dtype.kind not in "biuf":
            raise ValueError(f"{name}: cannot store an array of dtype {value.dtype}")
        return [to_plain(item, f"{name}[{i}]") for i, item in enumerate(value.tolist())]
    if isinstance(value, (list, tuple)):
        return [to_plain(item, f"{name}[{i}]") for i, item in enumerate(value)]
    if isinstance(value, dict):
        plain = {}
        for key, item in value.items():
            if not isinstance(key, str):
                raise ValueError(f"{name}: keys must be strings, got {key!r}")
            plain[key] = to_plain(item, f"{name}[{key!r}]")
        return plain
    raise ValueError(f"{name}: cannot store a value of type {type(value).__name__} in JSON")


def dumps_line(record: dict) -> str:
    """One compact JSON line (ASCII, no newline) for a record already made plain."""
    return json.dumps(record, allow_nan=False, separators=(",", ":"))
