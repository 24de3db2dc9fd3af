"""Resuming a stopped run from what it recorded.

A run that stopped halfway (a device that stopped answering, a crash, Ctrl-C) leaves its session
directory and ``contacts.csv`` behind. :func:`load_recorded_run` reads the touches back from the
session's touch events (and contacts), so the loop can be restored
(:meth:`explorer.loop.ExplorationLoop.restore`) and go on to its budget, appending to the same files.

The session is the record the run is rebuilt from: ``contacts.csv`` is rewritten from it
(:func:`rewrite_contacts_csv`), since a crash can land between the two writes.
"""
from __future__ import annotations

import math
import os
import warnings
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from explorer.touch import TouchOutcome
from explorer.recording import CONTACTS_HEADER, contacts_csv_row
from explorer.session import SessionReader, SessionTruncatedWarning

#: Touch event kinds the loop writes (RunRecorder.touch), by the record's ``kind``.
TOUCH_EVENT_KINDS = ("touch", "miss", "realign", "unreachable", "blocked", "no_normal")

#: Session time left between the end of the stopped part and the resumed part, seconds.
RESUME_GAP_S = 1.0

#: Settings a resumed run may change: the budget and how results are evaluated and drawn.
CHANGEABLE_SETTINGS = frozenset({"touches", "gui", "eval_every", "mesh_resolution", "reach_samples"})

#: Settings older sessions recorded in another place: (section, key) then -> (section, key) now.
#: A resumed run compares the recorded value with the one at its new place.
MOVED_SETTINGS = {("loop", "pad_compliance_m_per_n"): ("pad", "compliance_m_per_n")}


@dataclass(frozen=True)
class RecordedRun:
    """What a stopped run left behind.

    Attributes
    ----------
    touches : list of TouchOutcome
        The recorded touches in order (object frame; ``contact`` is the world-frame contact
        from ``contacts.jsonl`` where it was written, else None).
    end_time_s : float
        The latest time in the session (session clock), seconds.
    metadata : dict
        The session metadata (``configuration`` holds the run settings).
    """

    touches: list[TouchOutcome]
    end_time_s: float
    metadata: dict

    @property
    def contacts(self) -> list[TouchOutcome]:
        return [t for t in self.touches if t.kind == "contact"]


def load_recorded_run(out_dir: Path) -> RecordedRun:
    """Read the touches of the run in ``out_dir`` (its ``session/``) back as loop records.

    Raises
    ------
    FileNotFoundError
        No session in ``out_dir``.
    ValueError
        The touch events are not numbered 0, 1, ... (not a session written by the loop).
    """
    session_dir = Path(out_dir) / "session"
    if not (session_dir / "metadata.json").exists():
        raise FileNotFoundError(f"no run to resume in {out_dir}: {session_dir}/metadata.json is missing")
    with warnings.catch_warnings():  # a crash-cut last line is expected here; the writer cuts it on resume
        warnings.simplefilter("ignore", SessionTruncatedWarning)
        session = SessionReader(session_dir).read()
    contacts_by_time = {c.t_s: c for c in session.contacts}
    touches = []
    for event in session.events:
        if event.kind not in TOUCH_EVENT_KINDS or "index" not in event.fields:
            continue
        touches.append(_touch_record(event, contacts_by_time))
    for expected, record in enumerate(touches):
        if record.index != expected:
            raise ValueError(f"{session_dir}: touch events are not numbered 0, 1, ...: touch {expected} "
                             f"is numbered {record.index}")
    return RecordedRun(touches, _end_time(session), dict(session.metadata))


def _touch_record(event, contacts_by_time) -> TouchOutcome:
    f = event.fields

    def vector(name):
        return None if f.get(name) is None else np.asarray(f[name], float)

    record = TouchOutcome(
        index=int(f["index"]), kind=str(f["result"]), target_m=vector("target_m"),
        approach_dir=vector("approach_dir"), stand_yaw_rad=float(f.get("stand_yaw_rad", 0.0)),
        stand_tilt_rad=float(f.get("stand_tilt_rad", 0.0)), position_m=vector("position_m"),
        normal=vector("normal"), t_s=event.t_s, strategy=str(f.get("strategy", "")),
        press_t_s=None if f.get("press_t_s") is None else tuple(f["press_t_s"]))
    if f.get("repress_t_s") is not None:
        record.repress_t_s = float(f["repress_t_s"])
    free_space = vector("free_space_m")
    record.free_space_m = None if free_space is None else free_space.reshape(-1, 3)
    record.side_m = vector("side_m")
    record.left_line_m = vector("left_line_m")
    if record.kind == "contact":
        record.contact = contacts_by_time.get(event.t_s)
    if isinstance(f.get("quality"), dict):
        from explorer.contact import ContactQuality

        known = {item.name for item in fields(ContactQuality)}
        values = {k: tuple(v) if isinstance(v, list) else v for k, v in f["quality"].items() if k in known}
        if "force_n" in values and "n_readings" in values:
            record.quality = ContactQuality(**values)
    return record


def _end_time(session) -> float:
    times = [-math.inf]
    if len(session.readings):
        times.append(float(session.readings.t_s[-1]))
    if len(session.joint_states):
        times.append(float(session.joint_states.t_s[-1]))
    times += [e.t_s for e in session.events] + [c.t_s for c in session.contacts]
    times += [r.t_s for r in session.reconstructions]
    return max(times)


def resume_time_offset(previous_end_s: float, device_now_s: float, gap_s: float = RESUME_GAP_S) -> float:
    """Offset (seconds) that puts the device clock's ``now`` ``gap_s`` after the stopped part's end.

    Zero when the device clock is already past that (it did not restart).
    """
    if not math.isfinite(previous_end_s):
        return 0.0
    return max(0.0, previous_end_s + gap_s - device_now_s)


def check_resumable(stored: dict, settings: dict) -> None:
    """Refuse to resume with settings that would make the run a different experiment.

    ``stored`` and ``settings`` are run settings as dicts (the stored one from the session's
    ``configuration``); only :data:`CHANGEABLE_SETTINGS` may differ. Settings that moved
    (:data:`MOVED_SETTINGS`) are compared at their new place.
    """
    stored = _moved_to_current_places(stored)
    differing = sorted(key for key in stored.keys() & settings.keys()
                       if key not in CHANGEABLE_SETTINGS and stored[key] != settings[key])
    if differing:
        details = "; ".join(f"{key}: recorded {stored[key]!r}, now {settings[key]!r}" for key in differing)
        raise ValueError(f"cannot resume with different settings ({details}); only "
                         f"{', '.join(sorted(CHANGEABLE_SETTINGS))} may change")


def _moved_to_current_places(stored: dict) -> dict:
    """A copy of ``stored`` with each of :data:`MOVED_SETTINGS` taken out of its old section into its new one."""
    stored = {key: dict(value) if isinstance(value, dict) else value for key, value in stored.items()}
    for (old_section, old_key), (new_section, new_key) in MOVED_SETTINGS.items():
        section = stored.get(old_section)
        if isinstance(section, dict) and old_key in section:
            value = section.pop(old_key)
            stored.setdefault(new_section, {})
            if isinstance(stored[new_section], dict):
                stored[new_section].setdefault(new_key, value)
    return stored


def rewrite_contacts_csv(out_dir: Path, touches: list[TouchOutcome]) -> None:
    """Write ``contacts.csv`` afresh from the recorded contacts (atomically: temporary file, rename)."""
    path = Path(out_dir) / "contacts.csv"
    partial = path.with_suffix(".csv.partial")
    with open(partial, "w", encoding="utf-8") as stream:
        stream.write(CONTACTS_HEADER)
        for record in touches:
            if record.kind != "contact":
                continue
            t_s = record.t_s if record.contact is None else record.contact.t_s
            force = math.nan if record.contact is None else record.contact.force_n
            stream.write(contacts_csv_row(record, t_s, force))
        stream.flush()
        os.fsync(stream.fileno())
    os.replace(partial, path)
