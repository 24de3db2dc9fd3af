"""Names of the files in a session directory, their CSV columns and the format version.

The prose description of every file lives in ``docs/SESSION_FORMAT.md``; this module is the single
place the code takes the names from.
"""
from __future__ import annotations

FORMAT_NAME = "tactile-explore-session"
FORMAT_VERSION = 1

METADATA_FILE = "metadata.json"
READINGS_FILE = "readings.csv"
JOINT_STATES_FILE = "joint_states.csv"
CONTACTS_FILE = "contacts.jsonl"
EVENTS_FILE = "events.jsonl"
RECONSTRUCTIONS_FILE = "reconstructions.jsonl"
RECONSTRUCTIONS_DIR = "reconstructions"

RECORD_FILES = (READINGS_FILE, JOINT_STATES_FILE, CONTACTS_FILE, EVENTS_FILE, RECONSTRUCTIONS_FILE)

READINGS_COLUMNS = (
    "t_s",
    "pressure_pa",
    "quat_w",
    "quat_x",
    "quat_y",
    "quat_z",
    "lin_acc_x_mps2",
    "lin_acc_y_mps2",
    "lin_acc_z_mps2",
    "gravity_x_mps2",
    "gravity_y_mps2",
    "gravity_z_mps2",
    "temperature_c",
)


def joint_state_columns(dof: int) -> tuple[str, ...]:
    """Header of ``joint_states.csv`` for an arm with ``dof`` joints: ``t_s, q0, ..., q{dof-1}``."""
    return ("t_s",) + tuple(f"q{i}" for i in range(dof))


def dof_from_joint_state_columns(columns: list[str]) -> int | None:
    """The dof a ``joint_states.csv`` header describes, or None when it is not such a header."""
    dof = len(columns) - 1
    if dof < 1 or tuple(columns) != joint_state_columns(dof):
        return None
    return dof


def reconstruction_file_name(index: int) -> str:
    """Relative path (POSIX separators) of the ``index``-th reconstruction snapshot's PLY file."""
    return f"{RECONSTRUCTIONS_DIR}/{index:06d}.ply"
