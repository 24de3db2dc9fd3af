"""One record <-> one line: validation on the way in, parsing with file/line errors on the way out.

CSV rows and JSON values are written with Python's float ``repr``, the shortest text that parses
back to the same float64, so every value reads back bit-exact.
"""
from __future__ import annotations

import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np

from explorer.session.errors import SessionFormatError
from common.plain_json import to_plain
from explorer.session.records import Event
from sensor.oriented_contact import OrientedContact
from sensor.reading import Reading

NORMAL_NORM_TOLERANCE = 1e-6
EVENT_KIND_PATTERN = re.compile(r"[a-z][a-z0-9_]*\Z")


# ---------------------------------------------------------------------------- validation helpers
def as_float(value: Any, name: str, finite: bool = True) -> float:
    """``value`` as a Python float; ValueError naming ``name`` when it is not a (finite) number."""
    if isinstance(value, (bool, np.bool_, str, bytes)) or not isinstance(
        value, (int, float, np.integer, np.floating)
    ):
        raise ValueError(f"{name} must be a number, got {value!r}")
    number = float(value)
    if finite and not math.isfinite(number):
        raise ValueError(f"{name} must be finite, got {number!r}")
    return number


def as_vector(value: Any, shape: tuple[int, ...], name: str, finite: bool = True) -> np.ndarray:
    """``value`` as a float64 array of ``shape``; ValueError naming ``name`` otherwise."""
    try:
        array = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{name} must be numeric with shape {shape}: {error}") from None
    if array.shape != shape:
        raise ValueError(f"{name} must have shape {shape}, got {array.shape}")
    if finite and not np.all(np.isfinite(array)):
        raise ValueError(f"{name} must be finite, got {array.tolist()}")
    return array


def as_count(value: Any, name: str) -> int:
    """``value`` as a non-negative int; ValueError naming ``name`` otherwise."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise ValueError(f"{name} must be an integer, got {value!r}")
    if value < 0:
        raise ValueError(f"{name} must be >= 0, got {value}")
    return int(value)


def csv_row(values: list[float]) -> str:
    """Comma-separated repr-exact floats (``nan``/``inf`` for non-finite values)."""
    return ",".join(repr(float(v)) for v in values)


# ---------------------------------------------------------------------------- encoding
def encode_reading(reading: Reading) -> tuple[float, str]:
    """Validate ``reading``; return its time stamp and its ``readings.csv`` row.

    The time stamp must be finite; the channels are raw measurements and are stored as they are,
    non-finite values included.
    """
    if not isinstance(reading, Reading):
        raise TypeError(f"write_reading expects a sensor.reading.Reading, got {type(reading).__name__}")
    t_s = as_float(reading.t_s, "reading.t_s")
    values = [
        t_s,
        as_float(reading.pressure_pa, "reading.pressure_pa", finite=False),
        *as_vector(reading.quat_wxyz, (4,), "reading.quat_wxyz", finite=False).tolist(),
        *as_vector(reading.lin_acc_mps2, (3,), "reading.lin_acc_mps2", finite=False).tolist(),
        *as_vector(reading.gravity_mps2, (3,), "reading.gravity_mps2", finite=False).tolist(),
        as_float(reading.temperature_c, "reading.temperature_c", finite=False),
    ]
    return t_s, csv_row(values)


def encode_joint_state(t_s: float, q: Any, dof: int | None) -> tuple[float, np.ndarray, str]:
    """Validate one joint state; return ``(t_s, q, row)``. ``dof=None`` accepts any ``(dof,)``."""
    t_s = as_float(t_s, "t_s")
    try:
        q = np.asarray(q, dtype=np.float64)
    except (TypeError, ValueError) as error:
        raise ValueError(f"q must be numeric: {error}") from None
    if q.ndim != 1 or q.size == 0:
        raise ValueError(f"q must have shape (dof,) with dof >= 1, got {q.shape}")
    if dof is not None and q.shape != (dof,):
        raise ValueError(f"q must have shape ({dof},) like the session's earlier joint states, got {q.shape}")
    return t_s, q, csv_row([t_s, *q.tolist()])


def encode_contact(contact: OrientedContact) -> dict:
    """Validate ``contact``; return its ``contacts.jsonl`` record (readings referenced by time)."""
    if not isinstance(contact, OrientedContact):
        raise TypeError(
            f"write_contact expects a sensor.oriented_contact.OrientedContact, got {type(contact).__name__}"
        )
    t_s = as_float(contact.t_s, "contact.t_s")
    position_m = as_vector(contact.position_m, (3,), "contact.position_m")
    normal = as_vector(contact.normal, (3,), "contact.normal")
    norm = float(np.linalg.norm(normal))
    if abs(norm - 1.0) > NORMAL_NORM_TOLERANCE:
        raise ValueError(f"contact.normal must be a unit vector, its norm is {norm!r}")
    force_n = as_float(contact.force_n, "contact.force_n")
    readings = tuple(contact.readings)
    for i, reading in enumerate(readings):
        if not isinstance(reading, Reading):
            raise TypeError(f"contact.readings[{i}] must be a Reading, got {type(reading).__name__}")
    times = [as_float(r.t_s, f"contact.readings[{i}].t_s") for i, r in enumerate(readings)]
    if any(later < earlier for earlier, later in zip(times, times[1:])):
        raise ValueError("contact.readings must be in time order")
    return {
        "t_s": t_s,
        "position_m": position_m.tolist(),
        "normal": normal.tolist(),
        "force_n": force_n,
        "readings_t_s": [times[0], times[-1]] if times else None,
        "n_readings": len(times),
    }


def _vector3_field(value: Any, name: str) -> None:
    as_vector(value, (3,), name)


def _text_field(value: Any, name: str) -> None:
    if not isinstance(value, str) or not value:
        raise ValueError(f"{name} must be a non-empty string, got {value!r}")


STANDARD_EVENT_FIELDS = {
    "contact_start": {},
    "contact_end": {},
    "touch": {"target_m": _vector3_field, "approach_dir": _vector3_field},
    "miss": {"target_m": _vector3_field, "approach_dir": _vector3_field},
    "error": {"source": _text_field, "message": _text_field},
}
"""Standard event kinds and the fields each must carry (any kind may carry more fields)."""


def encode_event(kind: str, t_s: float, fields: dict) -> dict:
    """Validate an event; return its ``events.jsonl`` record ``{"t_s", "kind", **fields}``."""
    if not isinstance(kind, str) or not EVENT_KIND_PATTERN.match(kind):
        raise ValueError(f"event kind must be a lower-case identifier like 'touch', got {kind!r}")
    t_s = as_float(t_s, "t_s")
    for field_name, check in STANDARD_EVENT_FIELDS.get(kind, {}).items():
        if field_name not in fields:
            raise ValueError(f"a {kind!r} event needs the field {field_name!r}")
        check(fields[field_name], f"{kind} event field {field_name!r}")
    record = {"t_s": t_s, "kind": kind}
    for field_name, value in fields.items():
        record[field_name] = to_plain(value, f"event field {field_name!r}")
    return record


# ---------------------------------------------------------------------------- decoding
def parse_csv_table(path: Path, lines: list[str], columns: tuple[str, ...]) -> np.ndarray:
    """Rows of a CSV file whose complete ``lines`` start with the header ``columns``.

    Returns
    -------
    (n, len(columns)) float
        One row per record line; empty when the file has no complete header line.
    """
    if not lines:
        return np.empty((0, len(columns)))
    if lines[0] != ",".join(columns):
        raise SessionFormatError(path, 1, f"header must be {','.join(columns)!r}, got {lines[0]!r}")
    rows = [line.split(",") for line in lines[1:]]
    for offset, row in enumerate(rows):
        if len(row) != len(columns):
            raise SessionFormatError(
                path, offset + 2, f"expected {len(columns)} comma-separated values, got {len(row)}"
            )
    try:
        return np.array(rows, dtype=np.float64).reshape(-1, len(columns))
    except ValueError:
        pass
    for offset, row in enumerate(rows):
        try:
            [float(value) for value in row]
        except ValueError:
            problem = f"not a row of numbers: {lines[offset + 1]!r}"
            raise SessionFormatError(path, offset + 2, problem) from None
    raise AssertionError("unreachable: numpy refused a table that Python parses")


def _reject_constant(constant: str) -> None:
    raise ValueError(f"{constant} is not allowed")


def _has_json_type(value: Any, kind: type) -> bool:
    if isinstance(value, bool):
        return kind is bool
    if kind is float:
        return isinstance(value, (int, float))
    return isinstance(value, kind)


def parse_json_record(path: Path, line_number: int, line: str, required: dict[str, type]) -> dict:
    """One JSON object line with at least the ``required`` keys of the given types."""
    try:
        record = json.loads(line, parse_constant=_reject_constant)
    except ValueError as error:
        raise SessionFormatError(path, line_number, f"not a JSON record ({error}): {line[:80]!r}") from None
    if not isinstance(record, dict):
        raise SessionFormatError(path, line_number, f"expected a JSON object, got {line[:80]!r}")
    for key, kind in required.items():
        if key not in record:
            raise SessionFormatError(path, line_number, f"missing field {key!r}")
        value = record[key]
        if not _has_json_type(value, kind):
            problem = f"field {key!r} must be {kind.__name__}, got {value!r}"
            raise SessionFormatError(path, line_number, problem)
    return record


def _vector_from_record(path: Path, line_number: int, record: dict, key: str) -> np.ndarray:
    value = record[key]
    if len(value) != 3 or not all(_has_json_type(v, float) for v in value):
        raise SessionFormatError(path, line_number, f"field {key!r} must be 3 numbers, got {value!r}")
    return np.array(value, dtype=np.float64)


def parse_contact(
    path: Path, line_number: int, line: str
) -> tuple[OrientedContact, tuple[float, float] | None, int]:
    """A ``contacts.jsonl`` line: the contact (without readings), its readings' time range and count."""
    record = parse_json_record(
        path,
        line_number,
        line,
        {"t_s": float, "position_m": list, "normal": list, "force_n": float, "n_readings": int},
    )
    time_range = record.get("readings_t_s")
    if time_range is not None:
        if not (isinstance(time_range, list) and len(time_range) == 2
                and all(_has_json_type(t, float) for t in time_range)):
            raise SessionFormatError(
                path, line_number, f"readings_t_s must be null or [t_first, t_last], got {time_range!r}"
            )
        time_range = (float(time_range[0]), float(time_range[1]))
    contact = OrientedContact(
        t_s=float(record["t_s"]),
        position_m=_vector_from_record(path, line_number, record, "position_m"),
        normal=_vector_from_record(path, line_number, record, "normal"),
        force_n=float(record["force_n"]),
    )
    return contact, time_range, record["n_readings"]


def parse_event(path: Path, line_number: int, line: str) -> Event:
    """An ``events.jsonl`` line."""
    record = parse_json_record(path, line_number, line, {"t_s": float, "kind": str})
    t_s = float(record.pop("t_s"))
    kind = record.pop("kind")
    return Event(kind=kind, t_s=t_s, fields=record)
