"""The simulated arm's hardware errors: joint calibration offsets, backlash, spring friction."""
from __future__ import annotations

import math

import numpy as np
import pytest

import robots
from robots.sim_arm import EncoderModel, SimArm
from robots.sim_world import SimWorld


@pytest.fixture(scope="module")
def spec():
    return robots.load("armar3")


@pytest.fixture
def world():
    with SimWorld(table=None) as sim:
        yield sim


def test_calibration_offset_moves_the_true_arm_while_the_encoders_read_the_command(world, spec):
    offsets = np.radians([0.5, -0.3, 0.2, 0.4, -0.6, 0.1, 0.3])
    arm = SimArm(world, spec, encoder=EncoderModel(offset_rad=tuple(offsets)))
    target = spec.home_q + np.radians([5, -5, 0, 5, 0, 0, 5])
    arm.move_joints(target, speed_rad_s=0.5)
    assert np.abs(arm.joint_positions() - target).max() < 2.5e-3
    assert np.abs(arm.true_joint_positions() - (target - offsets)).max() < 2.5e-3
    with pytest.raises(ValueError, match="offset_rad has 2 values"):
        SimArm(world, spec, encoder=EncoderModel(offset_rad=(0.1, 0.2)))


def test_an_offset_arm_reaches_every_software_limit_and_stops_at_its_mechanical_one(world, spec):
    from robots.sim_arm import MECHANICAL_STOP_MARGIN_RAD

    offsets = np.radians([0.5, -0.3, 0.2, 0.4, -0.6, 0.1, 0.3])
    arm = SimArm(world, spec, encoder=EncoderModel(offset_rad=tuple(offsets)))
    for limits in (arm.upper_rad, arm.lower_rad):  # the joint whose true stop the offset would cross first
        target = spec.home_q.copy()
        joint = int(np.argmin(offsets) if limits is arm.upper_rad else np.argmax(offsets))
        target[joint] = limits[joint]
        arm.move_joints(target, speed_rad_s=0.5)  # raised "stopped ... away" when the URDF stop was the true one
        assert abs(arm.joint_positions()[joint] - limits[joint]) < 2.5e-3
    arm.reset_joint_positions(spec.home_q)
    arm._command(arm.upper_rad + np.radians(5.0), np.zeros(arm.dof))  # past the software limit, as a fault would
    world.step(480)
    true_beyond = arm.true_joint_positions() - (arm.upper_rad - offsets)
    assert np.all(true_beyond < MECHANICAL_STOP_MARGIN_RAD + 2e-3)  # held by the stop, one margin beyond


def test_backlash_leads_the_reading_in_the_direction_of_motion(world, spec):
    backlash = math.radians(0.5)
    arm = SimArm(world, spec, encoder=EncoderModel(backlash_rad=backlash))
    up = spec.home_q + np.radians([0, 0, 0, 6, 0, 0, 0])
    arm.joint_positions()
    arm.move_joints(up, speed_rad_s=0.3)
    rising = arm.joint_positions() - arm.true_joint_positions()
    arm.move_joints(spec.home_q, speed_rad_s=0.3)
    falling = arm.joint_positions() - arm.true_joint_positions()
    assert rising[3] == pytest.approx(backlash / 2, abs=1e-9)
    assert falling[3] == pytest.approx(-backlash / 2, abs=1e-9)


def test_spring_friction_holds_the_module_against_torques_inside_its_band(spec):
    def turned_by(torque_nm, friction_nm):
        with SimWorld(table=None) as sim:
            arm = SimArm(sim, spec, spring_friction_nm=friction_nm)
            sim.step(120)
            before = arm.spring_angles()
            axis = arm.link_state("spring_gimbal").rotation[:, 0]
            remove = sim.add_pre_step_hook(lambda _t: arm.apply_pad_wrench(torque_nm=torque_nm * axis))
            sim.step(240)
            remove()
            return float(np.abs(arm.spring_angles() - before).max())

    friction = 2e-3
    assert turned_by(0.5 * friction, friction) < math.radians(0.05)
    assert turned_by(0.5 * friction, 0.0) > math.radians(1.0)  # the spring alone yields
    assert turned_by(3.0 * friction, friction) > math.radians(1.0)
