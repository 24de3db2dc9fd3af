"""The exploration loop, unchanged, on the hardware backend: SerialArm and HardwareTactileSensor on emulators.

A ContactWorld couples the emulated arm controller to the emulated BMP280/BNO055 through a virtual
sphere, so every byte goes through the real line protocol and the real chip drivers.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import robots
from explorer.loop import ExplorationLoop, LoopConfig
from explorer.planner import ApproachPlanner, PlannerConfig
from explorer.positioner import FixedStand
from explorer.recording import RunRecorder, read_contacts_csv
from explorer.rig import Rig
from explorer.strategies import make_strategy
from explorer.touch import ObjectPrior
from reconstruction.gpis import GPIS
from explorer.contact_world import VirtualSphere, aligned_rotation, emulated_rig
from robots.ik import PadIK
from robots.kinematics import ArmKinematics
from sensor.sim.pad_response import PadResponse
from common.rotations import rotation_from_wxyz

RADIUS_M = 0.05
AMBIENT_PA = 100_900.0


@pytest.fixture(scope="module")
def spec():
    return robots.load("armar3")


@pytest.fixture(scope="module")
def kinematics(spec):
    return ArmKinematics(spec)


def _pad_at_home(spec, kinematics):
    pad = kinematics.forward_kinematics(spec.home_q, link=spec.pad_link)
    return pad.position_m, pad.rotation


# ---- the contact world on its own ------------------------------------------------------------

def test_free_pad_reads_ambient_pressure_and_the_commanded_orientation(spec, kinematics):
    pad_m, pad_rotation = _pad_at_home(spec, kinematics)
    far = VirtualSphere(pad_m + np.array([0.0, 0.0, 0.5]), RADIUS_M)
    rig = emulated_rig(spec, far, kinematics=kinematics, noise_pa=0.0, ambient_pa=AMBIENT_PA)
    assert rig.world.state.normal is None and rig.world.state.force_n == 0.0
    with rig.sensor:
        reading = rig.sensor.read()
    assert reading.pressure_pa == pytest.approx(AMBIENT_PA, abs=1.0)
    body = rotation_from_wxyz(reading.quat_wxyz).as_matrix()
    np.testing.assert_allclose(body, pad_rotation, atol=1e-3)  # chip quaternions are 1/2^14 steps


def test_penetration_sets_force_and_pressure_by_stiffness_and_the_pad_response(spec, kinematics):
    pad_m, pad_rotation = _pad_at_home(spec, kinematics)
    depth_m = 0.5e-3
    # sphere straight ahead of the pad face (+z of the pad points into the object), pad 0.5 mm inside
    centre = pad_m + pad_rotation[:, 2] * (RADIUS_M - depth_m)
    rig = emulated_rig(spec, VirtualSphere(centre, RADIUS_M), kinematics=kinematics, noise_pa=0.0,
                       ambient_pa=AMBIENT_PA, stiffness_n_per_m=3000.0)
    state = rig.world.state
    assert state.penetration_m == pytest.approx(depth_m, abs=1e-6)
    assert state.force_n == pytest.approx(1.5, rel=1e-3)
    expected_rise = 3000.0 * (1.0 - np.exp(-1.5 / 5.0))  # P_sat (1 - exp(-F / F0)), default pad
    assert expected_rise == pytest.approx(PadResponse().pressure_rise_pa(1.5))
    with rig.sensor:
        reading = rig.sensor.read()
    assert reading.pressure_pa - AMBIENT_PA == pytest.approx(expected_rise, abs=1.0)
    np.testing.assert_allclose(state.normal, -pad_rotation[:, 2], atol=1e-6)


def test_the_spring_aligns_the_body_with_a_tilted_surface_and_keeps_its_roll(spec, kinematics):
    pad_m, pad_rotation = _pad_at_home(spec, kinematics)
    z = pad_rotation[:, 2]
    sideways = pad_rotation[:, 0]
    tilt = np.radians(10.0)
    # the surface normal at the pad is tilted 10 deg from -z towards x
    normal = -(np.cos(tilt) * z) + np.sin(tilt) * sideways
    centre = pad_m - normal * (RADIUS_M - 0.3e-3)
    rig = emulated_rig(spec, VirtualSphere(centre, RADIUS_M), kinematics=kinematics, noise_pa=0.0)
    state = rig.world.state
    assert state.force_n > 0.0
    np.testing.assert_allclose(state.body_rotation[:, 2], -state.normal, atol=1e-9)
    assert np.degrees(np.arccos(np.dot(state.normal, normal))) < 1.0
    turn = Rotation.from_matrix(state.body_rotation @ pad_rotation.T).as_rotvec()
    assert np.linalg.norm(turn) == pytest.approx(np.arccos(np.dot(-state.normal, z)), abs=1e-9)
    assert abs(np.dot(turn, z)) < 1e-9  # no twist about the face axis
    with rig.sensor:
        reading = rig.sensor.read()
    measured_normal = -rotation_from_wxyz(reading.quat_wxyz).apply([0.0, 0.0, 1.0])
    assert np.degrees(np.arccos(np.clip(np.dot(measured_normal, state.normal), -1, 1))) < 0.1


def test_aligned_rotation_refuses_a_pad_facing_away():
    with pytest.raises(ValueError, match="faces straight away"):
        aligned_rotation(np.eye(3), np.array([0.0, 0.0, 1.0]))


def test_bad_world_settings_are_refused(spec, kinematics):
    with pytest.raises(ValueError, match="radius_m"):
        VirtualSphere(np.zeros(3), 0.0)
    with pytest.raises(ValueError, match="centre_m"):
        VirtualSphere(np.zeros(2), 0.05)
    with pytest.raises(ValueError, match="stiffness_n_per_m"):
        emulated_rig(spec, VirtualSphere(np.zeros(3), 0.05), kinematics=kinematics, stiffness_n_per_m=-1.0)


# ---- the loop end to end ------------------------------------------------------------------------

def test_exploration_loop_on_the_hardware_backend_touches_the_virtual_sphere(spec, kinematics, tmp_path,
                                                                             one_torch_thread):
    centre = np.asarray(spec.workspace_center_m, dtype=float)
    rig = emulated_rig(spec, VirtualSphere(centre, RADIUS_M), kinematics=kinematics)
    stand = FixedStand(centre)
    prior = ObjectPrior(np.zeros(3), np.full(3, 0.06))
    planner = ApproachPlanner(kinematics, PadIK(kinematics), stand, prior, PlannerConfig())
    gpis = GPIS(bounds=prior.bounds())
    metadata = dict(robot=spec.name, sensor="emulated BMP280 + BNO055 on a fake I2C bus",
                    object=f"virtual sphere r = {RADIUS_M * 1e3:.0f} mm", seed=0, backend="hardware emulators")
    recorder = RunRecorder(tmp_path, metadata)
    with rig.arm, rig.sensor:
        loop = ExplorationLoop(Rig(rig.arm, rig.sensor, kinematics, stand, prior, None, metadata), planner,
                               make_strategy("variance"), gpis, LoopConfig(touches=5), recorder)
        records = loop.run()
    mesh = gpis.mesh(resolution=24)
    recorder.reconstruction(mesh, gpis.n_contacts, rig.clock.monotonic())
    recorder.close()

    assert len(records) == 5
    contacts = loop.contacts
    assert len(contacts) >= 3, [r.kind for r in records]
    for record in contacts:
        radial = record.position_m / np.linalg.norm(record.position_m)  # object frame: sphere at the origin
        assert abs(np.linalg.norm(record.position_m) - RADIUS_M) < 1.5e-3
        assert np.degrees(np.arccos(np.clip(np.dot(record.normal, radial), -1.0, 1.0))) < 3.0
        assert 0.1 < record.contact.force_n < 7.0
        assert record.contact.t_s <= rig.clock.monotonic()
    # the press really went through the protocol and the chips
    assert rig.controller.commands["SETQ"] > 100
    assert 1.0 < rig.world.max_force_n < 7.0
    assert gpis.n_contacts == len(contacts)
    assert len(mesh.vertices) > 0 and len(mesh.faces) > 0
    lo, hi = prior.bounds()
    assert np.all(mesh.vertices >= lo - 1e-9) and np.all(mesh.vertices <= hi + 1e-9)

    points, normals = read_contacts_csv(tmp_path / "contacts.csv")
    np.testing.assert_array_equal(points, np.array([r.position_m for r in contacts]))
    np.testing.assert_array_equal(normals, np.array([r.normal for r in contacts]))
    assert (tmp_path / "session").is_dir()



# ---- a device that fails mid-run, and the resumed run ------------------------------------------

def _rig_for_run(spec, kinematics, sphere_centre):
    emulated = emulated_rig(spec, VirtualSphere(sphere_centre, RADIUS_M), kinematics=kinematics)
    prior = ObjectPrior(np.zeros(3), np.full(3, 0.06))
    rig = Rig(emulated.arm, emulated.sensor, kinematics, FixedStand(sphere_centre), prior, None,
              dict(robot=spec.name, sensor="emulated BMP280 + BNO055", object="virtual sphere", backend="emulators"))
    return emulated, rig


def _inject_sensor_disconnect(emulated):
    from sensor.emulators.faults import Fault
    emulated.bus.faults.inject(Fault.DISCONNECT)


def _inject_arm_link_silent(emulated):
    from robots.emulators.arm_serial import ArmFault
    emulated.port.faults.inject(ArmFault.SILENT, after=30)  # part-way through the next move


@pytest.mark.parametrize("inject, device_words", [(_inject_sensor_disconnect, ("I2C", "0x")),
                                                  (_inject_arm_link_silent, ("arm",))],
                         ids=["sensor-bus-disconnect", "arm-link-silent"])
def test_a_device_failing_mid_run_stops_the_arm_keeps_the_records_and_the_run_resumes(
        spec, kinematics, tmp_path, one_torch_thread, inject, device_words):
    import json

    from explorer.run import RunSettings, run_on_rig
    from explorer.session import read_session

    centre = np.asarray(spec.workspace_center_m, dtype=float)
    settings = RunSettings(object="virtual sphere", robot=spec.name, touches=6, eval_every=0, mesh_resolution=24,
                           reach_samples=0)
    emulated, rig = _rig_for_run(spec, kinematics, centre)
    finished = []

    def fail_after_three(record):
        finished.append(record)
        if record.index == 2:
            inject(emulated)

    with emulated.arm, emulated.sensor:
        with pytest.raises(Exception) as failure:
            run_on_rig(rig, settings, tmp_path, progress=fail_after_three)
        moving_after_failure = emulated.controller.is_moving
    error = failure.value
    device = getattr(error, "device", "")
    assert all(word in device for word in device_words), (type(error), str(error))
    assert 3 <= len(finished) < 6
    assert not moving_after_failure  # stopped, not left tracking a stale target
    print(f"{type(error).__name__}: {error}")

    recorded_contacts = [r for r in finished if r.kind == "contact"]
    points, _ = read_contacts_csv(tmp_path / "contacts.csv")
    assert len(points) == len(recorded_contacts) >= 2
    np.testing.assert_array_equal(points, [r.position_m for r in recorded_contacts])
    metrics = json.loads((tmp_path / "metrics.json").read_text())
    assert metrics["completed"] is False and metrics["error"]["device"] == device
    session = read_session(tmp_path / "session")
    assert session.metadata["end_status"] == "aborted" and device in session.metadata["end_error"]
    assert [e.fields["source"] for e in session.events if e.kind == "error"] == [device]
    assert len(session.contacts) == len(recorded_contacts)

    # the device is back (a fresh emulator, its clock from zero again): the run goes on to its budget
    emulated, rig = _rig_for_run(spec, kinematics, centre)
    with emulated.arm, emulated.sensor:
        result = run_on_rig(rig, settings, tmp_path, resume=True)
    assert len(result.records) == 6 and result.metrics["completed"], [r.kind for r in result.records]
    resumed_points, _ = read_contacts_csv(tmp_path / "contacts.csv")
    np.testing.assert_array_equal(resumed_points[:len(points)], points)
    assert len(resumed_points) == sum(r.kind == "contact" for r in result.records) > len(points), [r.kind for r in result.records]
    for position in resumed_points:
        assert abs(np.linalg.norm(position) - RADIUS_M) < 1.5e-3
    session = read_session(tmp_path / "session")  # times checked non-decreasing by the reader
    assert session.metadata["end_status"] == "closed"


def test_the_calibrated_imu_mounting_is_applied_to_the_measured_normals(spec, kinematics, tmp_path, one_torch_thread):
    """An IMU mounted 12 deg off: normals are 12 deg off without its calibration and right with it."""
    from explorer.replay import ReplaySettings, SessionReplay
    from explorer.run import RunSettings, run_on_rig
    from sensor.normal_estimation import ImuAlignment
    from sensor.pad_calibration import PadCalibration
    from common.rotations import wxyz_from_rotation

    mounting = wxyz_from_rotation(Rotation.from_euler("x", 12.0, degrees=True))
    centre = np.asarray(spec.workspace_center_m, dtype=float)
    settings = RunSettings(object="virtual sphere", robot=spec.name, touches=3, eval_every=0, mesh_resolution=24,
                           reach_samples=0)
    errors = {}
    for name, alignment in (("uncalibrated", None), ("calibrated", ImuAlignment(body_in_imu_wxyz=tuple(mounting)))):
        emulated = emulated_rig(spec, VirtualSphere(centre, RADIUS_M), kinematics=kinematics,
                                body_in_imu_wxyz=mounting)
        rig = Rig(emulated.arm, emulated.sensor, kinematics, FixedStand(centre), ObjectPrior(np.zeros(3), np.full(3, 0.06)),
                  None, dict(robot=spec.name, sensor="emulated", object="sphere", backend="emulators"),
                  PadCalibration(alignment=alignment or ImuAlignment()))
        with emulated.arm, emulated.sensor:
            result = run_on_rig(rig, settings, tmp_path / name)
        contacts = [r for r in result.records if r.kind in ("contact", "realign")]
        assert contacts, [r.kind for r in result.records]
        if name == "calibrated":  # the recorded pad calibration (IMU mounting) is what replay uses
            replayed = SessionReplay(tmp_path / name).run(ReplaySettings(figures=False))
            assert replayed.notes == []
            np.testing.assert_array_equal(replayed.points_m, [r.position_m for r in result.records
                                                              if r.kind == "contact"])
        errors[name] = [np.degrees(np.arccos(np.clip(np.dot(r.normal, r.position_m / np.linalg.norm(r.position_m)),
                                                     -1, 1))) for r in contacts]
    assert max(errors["calibrated"]) < 3.0, errors
    assert min(errors["uncalibrated"]) > 8.0, errors
