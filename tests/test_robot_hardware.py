"""SerialArm / HardwareArm against the emulated controller: protocol, motions, watchdog, limits, FK."""
from __future__ import annotations

import math
import re
from functools import reduce
from pathlib import Path

import numpy as np
import pytest

import robots
from robots.emulators import ArmFault, EmulatedArmController, FakeArmSerial
from robots.hardware import (ControllerStatus, ErrorCode, HardwareArm, JointInterface, RobotCommandError,
                             RobotFaultError, RobotNotOpenError, RobotProtocolError, SerialArm)
from robots.hardware import protocol
from robots.sim_arm import MoveNotReachedError
from sensor.emulators import FakeClock

DOCS = Path(__file__).resolve().parents[1] / "docs"
RESOLUTION = 1e-4


@pytest.fixture(scope="module")
def spec():
    return robots.load("armar3")


@pytest.fixture
def rig(spec):
    """(arm, controller, port, clock) on a fake clock, arm not yet open."""
    clock = FakeClock()
    controller = EmulatedArmController.for_spec(spec, clock=clock.monotonic, encoder_resolution_rad=RESOLUTION)
    port = FakeArmSerial(controller, clock=clock, port="/dev/ttyTEST")
    arm = SerialArm(port, spec, clock=clock.monotonic, sleep=clock.sleep)
    return arm, controller, port, clock


def _delta(spec, degrees=(6.0, 5.0, -4.0, 8.0, -3.0, 2.0, -5.0)):
    return spec.home_q + np.radians(degrees)


# ---- protocol ------------------------------------------------------------------------------

def test_checksum_matches_a_published_nmea_sentence():
    # a widely quoted GPS sentence and its checksum, 0x76
    body = b"GPGGA,092750.000,5321.6802,N,00630.3372,W,1,8,1.03,61.7,M,55.2,M,,"
    assert protocol.checksum(body) == 0x76
    assert protocol.decode_frame(b"$" + body + b"*76\r\n")[0] == "GPGGA"


def test_frames_round_trip_and_carry_the_xor_checksum():
    frame = protocol.encode_request(protocol.Command.SETQ, 7, np.array([0.1, -1.25, 3.0]))
    assert frame == b"$SETQ,7,0.100000,-1.250000,3.000000*" + frame[-4:-2] + b"\r\n"
    body = frame[1:frame.index(b"*")]
    assert int(frame[-4:-2], 16) == reduce(lambda a, b: a ^ b, body, 0)
    request = protocol.parse_request(protocol.decode_frame(frame))
    assert request.command is protocol.Command.SETQ and request.seq == 7
    np.testing.assert_allclose(request.q, [0.1, -1.25, 3.0])
    reply = protocol.parse_reply(protocol.decode_frame(
        protocol.encode_encoder_reply(7, 2**32 + 5, ControllerStatus.TRACKING, np.array([0.5, -0.25]))))
    assert reply == protocol.EncoderReply(7, 5, ControllerStatus.TRACKING, reply.q)
    np.testing.assert_allclose(reply.q, [0.5, -0.25])


@pytest.mark.parametrize("line, kind", [
    (b"$GETQ,1*00", "checksum"),
    (b"GETQ,1*5A", "malformed"),
    (b"$GETQ,1", "malformed"),
    (b"$GETQ,1*G1", "malformed"),
])
def test_bad_frames_are_rejected_by_kind(line, kind):
    with pytest.raises(protocol.FrameError) as info:
        protocol.decode_frame(line)
    assert info.value.kind == kind


def test_noise_before_a_frame_on_the_same_line_is_skipped():
    frame = protocol.encode_ack(3, ControllerStatus.IDLE)
    assert protocol.parse_reply(protocol.decode_frame(b"\x00\xff$Q,1,2" + frame)) == protocol.AckReply(3, 0)


def test_every_frame_in_the_protocol_document_checks_out():
    text = (DOCS / "ROBOT_PROTOCOL.md").read_text()
    frames = re.findall(r"\$[A-Z]+,[^*\n`]*\*[0-9A-F]{2}", text)
    assert len(frames) >= 20
    for frame in frames:
        fields = protocol.decode_frame(frame.encode())
        if fields[0] in {c.value for c in protocol.Command}:
            protocol.parse_request(fields)
        else:
            protocol.parse_reply(fields)


# ---- emulated controller -------------------------------------------------------------------

def test_controller_joints_follow_a_first_order_lag(spec):
    clock = FakeClock()
    controller = EmulatedArmController.for_spec(spec, clock=clock.monotonic, encoder_resolution_rad=0.0,
                                                time_constant_s=0.05, watchdog_s=10.0)
    q0, target = spec.home_q, _delta(spec)
    assert controller.handle_line(protocol.encode_request(protocol.Command.SETQ, 1, target)).startswith(b"$OK,1,1*")
    clock.advance(0.08)
    expected = target + (q0 - target) * math.exp(-0.08 / 0.05)
    np.testing.assert_allclose(controller.true_q, expected, atol=1e-6)  # SETQ carries 6 decimals


def test_controller_watchdog_holds_the_position_reached_at_the_timeout(spec):
    clock = FakeClock()
    controller = EmulatedArmController.for_spec(spec, clock=clock.monotonic, encoder_resolution_rad=0.0,
                                                time_constant_s=0.1, watchdog_s=0.2)
    q0, target = spec.home_q, _delta(spec, (30.0, 30.0, -30.0, 30.0, -30.0, 20.0, -30.0))
    controller.handle_line(protocol.encode_request(protocol.Command.SETQ, 1, target))
    clock.advance(1.0)
    held = target + (q0 - target) * math.exp(-0.2 / 0.1)
    np.testing.assert_allclose(controller.true_q, held, atol=1e-6)
    assert controller.status == ControllerStatus.WATCHDOG_HOLD and controller.watchdog_trips == 1
    refused = protocol.parse_reply(protocol.decode_frame(
        controller.handle_line(protocol.encode_request(protocol.Command.SETQ, 2, target))))
    assert refused.code == ErrorCode.WATCHDOG_TRIPPED
    controller.handle_line(protocol.encode_request(protocol.Command.STOP, 3))
    assert controller.status == ControllerStatus.IDLE


def test_controller_refuses_targets_outside_its_limits_and_keeps_the_old_target(spec):
    clock = FakeClock()
    controller = EmulatedArmController.for_spec(spec, clock=clock.monotonic)
    outside = spec.home_q.copy()
    outside[2] = controller.upper_rad[2] + 0.01
    reply = protocol.parse_reply(protocol.decode_frame(
        controller.handle_line(protocol.encode_request(protocol.Command.SETQ, 4, outside))))
    assert reply.code == ErrorCode.OUT_OF_LIMITS and "[2]" in reply.text
    np.testing.assert_array_equal(controller.target, spec.home_q)


def test_encoders_are_quantised(spec):
    clock = FakeClock()
    controller = EmulatedArmController.for_spec(spec, clock=clock.monotonic, encoder_resolution_rad=1e-3)
    steps = controller.encoder_q / 1e-3
    np.testing.assert_allclose(steps, np.round(steps), atol=1e-9)
    assert np.max(np.abs(controller.encoder_q - controller.true_q)) <= 0.5e-3 + 1e-12


# ---- SerialArm -----------------------------------------------------------------------------

def test_constructor_does_no_io_and_use_before_open_is_an_error(rig):
    arm, controller, port, clock = rig
    assert port.requests == []
    with pytest.raises(RobotNotOpenError, match="/dev/ttyTEST.*open"):
        arm.joint_positions()


def test_open_checks_the_controller_dof(spec):
    clock = FakeClock()
    controller = EmulatedArmController(np.full(6, -1.0), np.full(6, 1.0), clock=clock.monotonic)
    arm = SerialArm(FakeArmSerial(controller, clock=clock), spec, clock=clock.monotonic, sleep=clock.sleep)
    with pytest.raises(RobotProtocolError, match="6 joints.*7"):
        arm.open()


def test_a_port_without_read_timeout_is_refused(rig, spec):
    arm, controller, port, clock = rig
    port.timeout = None
    with pytest.raises(ValueError, match="no read timeout"):
        arm.open()


def test_move_joints_reaches_the_target_at_the_requested_speed(rig, spec):
    arm, controller, port, clock = rig
    target = _delta(spec)
    with arm:
        start_time = clock.now
        arm.move_joints(target, speed_rad_s=0.5)
        elapsed = clock.now - start_time
        q = arm.joint_positions()
    assert np.max(np.abs(q - target)) <= arm.reached_tolerance_rad
    assert np.max(np.abs(controller.true_q - target)) <= arm.reached_tolerance_rad + RESOLUTION
    planned = np.max(np.abs(target - spec.home_q)) / 0.5
    assert planned <= elapsed <= planned + 0.2  # streaming plus the first-order lag settling
    setq = [protocol.parse_request(protocol.decode_frame(r)).q for r in port.requests if r.startswith(b"$SETQ")]
    steps = np.max(np.abs(np.diff(setq, axis=0)), axis=1)
    assert np.max(steps) <= 0.5 * arm.control_period_s * 1.01 + 1e-6  # fastest joint at 0.5 rad/s
    assert controller.status == ControllerStatus.IDLE and not controller.is_moving
    assert port.requests[-1].startswith(b"$STOP")  # close() leaves the arm holding


def test_move_joints_that_cannot_reach_raises_move_not_reached(rig, spec):
    arm, controller, port, clock = rig
    controller.time_constant_s = 5.0  # a sluggish arm: cannot settle within settle_timeout_s
    with arm, pytest.raises(MoveNotReachedError, match="deg away"):
        arm.move_joints(_delta(spec), speed_rad_s=1.0)
    assert not controller.status == ControllerStatus.TRACKING


def test_guarded_move_stops_when_the_predicate_fires_and_holds(rig, spec):
    arm, controller, port, clock = rig
    via, end = _delta(spec, (3, 3, 3, 3, 3, 3, 3)), _delta(spec, (6, 6, 6, 6, 6, 6, 6))
    calls = []

    def stop():
        calls.append(clock.now)
        return controller.true_q[0] >= spec.home_q[0] + np.radians(4.5)

    with arm:
        result = arm.guarded_move(np.array([via, end]), stop, speed_rad_s=0.2)
        assert result.stopped and result.waypoint_index == 1
        assert controller.status == ControllerStatus.IDLE
        q_stop = controller.true_q
        np.testing.assert_allclose(result.q, controller.encoder_q, atol=1e-6)
        clock.advance(1.0)
        np.testing.assert_array_equal(controller.true_q, q_stop)  # held
    assert np.degrees(q_stop[0] - spec.home_q[0]) == pytest.approx(4.5, abs=0.2)
    ticks = np.diff(calls)
    np.testing.assert_allclose(ticks, arm.control_period_s, atol=0.011)  # one stop() call per tick


def test_guarded_move_to_the_end_reports_not_stopped(rig, spec):
    arm, controller, port, clock = rig
    end = _delta(spec)
    with arm:
        result = arm.guarded_move(end[None], lambda: False, speed_rad_s=1.0)
    assert not result.stopped and result.waypoint_index == 0
    assert np.max(np.abs(result.q - end)) <= arm.reached_tolerance_rad


def test_an_error_in_the_predicate_stops_the_arm_and_propagates(rig, spec):
    arm, controller, port, clock = rig

    def stop():
        if clock.now > 0.1:
            raise KeyError("sensor gone")
        return False

    with arm:
        with pytest.raises(KeyError, match="sensor gone"):
            arm.guarded_move(_delta(spec)[None], stop, speed_rad_s=0.5)
        assert port.requests[-1].startswith(b"$STOP")
        assert controller.status == ControllerStatus.IDLE


@pytest.mark.parametrize("path, speed, error", [
    (np.zeros((0, 7)), 0.2, "shape"),
    (np.zeros((1, 6)), 0.2, "shape"),
    (None, 0.0, "speed_rad_s must be positive"),
    (None, -1.0, "speed_rad_s must be positive"),
])
def test_guarded_move_rejects_bad_input(rig, spec, path, speed, error):
    arm, controller, port, clock = rig
    path = spec.home_q[None] if path is None else path
    with arm, pytest.raises(ValueError, match=error):
        arm.guarded_move(path, lambda: False, speed_rad_s=speed)


def test_targets_outside_the_urdf_limits_are_refused_before_anything_is_sent(rig, spec):
    arm, controller, port, clock = rig
    q = spec.home_q.copy()
    q[5] = math.radians(45.0)
    with arm:
        sent = len(port.requests)
        with pytest.raises(ValueError, match=r"wrist_1 = 45.00 deg not in \[-29"):
            arm.move_joints(q)
        assert len(port.requests) == sent


def test_a_controller_with_narrower_limits_refuses_with_a_named_error(spec):
    clock = FakeClock()
    controller = EmulatedArmController.for_spec(spec, clock=clock.monotonic)
    controller.upper_rad = spec.home_q + 0.01
    arm = SerialArm(FakeArmSerial(controller, clock=clock), spec, clock=clock.monotonic, sleep=clock.sleep)
    with arm, pytest.raises(RobotCommandError, match="SETQ refused with OUT_OF_LIMITS") as info:
        arm.move_joints(_delta(spec))
    assert info.value.code == ErrorCode.OUT_OF_LIMITS and "during move_joints" in str(info.value)


def test_a_latched_fault_needs_its_cause_removed_before_clear(rig, spec):
    arm, controller, port, clock = rig
    with arm:
        port.faults.inject(ArmFault.DRIVE_FAULT, command="GETQ")
        with pytest.raises(RobotFaultError, match="DRIVE_FAULT") as info:
            arm.joint_positions()
        assert info.value.status == ControllerStatus.DRIVE_FAULT
        with pytest.raises(RobotCommandError, match="FAULT_PERSISTS"):
            arm.clear_fault()
        with pytest.raises(RobotFaultError, match="DRIVE_FAULT.*during move_joints; STOP sent"):
            arm.move_joints(_delta(spec))
        with pytest.raises(RobotFaultError, match="SETQ refused: controller fault DRIVE_FAULT"):
            arm.joints.command(_delta(spec))
        controller.fault_cause_present = False
        arm.clear_fault()
        arm.move_joints(_delta(spec))
    assert np.max(np.abs(controller.true_q - _delta(spec))) <= arm.reached_tolerance_rad + RESOLUTION


def test_close_leaves_a_caller_owned_port_open(rig):
    arm, controller, port, clock = rig
    arm.open()
    arm.close()
    arm.close()
    assert port.is_open and port.requests[-1].startswith(b"$STOP")
    with pytest.raises(RobotNotOpenError):
        arm.joint_positions()


def test_port_by_url_opens_and_closes_the_emulator(spec):
    pytest.importorskip("serial")
    arm = SerialArm("armemu://armar3", spec, settle_timeout_s=0.5)
    with arm:
        emulator = arm.joints._port.emulator
        np.testing.assert_allclose(arm.joint_positions(), spec.home_q, atol=1e-4)
        target = _delta(spec, (1.0, -1.0, 1.0, -1.0, 1.0, -1.0, 1.0))
        arm.move_joints(target, speed_rad_s=1.0)  # real time: about 30 ms
        assert arm.link_stats.timeouts == 0
    assert not emulator.is_open
    np.testing.assert_allclose(emulator.controller.true_q, target, atol=arm.reached_tolerance_rad + 1e-4)


def test_encoder_values_are_what_forward_kinematics_uses(spec):
    from robots.kinematics import ArmKinematics
    clock = FakeClock()
    resolution = 2 * math.pi / 2**12  # a coarse 12-bit encoder makes quantisation visible
    controller = EmulatedArmController.for_spec(spec, clock=clock.monotonic, encoder_resolution_rad=resolution)
    arm = SerialArm(FakeArmSerial(controller, clock=clock), spec, clock=clock.monotonic, sleep=clock.sleep,
                    reached_tolerance_rad=resolution)
    kinematics = ArmKinematics(spec)
    with arm:
        arm.move_joints(_delta(spec), speed_rad_s=1.0)
        q_encoders = arm.joint_positions()
    np.testing.assert_allclose(q_encoders, controller.encoder_q, rtol=0, atol=0.5e-6)  # 6 decimals on the wire
    steps = controller.encoder_q / resolution
    np.testing.assert_allclose(steps, np.round(steps), atol=1e-9)  # on the encoder grid
    q_true = controller.true_q
    pad_from_encoders = kinematics.forward_kinematics(q_encoders).position_m
    pad_true = kinematics.forward_kinematics(q_true).position_m
    jacobian = kinematics.jacobian(q_true)[:3]
    bound = np.sum(np.linalg.norm(jacobian, axis=0)) * resolution / 2  # every joint half a step off
    error = np.linalg.norm(pad_from_encoders - pad_true)
    assert 0.0 < error <= bound


class ListJoints(JointInterface):
    """A minimal adapter: the plug-in point a ROS/vendor adapter uses (here an ideal arm)."""

    def __init__(self, q):
        self.q = np.array(q, dtype=float)
        self.log = []

    device = "arm in memory"
    dof = 7

    def open(self):
        self.log.append("open")

    def close(self):
        self.log.append("close")

    def read_encoders(self):
        return 0.0, self.q.copy()

    def command(self, q):
        self.q = np.array(q)
        self.log.append("command")

    def stop(self):
        self.log.append("stop")


def test_hardware_arm_runs_on_any_joint_interface(spec):
    joints = ListJoints(spec.home_q)
    clock = FakeClock()
    arm = HardwareArm(joints, spec, clock=clock.monotonic, sleep=clock.sleep)
    with arm:
        arm.move_joints(_delta(spec), speed_rad_s=1.0)
    np.testing.assert_allclose(joints.q, _delta(spec))
    assert joints.log[0] == "open" and joints.log[-2:] == ["stop", "close"]


def test_the_adapter_skeleton_in_the_docs_is_a_complete_joint_interface(spec):
    text = (DOCS / "HARDWARE.md").read_text()
    code = re.search(r"```python\n(# adapter skeleton.*?)```", text, re.S).group(1)
    namespace = {}
    exec(compile(code, "HARDWARE.md", "exec"), namespace)
    adapter_class = namespace["MyRobotJoints"]
    assert issubclass(adapter_class, JointInterface) and not adapter_class.__abstractmethods__
    arm = HardwareArm(adapter_class(dof=spec.dof), spec)  # constructing does no I/O
    assert arm.device.startswith("arm")


def test_an_encoder_reading_past_a_limit_is_not_commanded_back_to_the_controller(spec):
    """Found by the emulated dry run: at a limit the quantised encoder reads up to a step past it,
    and targets interpolated from there were refused (OUT_OF_LIMITS) mid guarded move."""
    clock = FakeClock()
    upper = EmulatedArmController.for_spec(spec).upper_rad
    past = np.round(upper / RESOLUTION) * RESOLUTION - upper
    joint = int(np.argmax(past))
    assert past[joint] > 1e-6, "no joint limit rounds past itself at this encoder resolution"
    at_limit = spec.home_q.copy()
    at_limit[joint] = upper[joint]
    controller = EmulatedArmController.for_spec(spec, clock=clock.monotonic, encoder_resolution_rad=RESOLUTION,
                                                q_init_rad=at_limit)
    arm = SerialArm(FakeArmSerial(controller, clock=clock, port="/dev/ttyTEST"), spec, clock=clock.monotonic,
                    sleep=clock.sleep)
    back = at_limit.copy()
    back[joint] -= 0.05
    with arm:
        assert arm.joint_positions()[joint] > upper[joint] + 1e-6  # the encoder reads past the limit
        arm.hold(0.05)
        result = arm.guarded_move(np.array([at_limit, back]), stop=lambda: False, speed_rad_s=0.5)
    assert not result.stopped
    assert abs(result.q[joint] - back[joint]) < 3e-3
