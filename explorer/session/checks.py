"""Checks before a recorded session is replayed: every file it needs is there, and rows that no
detector can use (a non-finite pressure or orientation) are named and set aside."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from explorer.session.layout import EVENTS_FILE, JOINT_STATES_FILE, METADATA_FILE, READINGS_FILE
from explorer.session.records import Readings

#: The files a replay cannot do without.
REPLAY_FILES = (METADATA_FILE, READINGS_FILE, JOINT_STATES_FILE, EVENTS_FILE)


class IncompleteSessionError(ValueError):
    """A session directory lacks a file a replay needs (or is no session at all)."""


def require_replay_files(directory: Path) -> None:
    """Raise :class:`IncompleteSessionError` naming the first missing file of :data:`REPLAY_FILES`."""
    directory = Path(directory)
    if not directory.is_dir():
        raise IncompleteSessionError(f"{directory}: no such session directory")
    if not (directory / METADATA_FILE).is_file():
        raise IncompleteSessionError(
            f"{directory} is not a session: {METADATA_FILE} is missing (give a session directory, or the "
            f"run directory that holds session/)")
    for name in REPLAY_FILES:
        if not (directory / name).is_file():
            raise IncompleteSessionError(f"{directory}: incomplete session: {name} is missing")


def usable_readings(readings: Readings) -> tuple[Readings, list[str]]:
    """``readings`` without the rows whose pressure or orientation is not finite, and a note per
    kind of problem naming the lines of ``readings.csv`` (line 1 is the header)."""
    bad = ~np.isfinite(readings.pressure_pa) | ~np.all(np.isfinite(readings.quat_wxyz), axis=1)
    if not bad.any():
        return readings, []
    rows = np.flatnonzero(bad)
    lines = ", ".join(str(int(i) + 2) for i in rows[:10]) + (", ..." if len(rows) > 10 else "")
    keep = ~bad
    table = np.column_stack([readings.t_s, readings.pressure_pa, readings.quat_wxyz, readings.lin_acc_mps2,
                             readings.gravity_mps2, readings.temperature_c])[keep]
    note = (f"{READINGS_FILE}: {len(rows)} row(s) with a non-finite pressure or orientation skipped "
            f"(line {lines})")
    return Readings.from_rows(table), [note]
