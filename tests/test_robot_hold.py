"""Robot.hold on both backends: the arm keeps its position, and stop() ends the hold early."""
import numpy as np
import pytest

import robots
from robots.emulators import EmulatedArmController, FakeArmSerial
from robots.hardware import SerialArm
from robots.sim_arm import SimArm
from robots.sim_world import SimWorld
from sensor.emulators import FakeClock


@pytest.fixture(scope="module")
def spec():
    return robots.load("armar3")


def test_simulated_arm_holds_for_the_duration(spec):
    with SimWorld(table=None) as world:
        arm = SimArm(world, spec)
        q0 = arm.joint_positions()
        t0 = arm.time_s()
        result = arm.hold(0.5)
        assert not result.stopped
        assert arm.time_s() - t0 == pytest.approx(0.5, abs=0.01)
        assert np.max(np.abs(arm.joint_positions() - q0)) < 2e-3


def test_simulated_hold_ends_when_stop_fires(spec):
    with SimWorld(table=None) as world:
        arm = SimArm(world, spec)
        t0 = arm.time_s()
        result = arm.hold(2.0, stop=lambda: arm.time_s() - t0 >= 0.2)
        assert result.stopped
        assert 0.2 <= arm.time_s() - t0 < 0.25
        with pytest.raises(ValueError, match="duration_s"):
            arm.hold(-1.0)


def test_hardware_arm_holds_and_stops_on_the_predicate(spec):
    clock = FakeClock()
    controller = EmulatedArmController.for_spec(spec, clock=clock.monotonic)
    arm = SerialArm(FakeArmSerial(controller, clock=clock, port="/dev/ttyTEST"), spec,
                    clock=clock.monotonic, sleep=clock.sleep)
    with arm:
        q0 = arm.joint_positions()
        t0 = clock.monotonic()
        assert not arm.hold(0.3).stopped
        assert clock.monotonic() - t0 >= 0.3
        assert np.max(np.abs(arm.joint_positions() - q0)) < 2e-3
        t1 = clock.monotonic()
        assert arm.hold(5.0, stop=lambda: clock.monotonic() - t1 >= 0.1).stopped
        assert clock.monotonic() - t1 < 0.2
