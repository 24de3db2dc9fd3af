"""A run cut short (bytes chopped, process SIGKILLed) leaves a readable session; resume appends."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
import warnings

import numpy as np
import pytest

from explorer.session import SessionTruncatedWarning, SessionWriter, read_session
from sensor.oriented_contact import OrientedContact
from sensor.reading import Reading

METADATA = {"robot": "panda", "sensor": "sim", "object": "cube", "seed": 5}
RECORD_FILES = ("readings.csv", "joint_states.csv", "contacts.jsonl", "events.jsonl", "reconstructions.jsonl")


def reading(i: int) -> Reading:
    """The i-th reading of a synthetic stream whose every value is known from i alone."""
    return Reading(
        t_s=i / 1000.0,
        pressure_pa=101325.0 + i / 7.0,
        quat_wxyz=np.array([1.0, 0.0, 0.0, 0.0]),
        lin_acc_mps2=np.array([i / 3.0, -i / 11.0, 0.5]),
        gravity_mps2=np.array([0.0, 0.0, -9.81]),
        temperature_c=25.0 + i / 1e4,
    )


def write_session(directory, n_readings: int, n_contacts: int) -> SessionWriter:
    """Readings, joint states, contacts (each on 3 earlier readings), events and snapshots; left open."""
    writer = SessionWriter(directory, METADATA)
    write_records(writer, 0, n_readings, n_contacts)
    return writer


def write_records(writer: SessionWriter, start: int, n_readings: int, n_contacts: int) -> None:
    for i in range(start, start + n_readings):
        writer.write_reading(reading(i))
        writer.write_joint_state(i / 1000.0, np.full(6, i / 100.0))
    for k in range(n_contacts):
        first = start + 2 + 4 * k  # the last readings are never part of a contact
        writer.write_contact(
            OrientedContact(
                (first + 3) / 1000.0,
                np.array([0.1, 0.2, k / 10.0]),
                np.array([0.0, 0.0, 1.0]),
                1.0 + k,
                tuple(reading(j) for j in range(first, first + 3)),
            )
        )
        writer.write_event("contact_start", first / 1000.0, index=k)
    writer.write_reconstruction((np.eye(3), np.array([[0, 1, 2]])), n_contacts, (start + n_readings) / 1000.0)


def assert_reading_sequence(readings, count: int) -> None:
    expected = [reading(i) for i in range(count)]
    assert len(readings) == count
    np.testing.assert_array_equal(readings.t_s, [r.t_s for r in expected])
    np.testing.assert_array_equal(readings.pressure_pa, [r.pressure_pa for r in expected])
    np.testing.assert_array_equal(readings.lin_acc_mps2, [r.lin_acc_mps2 for r in expected])


def chop(path, n_bytes: int) -> None:
    data = path.read_bytes()
    path.write_bytes(data[:-n_bytes])


def complete_line_count(path) -> int:
    return path.read_bytes().count(b"\n")


@pytest.mark.parametrize("chopped", [1, 2, 7])
def test_session_chopped_at_the_end_of_every_file_reads_up_to_the_last_complete_record(tmp_path, chopped):
    writer = write_session(tmp_path / "run", n_readings=40, n_contacts=4)
    for name in RECORD_FILES:
        chop(tmp_path / "run" / name, chopped)
    writer.close()  # a writer that is killed never closes; closing here only rewrites metadata.json

    with pytest.warns(SessionTruncatedWarning) as caught:
        session = read_session(tmp_path / "run")

    assert session.truncated_files == RECORD_FILES
    assert {name for name in RECORD_FILES if any(name in str(w.message) for w in caught)} == set(RECORD_FILES)
    assert_reading_sequence(session.readings, 39)
    assert len(session.joint_states) == 39
    np.testing.assert_array_equal(session.joint_states.q[-1], np.full(6, 38 / 100.0))
    assert [c.force_n for c in session.contacts] == [1.0, 2.0, 3.0]
    assert [e.fields["index"] for e in session.events] == [0, 1, 2]
    assert session.reconstructions == ()


def test_only_the_cut_file_is_reported(tmp_path):
    writer = write_session(tmp_path / "run", n_readings=10, n_contacts=2)
    writer.close()
    chop(tmp_path / "run" / "events.jsonl", 5)
    with pytest.warns(SessionTruncatedWarning, match="events.jsonl"):
        session = read_session(tmp_path / "run")
    assert session.truncated_files == ("events.jsonl",)
    assert len(session.events) == 1 and len(session.contacts) == 2 and len(session.readings) == 10


def test_a_clean_session_raises_no_truncation_warning(tmp_path):
    write_session(tmp_path / "run", n_readings=10, n_contacts=2).close()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        session = read_session(tmp_path / "run")
    assert session.truncated_files == ()


def test_a_header_cut_mid_line_reads_as_an_empty_stream(tmp_path):
    write_session(tmp_path / "run", n_readings=3, n_contacts=0).close()
    path = tmp_path / "run" / "readings.csv"
    path.write_bytes(path.read_bytes()[:20])
    with pytest.warns(SessionTruncatedWarning, match="readings.csv"):
        session = read_session(tmp_path / "run")
    assert len(session.readings) == 0


WRITER_SCRIPT = textwrap.dedent(
    """
    import sys
    import numpy as np
    sys.path.insert(0, sys.argv[2])
    from test_session_crash import METADATA, reading
    from explorer.session import SessionWriter
    from sensor.oriented_contact import OrientedContact

    writer = SessionWriter(sys.argv[1], METADATA)
    i = 0
    while True:
        writer.write_reading(reading(i))
        writer.write_joint_state(i / 1000.0, np.full(6, i / 100.0))
        if i % 50 == 49:
            window = tuple(reading(j) for j in range(i - 4, i + 1))
            writer.write_contact(OrientedContact(i / 1000.0, np.array([0.1, 0.2, 0.3]),
                                                 np.array([0.0, 0.6, 0.8]), i / 50.0, window))
            writer.write_event("contact_start", i / 1000.0, index=i)
        i += 1
    """
)


def test_a_sigkilled_writer_leaves_a_readable_session(tmp_path):
    directory = tmp_path / "run"
    process = subprocess.Popen(
        [sys.executable, "-c", WRITER_SCRIPT, str(directory), os.path.dirname(__file__)],
        stderr=subprocess.PIPE,
    )
    try:
        readings_path = directory / "readings.csv"
        deadline = time.monotonic() + 20.0
        while not (readings_path.exists() and readings_path.stat().st_size > 150_000):
            assert process.poll() is None, process.stderr.read().decode()
            assert time.monotonic() < deadline, "the writer subprocess produced too little"
            time.sleep(0.02)
    finally:
        process.send_signal(signal.SIGKILL)
        process.wait()
    assert process.returncode == -signal.SIGKILL

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        session = read_session(directory)

    complete_readings = complete_line_count(readings_path) - 1
    assert complete_readings > 1000
    assert_reading_sequence(session.readings, complete_readings)
    assert len(session.joint_states) == complete_line_count(directory / "joint_states.csv") - 1
    assert abs(len(session.joint_states) - len(session.readings)) <= 1
    assert len(session.contacts) == complete_line_count(directory / "contacts.jsonl")
    assert len(session.contacts) >= complete_readings // 50 - 1
    contact_indices = [round(contact.t_s * 1000) for contact in session.contacts]
    for i, contact in zip(contact_indices, session.contacts):
        assert [r.t_s for r in contact.readings] == [reading(j).t_s for j in range(i - 4, i + 1)]
    # each contact's event is written right after it, so the kill may fall between the two
    assert len(session.contacts) - 1 <= len(session.events) <= len(session.contacts)
    assert [e.fields["index"] for e in session.events] == contact_indices[: len(session.events)]
    cut = tuple(
        name
        for name in RECORD_FILES
        if (directory / name).exists() and (directory / name).read_bytes().rstrip(b"\n") != b""
        and not (directory / name).read_bytes().endswith(b"\n")
    )
    assert session.truncated_files == cut
    assert {str(w.message).split(":")[0].rsplit("/", 1)[-1] for w in caught} == set(cut)
    assert session.metadata["end_status"] == "open" and not session.closed_cleanly


def test_resume_appends_to_the_existing_session(tmp_path):
    write_session(tmp_path / "run", n_readings=20, n_contacts=2).close()
    with SessionWriter(tmp_path / "run", resume=True) as writer:
        write_records(writer, start=20, n_readings=20, n_contacts=2)

    session = read_session(tmp_path / "run")
    assert_reading_sequence(session.readings, 40)
    np.testing.assert_array_equal(session.joint_states.t_s, np.arange(40) / 1000.0)
    assert [c.t_s for c in session.contacts] == [0.005, 0.009, 0.025, 0.029]
    assert [r.t_s for r in session.contacts[2].readings] == [0.022, 0.023, 0.024]
    assert [s.path.name for s in session.reconstructions] == ["000000.ply", "000001.ply"]
    assert [s.n_contacts for s in session.reconstructions] == [2, 2]
    assert len(session.metadata["resumed"]) == 1
    assert session.metadata["resumed"][0]["discarded_partial_bytes"] == {}
    assert session.closed_cleanly


def test_resume_after_a_crash_cuts_the_partial_line_and_records_it(tmp_path):
    write_session(tmp_path / "run", n_readings=20, n_contacts=2)  # never closed: as if killed
    last_reading_line = (tmp_path / "run" / "readings.csv").read_bytes().splitlines(keepends=True)[-1]
    last_event_line = (tmp_path / "run" / "events.jsonl").read_bytes().splitlines(keepends=True)[-1]
    chop(tmp_path / "run" / "readings.csv", 10)
    chop(tmp_path / "run" / "events.jsonl", 3)

    with pytest.warns(SessionTruncatedWarning, match="resuming after a crash"):
        writer = SessionWriter(tmp_path / "run", METADATA, resume=True)
    with writer:
        write_records(writer, start=20, n_readings=5, n_contacts=0)

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        session = read_session(tmp_path / "run")
    assert session.truncated_files == ()
    np.testing.assert_array_equal(session.readings.t_s, np.r_[np.arange(19), np.arange(20, 25)] / 1000.0)
    assert [e.fields["index"] for e in session.events] == [0]
    assert session.metadata["resumed"][0]["discarded_partial_bytes"] == {
        "readings.csv": len(last_reading_line) - 10,
        "events.jsonl": len(last_event_line) - 3,
    }


def test_resume_checks_metadata_and_continuity(tmp_path):
    write_session(tmp_path / "run", n_readings=10, n_contacts=0).close()
    with pytest.raises(ValueError, match=r"differs .* \['seed'\]"):
        SessionWriter(tmp_path / "run", {**METADATA, "seed": 6}, resume=True)
    with SessionWriter(tmp_path / "run", resume=True) as writer:
        with pytest.raises(ValueError, match="time order"):
            writer.write_reading(reading(3))
        with pytest.raises(ValueError, match=r"shape \(6,\)"):
            writer.write_joint_state(1.0, np.zeros(7))
    with pytest.raises(FileNotFoundError, match="no metadata.json"):
        SessionWriter(tmp_path / "missing", METADATA, resume=True)
