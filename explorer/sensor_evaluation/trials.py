"""Simulated trials: one press on a posed object, or free motion with sudden moves; each in its own world.

A trial records what the evaluation needs afterwards, as plain data: the readings of several
variants of the simulated fingertip sensor fed the same physics (the default noise model, a
noiseless twin and any others, so that the physics' own error and each sensor error source can be
told apart), and the ground-truth normal force on the pad after every physics step. The first
variant is the live one whose readings stop the guarded moves. The press protocol is the exploration loop's: move to a stand-off in front of the
surface, approach slowly in a guarded move that the live pressure detector stops, press on until the
pressure says the target force is reached, hold while the spring settles, retreat.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Callable, Literal, Mapping

import numpy as np

from objects import ObjectModel
from sensor.contact_detection import ContactEvent, PressureContactDetector
from explorer.sensor_evaluation.press_rig import PressRig
from explorer.sensor_evaluation.scene import TouchSite, free_gap_m, pose_for_contact, tilted_normal
from sensor.reading import Reading
from sensor.sim_sensor import SimulatedSensorConfig, SimulatedTactileSensor


@dataclass(frozen=True)
class PressProtocol:
    """Speeds, distances and timings of one press.

    The simulated arm is position-controlled and stiff at the pad (about 7e4 N/m, mostly the pad's
    contact stiffness), so the force overshoot of a guarded stop is about stiffness x approach speed
    x detection latency (~50 ms: pad lag, barometer period, confirmation time). At the default
    0.5 mm/s that is ~1.7 N, inside the 0.5-3 N press range; a faster approach presses harder.

    Attributes
    ----------
    gap_m : float
        Distance from the pad face centre at home to the surface, along the approach line, metres.
    standoff_m : float
        The guarded approach starts this far before the first point of the pad would touch, metres.
    approach_speed_mps : float
        Pad speed during the guarded approach and the press, m/s.
    transfer_speed_rad_s : float
        Fastest-joint speed of the unguarded moves to the stand-off and back home, rad/s.
    settle_s : float
        Free time before moving, seconds (the pressure detector learns its baseline).
    hold_s : float
        Time the press is held for the spring to settle, seconds; the normal is estimated from it.
    release_s : float
        Free time after returning home, seconds.
    max_press_travel_m : float
        How far past the first contact the press phase may travel before giving up, metres.
    """

    gap_m: float = 0.025
    standoff_m: float = 0.0015
    approach_speed_mps: float = 0.0005
    transfer_speed_rad_s: float = 0.3
    settle_s: float = 0.3
    hold_s: float = 0.6
    release_s: float = 0.3
    max_press_travel_m: float = 0.008

    def __post_init__(self) -> None:
        for name, value in vars(self).items():
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"PressProtocol.{name} must be finite and > 0, got {value}")


@dataclass(frozen=True)
class PressSpec:
    """What one press touches, at which tilt, how hard.

    Attributes
    ----------
    object_name : str
        One of :data:`explorer.sensor_evaluation.scene.SUPPORTED_OBJECTS`.
    site : TouchSite
        The touched point and its outward normal, object frame.
    tilt_rad : float
        Angle between the surface normal and the reversed approach direction, radians.
    azimuth_rad : float
        Direction of that tilt about the approach axis, radians.
    spin_rad : float
        Turn of the object about the surface normal, radians.
    target_force_n : float
        Force the press phase aims for (estimated from the pressure rise), newtons.
    sensor_seed : int
        Seed of the simulated sensor's noise.
    """

    object_name: str
    site: TouchSite
    tilt_rad: float
    azimuth_rad: float
    spin_rad: float
    target_force_n: float
    sensor_seed: int


@dataclass(frozen=True)
class PressOutcome:
    """What happened in a press (ground truth from the simulator).

    Attributes
    ----------
    spec : PressSpec
    true_normal : (3,) float
        Outward surface normal at the touched site, world frame (exact for the flat slab).
    guard_stopped : bool
        The live pressure detector stopped the approach (False: the path ended first).
    hold_start_s, hold_end_s : float
        The hold phase, simulation seconds.
    held_force_n : float
        Mean true normal force over the last half of the hold, newtons.
    body_misalignment_rad : float
        True angle between the sensor body's face axis and the reversed true normal at the end
        of the hold, radians (what the spring achieved, before any sensor error).
    other_links_touching : tuple of str
        Arm links other than the pad touching the object at the end of the hold (should be empty).
    """

    spec: PressSpec
    true_normal: np.ndarray
    guard_stopped: bool
    hold_start_s: float
    hold_end_s: float
    held_force_n: float
    body_misalignment_rad: float
    other_links_touching: tuple[str, ...]


@dataclass(frozen=True)
class TrialRecording:
    """Everything one trial recorded.

    Attributes
    ----------
    kind : {'press', 'free'}
    streams : dict of str -> tuple of Reading
        Readings of each sensor variant, in time order, by variant name (the live one first).
    force_t_s : (n,) float
        Simulation time after every physics step, seconds.
    normal_force_n : (n,) float
        True normal force on the pad at those times, newtons.
    press : PressOutcome or None
        For presses.
    simulated_s, wall_s : float
        Simulated and wall-clock duration of the trial, seconds.
    """

    kind: Literal["press", "free"]
    streams: dict[str, tuple[Reading, ...]] = field(repr=False)
    force_t_s: np.ndarray = field(repr=False)
    normal_force_n: np.ndarray = field(repr=False)
    press: PressOutcome | None
    simulated_s: float
    wall_s: float


def _check_variants(sensors: Mapping[str, SimulatedSensorConfig]) -> dict[str, SimulatedSensorConfig]:
    variants = dict(sensors)
    if not variants:
        raise ValueError("give at least one sensor variant (name -> SimulatedSensorConfig)")
    for name, config in variants.items():
        if not isinstance(config, SimulatedSensorConfig):
            raise ValueError(f"sensor variant {name!r} must be a SimulatedSensorConfig, got {type(config).__name__}")
    return variants


class _Recorder:
    """Feeds one pad state per physics step to every sensor variant and logs the true force."""

    def __init__(self, world, arm, sensors: Mapping[str, SimulatedSensorConfig], seed: int):
        self.arm = arm
        self.sensors = {name: SimulatedTactileSensor(config=config, seed=seed) for name, config in sensors.items()}
        self.live = next(iter(self.sensors))
        for sensor in self.sensors.values():
            sensor.open()
        self.streams: dict[str, list[Reading]] = {name: [] for name in self.sensors}
        self.times: list[float] = []
        self.forces: list[float] = []
        world.add_step_listener(self._on_step)

    def _on_step(self, t_s: float) -> None:
        state = self.arm.pad_state()
        for sensor in self.sensors.values():
            sensor.on_step(state)
        self.times.append(t_s)
        self.forces.append(state.normal_force_n)

    def collect(self) -> list[Reading]:
        """Drain every variant; return the live variant's new readings."""
        new: list[Reading] = []
        for name, sensor in self.sensors.items():
            readings = sensor.drain()
            self.streams[name].extend(readings)
            if name == self.live:
                new = readings
        return new

    def recording(self, kind, press, simulated_s, wall_s) -> TrialRecording:
        self.collect()
        return TrialRecording(kind, {name: tuple(stream) for name, stream in self.streams.items()},
                              np.array(self.times), np.array(self.forces), press, simulated_s, wall_s)


class _LiveGuard:
    """The exploration loop's stop conditions, from the live readings only."""

    def __init__(self, recorder: _Recorder, pad_response):
        self._recorder = recorder
        self._pad = pad_response
        self.detector = PressureContactDetector()
        self.start: ContactEvent | None = None
        self._latest: Reading | None = None

    def _feed(self) -> None:
        for reading in self._recorder.collect():
            event = self.detector.update(reading)
            if event is not None and event.kind == "start" and self.start is None:
                self.start = event
            self._latest = reading

    def in_contact(self) -> bool:
        self._feed()
        return self.detector.in_contact

    def force_reached(self, target_n: float) -> Callable[[], bool]:
        def stop() -> bool:
            self._feed()
            if self.start is None or self._latest is None:
                return False
            rise = self._latest.pressure_pa - self.start.baseline_pa
            return rise > 0.0 and self._pad.force_n(min(rise, 0.999 * self._pad.saturation_pa)) >= target_n
        return stop


def _new_world_and_arm(rig: PressRig):
    from robots.sim_arm import SimArm
    from robots.sim_world import SimWorld

    world = SimWorld(table=None)
    return world, SimArm(world, rig.spec, spring_friction_nm=rig.spring_friction_nm)


def _steps(world, seconds: float) -> None:
    world.step(max(int(round(seconds / world.time_step_s)), 1))


def run_press(rig: PressRig, model: ObjectModel, spec: PressSpec, sensors: Mapping[str, SimulatedSensorConfig],
              protocol: PressProtocol = PressProtocol()) -> TrialRecording:
    """Press the pad once onto ``model`` posed as ``spec`` says, in a fresh headless world.

    Every sensor variant in ``sensors`` (name -> config, the first one live) is seeded with
    ``spec.sensor_seed``, so the variants share their random draws where their configs allow.

    Raises
    ------
    ValueError
        If ``spec`` does not name ``model`` or the protocol's gap leaves the pad touching at home.
    """
    from common.rotations import angle_between_vectors, matrix_to_quat, quat_to_matrix

    variants = _check_variants(sensors)
    if spec.object_name != model.name:
        raise ValueError(f"press spec is for {spec.object_name!r} but the model is {model.name!r}")
    line = rig.line
    if protocol.gap_m + protocol.max_press_travel_m > line.depths_m[-1]:
        raise ValueError(f"PressProtocol gap_m + max_press_travel_m = "
                         f"{(protocol.gap_m + protocol.max_press_travel_m) * 1e3:.1f} mm goes past the rig's approach "
                         f"path ({line.depths_m[-1] * 1e3:.1f} mm); build the rig with a larger max_depth_m")
    normal = tilted_normal(line.direction, spec.tilt_rad, spec.azimuth_rad)
    pose = pose_for_contact(spec.site, line.start_m + protocol.gap_m * line.direction, normal, spec.spin_rad)
    gap = free_gap_m(model, pose, line.face_points_m(rig.pad_width_m), line.direction)
    if not gap > protocol.standoff_m:
        raise ValueError(f"{model.name} at {math.degrees(spec.tilt_rad):.1f} deg tilt is only {gap * 1e3:.1f} mm "
                         f"from the pad at home; increase PressProtocol.gap_m (now {protocol.gap_m * 1e3:.1f} mm)")
    started = time.perf_counter()
    world, arm = _new_world_and_arm(rig)
    with world:
        world.add_object(model.urdf_path, pose.position_m, matrix_to_quat(pose.rotation), name=model.name)
        recorder = _Recorder(world, arm, variants, spec.sensor_seed)
        guard = _LiveGuard(recorder, next(iter(variants.values())).barometer.pad)
        _steps(world, protocol.settle_s)
        first = line.index_before(gap - protocol.standoff_m)
        if first > 0:
            arm.guarded_move(line.q_rad[1:first + 1], lambda: False, speed_rad_s=protocol.transfer_speed_rad_s)
        slow = line.joint_speed_rad_s(protocol.approach_speed_mps)
        approach = arm.guarded_move(line.q_rad[first + 1:], guard.in_contact, speed_rad_s=slow)
        heading_to = approach.waypoint_index + first + 1  # the arm stopped short of this waypoint
        if approach.stopped:
            last = line.index_before(line.depths_m[heading_to] + protocol.max_press_travel_m)
            press = arm.guarded_move(line.q_rad[heading_to:last + 1], guard.force_reached(spec.target_force_n),
                                     speed_rad_s=slow)
            heading_to += press.waypoint_index
        hold_start = world.time_s
        forces_before = len(recorder.forces)
        _steps(world, protocol.hold_s)
        held = np.array(recorder.forces[forces_before:])
        state = arm.pad_state()
        body_axis = quat_to_matrix(state.quat_wxyz)[:, 2]
        touching = tuple(sorted({c.link for c in arm.contacts() if c.other == model.name and c.link != rig.spec.pad_link}))
        outcome = PressOutcome(
            spec=spec, true_normal=normal, guard_stopped=approach.stopped, hold_start_s=hold_start,
            hold_end_s=world.time_s, held_force_n=float(held[len(held) // 2:].mean()),
            body_misalignment_rad=float(angle_between_vectors(body_axis, -normal)), other_links_touching=touching,
        )
        behind = max(heading_to - 1, 0)  # retreat from the waypoint behind the pad, never into the surface
        arm.guarded_move(line.q_rad[:behind + 1][::-1], lambda: False, speed_rad_s=protocol.transfer_speed_rad_s)
        _steps(world, protocol.release_s)
        return recorder.recording("press", outcome, world.time_s, time.perf_counter() - started)


@dataclass(frozen=True)
class FreeMotionProtocol:
    """Sudden joint-space moves and abrupt stops with nothing to touch.

    Attributes
    ----------
    moves : int
        Moves per trial.
    max_offset_rad : float
        Targets are drawn uniformly within this of home, per joint (clipped to the limits), radians.
    speed_range_rad_s : (2,) float
        Fastest-joint speed range of the moves, rad/s (capped at the joints' velocity limits).
    abrupt_stop_probability : float
        Chance that a move is cut short half-way by a guarded stop (a sudden halt).
    pause_range_s : (2,) float
        Range of the pause after each move, seconds.
    settle_s : float
        Free time before the first move, seconds.
    """

    moves: int = 6
    max_offset_rad: float = 0.35
    speed_range_rad_s: tuple[float, float] = (0.8, 2.0)
    abrupt_stop_probability: float = 0.5
    pause_range_s: tuple[float, float] = (0.1, 0.5)
    settle_s: float = 0.3

    def __post_init__(self) -> None:
        if self.moves < 1 or not self.max_offset_rad > 0.0 or not 0.0 <= self.abrupt_stop_probability <= 1.0:
            raise ValueError(f"FreeMotionProtocol needs moves >= 1, max_offset_rad > 0 and a probability in "
                             f"[0, 1], got {self}")
        for name in ("speed_range_rad_s", "pause_range_s"):
            low, high = getattr(self, name)
            if not 0.0 < low <= high:
                raise ValueError(f"FreeMotionProtocol.{name} must satisfy 0 < low <= high, got {(low, high)}")


def run_free_motion(rig: PressRig, sensors: Mapping[str, SimulatedSensorConfig], seed: int,
                    protocol: FreeMotionProtocol = FreeMotionProtocol()) -> TrialRecording:
    """Random fast moves and abrupt stops in free space, in a fresh headless world.

    ``sensors`` as for :func:`run_press`; ``seed`` draws the moves and the sensors' seed.
    """
    variants = _check_variants(sensors)
    rng = np.random.default_rng(seed)
    started = time.perf_counter()
    world, arm = _new_world_and_arm(rig)
    with world:
        recorder = _Recorder(world, arm, variants, int(rng.integers(2**31)))
        _steps(world, protocol.settle_s)
        home = rig.spec.home_q
        speed_cap = float(np.min(arm.velocity_limit_rad_s))
        for _ in range(protocol.moves):
            target = np.clip(home + rng.uniform(-protocol.max_offset_rad, protocol.max_offset_rad, home.shape),
                             arm.lower_rad, arm.upper_rad)
            speed = min(rng.uniform(*protocol.speed_range_rad_s), speed_cap)
            if rng.random() < protocol.abrupt_stop_probability:
                halt_at = world.time_s + 0.5 * np.max(np.abs(target - arm.true_joint_positions())) / speed
                arm.guarded_move(target[None], lambda: world.time_s >= halt_at, speed_rad_s=speed)
            else:
                arm.guarded_move(target[None], lambda: False, speed_rad_s=speed)
            _steps(world, rng.uniform(*protocol.pause_range_s))
            recorder.collect()
        return recorder.recording("free", None, world.time_s, time.perf_counter() - started)
