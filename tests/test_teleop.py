"""A scripted operator guides the simulated fingertip through touches on the sphere (headless)."""
import json

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from explorer.session import read_session
from explorer.teleop.devices import ScriptedDevice, TeleopCommand, TimedCommand
from explorer.teleop.simulated import run_simulated_teleop

RADIUS_M = 0.05  # the registry sphere, centred on its frame's origin
TILTS_DEG = (0.0, 15.0, 15.0, 15.0)
AZIMUTHS_DEG = (0.0, 0.0, 120.0, 240.0)


def touch_normals(approach: np.ndarray) -> np.ndarray:
    """Surface normals to touch: facing the pad, then tilted 15 deg around it."""
    side = np.cross(approach, [0.0, 0.0, 1.0])
    side /= np.linalg.norm(side)
    up = np.cross(side, approach)
    normals = []
    for tilt, azimuth in zip(np.radians(TILTS_DEG), np.radians(AZIMUTHS_DEG)):
        axis = np.cos(azimuth) * side + np.sin(azimuth) * up
        normals.append(Rotation.from_rotvec(tilt * axis).apply(-approach))
    return np.array(normals)


def operator_script(context, standoff_m=0.015, speed_mps=0.02, press_mps=0.01, dwell_s=0.6):
    """Per touch: jog to a standoff before the point, move in until contact (and a little on: the
    session stops the push at its force limit), dwell, retract."""
    approach = context.approach_dir
    position = context.start_pad_m - context.object_origin_m
    steps = []
    for normal in touch_normals(approach):
        standoff = RADIUS_M * normal - standoff_m * approach
        travel = standoff - position
        duration = np.linalg.norm(travel) / speed_mps
        steps += [TimedCommand(duration, TeleopCommand(travel / duration)),
                  TimedCommand((standoff_m + 0.004) / press_mps, TeleopCommand(press_mps * approach)),
                  TimedCommand(dwell_s, TeleopCommand()),
                  TimedCommand(standoff_m / speed_mps, TeleopCommand(-speed_mps * approach))]
        position = standoff
    return steps


@pytest.fixture(scope="module")
def teleop(tmp_path_factory):
    out = tmp_path_factory.mktemp("teleop")
    return run_simulated_teleop("sphere", lambda ctx: ScriptedDevice(operator_script(ctx), ctx.clock),
                                out, gui=False)


def test_every_guided_touch_is_recorded_on_the_sphere(teleop):
    assert len(teleop.contacts) == len(TILTS_DEG)
    points = np.array([c.position_m for c in teleop.contacts])
    normals = np.array([c.normal for c in teleop.contacts])
    np.testing.assert_allclose(np.linalg.norm(points, axis=1), RADIUS_M, atol=2e-3)
    true_normals = points / np.linalg.norm(points, axis=1, keepdims=True)
    angles = np.degrees(np.arccos(np.clip(np.sum(normals * true_normals, axis=1), -1.0, 1.0)))
    assert np.all(angles < 10.0), angles
    spread = np.linalg.norm(points[1:] - points[0], axis=1)
    assert np.all(spread > 0.008)  # the tilted touches landed away from the first one


def test_the_reconstruction_exists_and_the_suggestion_is_away_from_the_touches(teleop):
    assert (teleop.out_dir / "reconstruction.ply").stat().st_size > 1000
    assert teleop.mesh is not None and len(teleop.mesh.vertices) > 100
    points = np.array([c.position_m for c in teleop.contacts])
    distances = np.linalg.norm(points - teleop.suggestion_m, axis=1)
    assert distances.min() > 0.03, distances  # the touches span about 2.6 cm of a 10 cm sphere
    summary = json.loads((teleop.out_dir / "teleop.json").read_text())
    np.testing.assert_allclose(summary["suggested_touch_m"], teleop.suggestion_m)


def test_the_session_records_everything_in_the_session_format(teleop):
    session = read_session(teleop.out_dir / "session")
    assert session.closed_cleanly and session.metadata["configuration"]["mode"] == "teleop"
    assert len(session.contacts) == len(teleop.contacts)
    kinds = [e.kind for e in session.events]
    assert kinds.count("touch") == kinds.count("suggested_touch") == kinds.count("contact_start") == 4
    for contact in session.contacts:  # each contact's readings are in the raw stream, in contact
        assert len(contact.readings) >= 10
    assert len(session.joint_states) > 100 and len(session.reconstructions) == 1
    csv = np.loadtxt(teleop.out_dir / "contacts.csv", delimiter=",", skiprows=1, ndmin=2)
    np.testing.assert_allclose(csv[:, 1:4], [c.position_m for c in teleop.contacts], rtol=0, atol=1e-12)


def test_headless_needs_a_script(capsys):
    from scripts.teleop import main

    with pytest.raises(SystemExit):
        main(["--object", "sphere", "--headless"])
    assert "--script" in capsys.readouterr().err


def test_the_command_plays_a_script_file_headless(tmp_path, capsys):
    from scripts.teleop import main

    script = tmp_path / "jog.json"
    script.write_text(json.dumps([{"duration_s": 0.3, "linear_mps": [-0.01, 0.0, 0.0]},
                                  {"duration_s": 0.2, "buttons": ["record"]}]))
    main(["--object", "sphere", "--headless", "--script", str(script), "--out", str(tmp_path / "out")])
    assert json.loads(capsys.readouterr().out.splitlines()[0]) == {"contacts": 0, "suggested_touch_m": None}
    session = read_session(tmp_path / "out" / "session")
    assert session.closed_cleanly and len(session.contacts) == 0
    assert session.readings.t_s[-1] - session.readings.t_s[0] == pytest.approx(0.5, abs=0.05)
