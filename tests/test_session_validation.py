"""Bad input to the writer and bad files for the reader fail loudly, naming the problem."""
from __future__ import annotations

import json

import numpy as np
import pytest

from explorer.session import SessionClosedError, SessionFormatError, SessionWriter, read_session
from sensor.oriented_contact import OrientedContact
from sensor.reading import Reading

METADATA = {"robot": "panda", "sensor": "sim", "object": "cube", "seed": 1}


def reading(t_s: float, **changes) -> Reading:
    values = dict(
        t_s=t_s,
        pressure_pa=101325.0,
        quat_wxyz=np.array([1.0, 0.0, 0.0, 0.0]),
        lin_acc_mps2=np.zeros(3),
        gravity_mps2=np.array([0.0, 0.0, -9.81]),
    )
    values.update(changes)
    return Reading(**values)


def contact(**changes) -> OrientedContact:
    values = dict(
        t_s=1.0, position_m=np.array([0.1, 0.2, 0.3]), normal=np.array([0.0, 0.0, 1.0]), force_n=1.0
    )
    values.update(changes)
    return OrientedContact(**values)


@pytest.fixture()
def writer(tmp_path):
    with SessionWriter(tmp_path / "run", METADATA) as session_writer:
        yield session_writer


@pytest.mark.parametrize(
    "changes, field",
    [
        ({"position_m": np.array([0.1, np.nan, 0.3])}, "contact.position_m"),
        ({"position_m": np.zeros(4)}, "contact.position_m"),
        ({"normal": np.array([0.0, np.inf, 1.0])}, "contact.normal"),
        ({"normal": np.array([0.0, 0.0, 2.0])}, "contact.normal"),
        ({"normal": np.zeros((3, 1))}, "contact.normal"),
        ({"force_n": float("nan")}, "contact.force_n"),
        ({"t_s": float("inf")}, "contact.t_s"),
    ],
)
def test_bad_contact_is_refused_naming_the_field(writer, changes, field):
    with pytest.raises(ValueError, match=field.replace(".", r"\.")):
        writer.write_contact(contact(**changes))
    assert (writer.directory / "contacts.jsonl").read_text() == ""


def test_contact_whose_readings_were_not_written_is_refused(writer):
    written = [reading(0.1 * i) for i in range(5)]
    for r in written:
        writer.write_reading(r)
    writer.write_contact(contact(readings=tuple(written[1:4])))
    with pytest.raises(ValueError, match="write_reading"):
        writer.write_contact(contact(readings=(reading(0.25),)))
    with pytest.raises(ValueError, match="write_reading"):
        writer.write_contact(contact(readings=(written[1], written[3])))  # not contiguous in the stream
    assert len((writer.directory / "contacts.jsonl").read_text().splitlines()) == 1


@pytest.mark.parametrize(
    "changes, field",
    [
        ({"quat_wxyz": np.zeros(3)}, "reading.quat_wxyz"),
        ({"lin_acc_mps2": np.zeros((1, 3))}, "reading.lin_acc_mps2"),
        ({"gravity_mps2": [0.0, "down", 0.0]}, "reading.gravity_mps2"),
        ({"t_s": float("nan")}, "reading.t_s"),
        ({"pressure_pa": "101325"}, "reading.pressure_pa"),
    ],
)
def test_bad_reading_is_refused_naming_the_field(writer, changes, field):
    with pytest.raises(ValueError, match=field.replace(".", r"\.")):
        writer.write_reading(reading(**{"t_s": 0.0, **changes}))


def test_streams_must_be_in_time_order(writer):
    writer.write_reading(reading(1.0))
    writer.write_reading(reading(1.0))
    with pytest.raises(ValueError, match="time order"):
        writer.write_reading(reading(0.5))
    writer.write_joint_state(2.0, np.zeros(6))
    with pytest.raises(ValueError, match="time order"):
        writer.write_joint_state(1.0, np.zeros(6))


def test_joint_state_shape_is_fixed_by_the_first_one(writer):
    with pytest.raises(ValueError, match=r"q must have shape \(dof,\)"):
        writer.write_joint_state(0.0, np.zeros((2, 3)))
    writer.write_joint_state(0.0, np.zeros(6))
    with pytest.raises(ValueError, match=r"q must have shape \(6,\)"):
        writer.write_joint_state(0.1, np.zeros(7))
    with pytest.raises(ValueError, match="t_s must be finite"):
        writer.write_joint_state(float("nan"), np.zeros(6))


@pytest.mark.parametrize(
    "kind, fields, message",
    [
        ("Touch", {}, "lower-case identifier"),
        ("touch", {"approach_dir": [0.0, 0.0, -1.0]}, "'target_m'"),
        ("touch", {"target_m": [0.0, 0.0], "approach_dir": [0.0, 0.0, -1.0]}, "target_m"),
        ("error", {"source": "bmp280"}, "'message'"),
        ("note", {"gain": float("nan")}, "event field 'gain' must be finite"),
        ("note", {"values": [1.0, np.inf]}, r"event field 'values'\[1\] must be finite"),
        ("note", {"handle": object()}, "event field 'handle': cannot store"),
    ],
)
def test_bad_event_is_refused(writer, kind, fields, message):
    with pytest.raises(ValueError, match=message):
        writer.write_event(kind, 0.0, **fields)
    assert (writer.directory / "events.jsonl").read_text() == ""


@pytest.mark.parametrize(
    "mesh, n_contacts, message",
    [
        ((np.zeros((3, 2)), np.array([[0, 1, 2]])), 1, "vertices must have shape"),
        ((np.zeros((3, 3)), np.array([[0, 1, 3]])), 1, "faces must index vertices 0..2"),
        ((np.zeros((3, 3)), np.array([[0.0, 1.0, 2.0]])), 1, "integer vertex indices"),
        ((np.full((3, 3), np.nan), np.array([[0, 1, 2]])), 1, "vertices must be finite"),
        ((np.zeros((3, 3)), np.array([[0, 1, 2]])), -1, "n_contacts must be >= 0"),
        ((np.zeros((3, 3)), np.array([[0, 1, 2]])), 2.0, "n_contacts must be an integer"),
    ],
)
def test_bad_reconstruction_is_refused(writer, mesh, n_contacts, message):
    with pytest.raises(ValueError, match=message):
        writer.write_reconstruction(mesh, n_contacts, 0.0)
    assert list((writer.directory / "reconstructions").iterdir()) == []


def test_writing_after_close_is_an_error(tmp_path):
    writer = SessionWriter(tmp_path / "run", METADATA)
    writer.close()
    writer.close()  # idempotent
    assert writer.closed
    for write in (
        lambda: writer.write_reading(reading(0.0)),
        lambda: writer.write_joint_state(0.0, np.zeros(6)),
        lambda: writer.write_contact(contact()),
        lambda: writer.write_event("contact_end", 0.0),
        lambda: writer.write_reconstruction((np.eye(3), np.array([[0, 1, 2]])), 1, 0.0),
    ):
        with pytest.raises(SessionClosedError, match="closed"):
            write()


def test_existing_session_is_not_overwritten(tmp_path):
    SessionWriter(tmp_path / "run", METADATA).close()
    before = (tmp_path / "run" / "metadata.json").read_bytes()
    with pytest.raises(FileExistsError, match="resume=True"):
        SessionWriter(tmp_path / "run", METADATA)
    assert (tmp_path / "run" / "metadata.json").read_bytes() == before
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "notes.txt").write_text("not a session")
    with pytest.raises(FileExistsError):
        SessionWriter(tmp_path / "other", METADATA)


def test_an_existing_empty_directory_can_hold_a_new_session(tmp_path):
    (tmp_path / "run").mkdir()
    SessionWriter(tmp_path / "run", METADATA).close()
    assert read_session(tmp_path / "run").closed_cleanly


@pytest.mark.parametrize(
    "metadata, message",
    [
        (None, "metadata is required"),
        ({"robot": "panda", "sensor": "sim", "object": "cube"}, "missing \\['seed'\\]"),
        ({**METADATA, "format_version": 2}, "format_version"),
        (
            {**METADATA, "configuration": {"gain": float("inf")}},
            r"metadata\['configuration'\]\['gain'\] must be finite",
        ),
    ],
)
def test_bad_metadata_is_refused(tmp_path, metadata, message):
    with pytest.raises(ValueError, match=message):
        SessionWriter(tmp_path / "run", metadata)
    assert not (tmp_path / "run").exists()


def write_small_session(directory):
    with SessionWriter(directory, METADATA) as writer:
        for i in range(5):
            writer.write_reading(reading(0.1 * i))
            writer.write_event("contact_start", 0.1 * i)
        writer.write_contact(contact(readings=(reading(0.1), reading(0.2))))


@pytest.mark.parametrize(
    "name, line_number, replacement, message",
    [
        ("events.jsonl", 3, '{"t_s": 0.2, "kind": ', "not a JSON record"),
        ("events.jsonl", 2, '{"t_s": "later", "kind": "x"}', "field 't_s' must be float"),
        ("events.jsonl", 4, '{"t_s": NaN, "kind": "x"}', "not a JSON record"),
        ("readings.csv", 3, "0.1,101325.0,1.0", "expected 13 comma-separated values"),
        ("readings.csv", 4, "0.2,oops" + ",0.0" * 11, "not a row of numbers"),
        ("readings.csv", 5, "0.01" + ",0.0" * 12, "earlier than the previous one"),
        ("readings.csv", 1, "time,pressure", "header must be"),
        (
            "contacts.jsonl",
            1,
            '{"t_s":1.0,"position_m":[0,0],"normal":[0,0,1],"force_n":1.0,"n_readings":0}',
            "position_m",
        ),
    ],
)
def test_a_corrupt_line_in_the_middle_names_file_and_line(tmp_path, name, line_number, replacement, message):
    write_small_session(tmp_path / "run")
    path = tmp_path / "run" / name
    lines = path.read_text().splitlines()
    lines[line_number - 1] = replacement
    path.write_text("\n".join(lines) + "\n")
    with pytest.raises(SessionFormatError, match=message) as raised:
        read_session(tmp_path / "run")
    assert raised.value.path == path
    assert raised.value.line_number == line_number
    assert f"{name}, line {line_number}" in str(raised.value)


def test_a_contact_that_does_not_match_the_readings_is_reported(tmp_path):
    write_small_session(tmp_path / "run")
    path = tmp_path / "run" / "contacts.jsonl"
    record = json.loads(path.read_text())
    record["n_readings"] = 3
    path.write_text(json.dumps(record) + "\n")
    with pytest.raises(SessionFormatError, match="references 3 readings .* holds 2"):
        read_session(tmp_path / "run")


def test_unknown_format_version_and_missing_metadata_are_refused(tmp_path):
    write_small_session(tmp_path / "run")
    path = tmp_path / "run" / "metadata.json"
    metadata = json.loads(path.read_text())
    metadata["format_version"] = 99
    path.write_text(json.dumps(metadata))
    with pytest.raises(SessionFormatError, match="format_version 99 is not supported"):
        read_session(tmp_path / "run")
    with pytest.raises(FileNotFoundError, match="no metadata.json"):
        read_session(tmp_path)


def test_a_snapshot_whose_mesh_file_is_missing_is_reported(tmp_path):
    with SessionWriter(tmp_path / "run", METADATA) as writer:
        snapshot = writer.write_reconstruction((np.eye(3), np.array([[0, 1, 2]])), 1, 0.0)
    snapshot.path.unlink()
    with pytest.raises(SessionFormatError, match="000000.ply is missing"):
        read_session(tmp_path / "run")
