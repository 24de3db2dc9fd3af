"""Every record type written by SessionWriter reads back equal, floats bit for bit."""
from __future__ import annotations

import json

import numpy as np
import pytest

from explorer.session import SessionWriter, read_session
from sensor.oriented_contact import OrientedContact
from sensor.reading import Reading

METADATA = {
    "robot": {"name": "panda", "dof": 7},
    "sensor": "simulated-bmp280-bno055",
    "object": {"mesh": "bunny.obj", "position_m": np.array([0.5, 0.0, 0.1])},
    "seed": 42,
    "configuration": {"strategy": "variance", "contact_threshold_pa": np.float32(100.0)},
}

# Floats whose decimal form is easy to get wrong: repeating binary fractions, the extremes of the
# double range, subnormals, signed zero.
AWKWARD_FLOATS = np.array(
    [0.1, 1 / 3, 2 / 3, 1e-300, 5e-324, 2.2250738585072014e-308, 1.7976931348623157e308, -0.0,
     101325.00000000001]
)


def random_readings(rng: np.random.Generator, n: int) -> list[Reading]:
    times = np.cumsum(rng.uniform(1e-4, 2e-3, n)) + 1 / 7
    quats = rng.normal(size=(n, 4))
    quats /= np.linalg.norm(quats, axis=1, keepdims=True)
    return [
        Reading(
            t_s=float(times[i]),
            pressure_pa=float(rng.normal(101325.0, 200.0)),
            quat_wxyz=quats[i],
            lin_acc_mps2=rng.normal(size=3) * 10.0 ** rng.integers(-200, 200, size=3),
            gravity_mps2=np.array([0.0, 0.0, -9.80665]) + rng.normal(scale=1e-3, size=3),
            temperature_c=float(rng.uniform(20.0, 30.0)),
        )
        for i in range(n)
    ]


def bits(values) -> np.ndarray:
    """The IEEE-754 bit patterns, so that -0.0 != 0.0 and every last bit counts."""
    return np.asarray(values, dtype=np.float64).view(np.int64)


def assert_same_reading(read, written: Reading) -> None:
    assert bits(read.t_s) == bits(written.t_s)
    assert bits(read.pressure_pa) == bits(written.pressure_pa)
    np.testing.assert_array_equal(bits(read.quat_wxyz), bits(written.quat_wxyz))
    np.testing.assert_array_equal(bits(read.lin_acc_mps2), bits(written.lin_acc_mps2))
    np.testing.assert_array_equal(bits(read.gravity_mps2), bits(written.gravity_mps2))
    assert bits(read.temperature_c) == bits(written.temperature_c)


@pytest.fixture()
def written(tmp_path):
    """A session holding every record type, and what was written to it."""
    rng = np.random.default_rng(7)
    readings = random_readings(rng, 300)
    readings.append(
        Reading(readings[-1].t_s + 1e-3, np.nan, np.array([1.0, -0.0, 0.0, 0.0]),
                AWKWARD_FLOATS[:3], AWKWARD_FLOATS[3:6], float(AWKWARD_FLOATS[6]))
    )
    joint_times = np.sort(rng.uniform(0.0, 0.5, 40))
    joint_q = rng.uniform(-np.pi, np.pi, (40, 7))
    joint_q[0] = AWKWARD_FLOATS[:7]
    normals = rng.normal(size=(3, 3))
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    contacts = [
        OrientedContact(0.31, rng.normal(size=3), normals[0], 2.5, tuple(readings[10:25])),
        OrientedContact(0.62, np.array([0.1, 0.2, 0.3]), normals[1], 0.1, tuple(readings[100:101])),
        OrientedContact(0.7, AWKWARD_FLOATS[:3], normals[2], 1 / 3, ()),
    ]
    events = [
        ("touch", 0.30,
         {"target_m": np.array([0.5, 0.0, 0.1]), "approach_dir": [0.0, 0.0, -1.0], "strategy": "variance"}),
        ("contact_start", 0.305, {"pressure_pa": 101500.25}),
        ("contact_end", 0.35, {}),
        ("miss", 0.5,
         {"target_m": [0.4, 0.1, 0.1], "approach_dir": np.array([0.0, -1.0, 0.0]), "travel_m": 0.02}),
        ("error", 0.6, {"source": "bno055", "message": "device stopped answering", "retries": np.int64(3)}),
        ("operator_note", 0.65,
         {"text": "nudged the object", "nested": {"ok": True, "values": [1, 2.5, None]}}),
    ]
    vertices = rng.normal(size=(30, 3))
    vertices[:3] = AWKWARD_FLOATS.reshape(3, 3)
    faces = rng.integers(0, 30, size=(50, 3))
    meshes = [(vertices, faces, 2, 0.64), (vertices[10:20] * 0.5, faces[:5] % 10, 3, 0.8)]

    with SessionWriter(tmp_path / "run", METADATA) as writer:
        for reading in readings:
            writer.write_reading(reading)
        for t, q in zip(joint_times, joint_q):
            writer.write_joint_state(t, q)
        for contact in contacts:
            writer.write_contact(contact)
        for kind, t, fields in events:
            writer.write_event(kind, t, **fields)
        snapshots = [writer.write_reconstruction((v, f), n, t) for v, f, n, t in meshes]
    return {
        "directory": tmp_path / "run",
        "readings": readings,
        "joint_times": joint_times,
        "joint_q": joint_q,
        "contacts": contacts,
        "events": events,
        "meshes": meshes,
        "snapshots": snapshots,
    }


def test_readings_round_trip_bit_exact(written):
    session = read_session(written["directory"])
    assert len(session.readings) == len(written["readings"])
    for read, original in zip(session.readings, written["readings"]):
        assert_same_reading(read, original)
    assert np.isnan(session.readings.pressure_pa[-1])
    assert session.readings.quat_wxyz.shape == (len(written["readings"]), 4)


def test_joint_states_round_trip_bit_exact(written):
    joint_states = read_session(written["directory"]).joint_states
    assert joint_states.dof == 7
    np.testing.assert_array_equal(bits(joint_states.t_s), bits(written["joint_times"]))
    np.testing.assert_array_equal(bits(joint_states.q), bits(written["joint_q"]))


def test_contacts_round_trip_with_their_readings(written):
    contacts = read_session(written["directory"]).contacts
    assert len(contacts) == len(written["contacts"])
    for read, original in zip(contacts, written["contacts"]):
        assert bits(read.t_s) == bits(original.t_s)
        np.testing.assert_array_equal(bits(read.position_m), bits(original.position_m))
        np.testing.assert_array_equal(bits(read.normal), bits(original.normal))
        assert bits(read.force_n) == bits(original.force_n)
        assert len(read.readings) == len(original.readings)
        for read_reading, original_reading in zip(read.readings, original.readings):
            assert_same_reading(read_reading, original_reading)


def test_contact_readings_are_referenced_not_copied(written):
    lines = (written["directory"] / "contacts.jsonl").read_text().splitlines()
    first = json.loads(lines[0])
    assert first["readings_t_s"] == [written["readings"][10].t_s, written["readings"][24].t_s]
    assert first["n_readings"] == 15
    assert "pressure_pa" not in lines[0]


def test_events_round_trip(written):
    events = read_session(written["directory"]).events
    assert [(e.kind, e.t_s) for e in events] == [(kind, t) for kind, t, _ in written["events"]]
    for event, (_, _, fields) in zip(events, written["events"]):
        assert set(event.fields) == set(fields)
        for name, value in fields.items():
            expected = value.tolist() if isinstance(value, np.ndarray) else value
            assert event.fields[name] == expected, name
    assert type(events[4].fields["retries"]) is int


def test_reconstruction_snapshots_round_trip_through_an_independent_ply_reader(written):
    trimesh = pytest.importorskip("trimesh")
    snapshots = read_session(written["directory"]).reconstructions
    assert snapshots == tuple(written["snapshots"])
    for snapshot, (vertices, faces, n_contacts, t_s) in zip(snapshots, written["meshes"]):
        assert (snapshot.n_contacts, snapshot.t_s) == (n_contacts, t_s)
        assert (snapshot.n_vertices, snapshot.n_faces) == (len(vertices), len(faces))
        mesh = trimesh.load(snapshot.path, process=False)
        np.testing.assert_array_equal(bits(mesh.vertices), bits(vertices))
        np.testing.assert_array_equal(mesh.faces, faces)


def test_write_reconstruction_accepts_a_trimesh(tmp_path):
    trimesh = pytest.importorskip("trimesh")
    sphere = trimesh.creation.icosphere(subdivisions=1, radius=0.05)
    with SessionWriter(tmp_path / "run", METADATA) as writer:
        writer.write_reconstruction(sphere, n_contacts=12, t_s=3.0)
    snapshot, = read_session(tmp_path / "run").reconstructions
    loaded = trimesh.load(snapshot.path, process=False)
    np.testing.assert_array_equal(loaded.vertices, sphere.vertices)
    np.testing.assert_array_equal(loaded.faces, sphere.faces)


def test_metadata_round_trip_and_format_fields(written):
    session = read_session(written["directory"])
    metadata = session.metadata
    assert metadata["format"] == "tactile-explore-session"
    assert metadata["format_version"] == 1
    assert metadata["robot"] == METADATA["robot"]
    assert metadata["object"]["position_m"] == [0.5, 0.0, 0.1]
    assert metadata["configuration"]["contact_threshold_pa"] == 100.0
    assert metadata["seed"] == 42
    assert metadata["package_versions"]["numpy"] == np.__version__
    assert metadata["start_time_utc"] <= metadata["end_time_utc"]
    assert session.closed_cleanly
    assert session.truncated_files == ()


def test_an_empty_session_reads_as_empty(tmp_path):
    SessionWriter(tmp_path / "run", METADATA).close()
    session = read_session(tmp_path / "run")
    assert len(session.readings) == 0 and session.readings.quat_wxyz.shape == (0, 4)
    assert session.joint_states.t_s.shape == (0,) and session.joint_states.q.shape == (0, 0)
    assert session.contacts == () and session.events == () and session.reconstructions == ()


def test_exception_inside_the_with_block_marks_the_session_aborted(tmp_path):
    with pytest.raises(KeyError):
        with SessionWriter(tmp_path / "run", METADATA) as writer:
            writer.write_event("contact_start", 1.0)
            raise KeyError("lost the arm")
    session = read_session(tmp_path / "run")
    assert session.metadata["end_status"] == "aborted"
    assert session.metadata["end_error"] == "KeyError: 'lost the arm'"
    assert not session.closed_cleanly
    assert [e.kind for e in session.events] == ["contact_start"]
