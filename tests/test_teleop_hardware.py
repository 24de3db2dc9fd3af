"""Human-guided exploration on the hardware backend: the arm is in compliant mode and moved by a
person (here: a script setting the emulated controller's joints); the teleop session only reads
encoders and the sensor, and records the contacts."""
import numpy as np
import pytest

import robots
from explorer.positioner import FixedStand
from explorer.rig import Rig
from explorer.teleop.devices import InputDevice, TeleopCommand
from explorer.teleop.controller import TeleopConfig, TeleopController
from explorer.touch import ObjectPrior
from explorer.contact_world import VirtualSphere, emulated_rig
from robots.hardware.compliant import CompliantArm, CompliantModeError
from robots.ik import PadIK

RADIUS = 0.05


class HandsOff(InputDevice):
    """The person guides the arm itself: no jog commands."""

    def _poll(self) -> TeleopCommand:
        return TeleopCommand()


def _guided_poses(kinematics, centre, directions, count=3):
    """Per touch: joint configurations with the pad 1.5 cm off and 0.6 mm into the sphere, for
    the first ``count`` outward directions the arm can reach."""
    ik = PadIK(kinematics)
    poses = []
    for outward in directions:
        outward = np.asarray(outward, float) / np.linalg.norm(outward)
        points = centre + np.outer([RADIUS + 0.015, RADIUS - 0.0006], outward)
        result = ik.solve(points, -np.tile(outward, (2, 1)), kinematics.spec.home_q)
        if result.success.all():
            poses.append(result.q_rad)
        if len(poses) == count:
            return poses
    raise AssertionError(f"only {len(poses)} of the test's directions are reachable")


def test_hand_guided_touches_are_recorded_without_commanding_the_arm():
    spec = robots.load("armar3")
    centre = np.asarray(spec.workspace_center_m, float)
    rig = emulated_rig(spec, VirtualSphere(centre, RADIUS), noise_pa=1.0)
    kinematics = rig.world.kinematics
    candidates = [(-1, 0, 0.3), (-0.6, 0.6, 0.4), (-0.7, -0.5, 0.5), (-0.8, 0.2, 0.6), (-0.5, -0.3, 0.8),
                  (-0.9, 0.3, 0.0), (-0.6, 0.0, 0.8), (-0.8, -0.4, 0.2)]
    poses = _guided_poses(kinematics, centre, candidates)
    schedule = []  # (start time, joint target) as the person moves: off, in (dwell), off
    t = 0.5
    for off, touching in poses:
        schedule += [(t, off), (t + 1.0, touching), (t + 2.5, off)]
        t += 3.5

    with rig.arm as arm, rig.sensor as sensor:
        start = rig.clock.monotonic()
        sleep = arm.sleep

        def person_then_sleep(seconds):
            now = rig.clock.monotonic() - start
            due = [q for t_s, q in schedule if t_s <= now]
            if due:
                rig.controller.target = np.array(due[-1])
            sleep(seconds)

        arm.sleep = person_then_sleep
        compliant = CompliantArm(arm)
        with pytest.raises(CompliantModeError):
            compliant.move_joints(spec.home_q)
        commands_before = rig.controller.commands.get("SETQ", 0)
        teleop_rig = Rig(compliant, sensor, kinematics, FixedStand(centre),
                         ObjectPrior(np.zeros(3), np.full(3, 0.06)), None, {})
        session = TeleopController(teleop_rig, config=TeleopConfig())
        with HandsOff() as device:
            contacts = session.run(device, max_duration_s=t)
        assert rig.controller.commands.get("SETQ", 0) == commands_before  # never commanded

    assert len(contacts) == len(poses)
    for contact in contacts:
        assert abs(np.linalg.norm(contact.position_m) - RADIUS) < 1.5e-3
        radial = contact.position_m / np.linalg.norm(contact.position_m)
        assert np.degrees(np.arccos(np.clip(contact.normal @ radial, -1, 1))) < 3.0
    assert session.gpis.n_contacts == len(poses)
