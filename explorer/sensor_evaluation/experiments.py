"""The three experiments of the sensor evaluation, run headless and seeded.

1. Contact detection: presses at random tilts and forces on the flat slab, the sphere and the
   cylinder, plus free-motion trials with sudden moves and stops; every detector is scored on the
   same recorded readings (:mod:`explorer.sensor_evaluation.detection`).
2. Normal accuracy: presses on the flat slab tilted by fixed angles at evenly spread azimuths,
   scored per sensor variant (:mod:`explorer.sensor_evaluation.normal_accuracy`).
3. Speed: simulated seconds per wall-clock second of the press trials (arm, physics, sensor models
   and recording), and optionally the robots package's own benchmark.

Every trial runs in its own :class:`robots.SimWorld`; seeds are spawned from one root seed.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np

import objects
from explorer.sensor_evaluation.detection import DetectorScore, score_detectors
from explorer.sensor_evaluation.normal_accuracy import NormalAccuracy, normal_trial, summarize
from explorer.sensor_evaluation.press_rig import PressRig, build_rig
from explorer.sensor_evaluation.scene import SUPPORTED_OBJECTS, check_object_name, random_touch_site
from explorer.sensor_evaluation.trials import (FreeMotionProtocol, PressProtocol, PressSpec, TrialRecording,
                                      run_free_motion, run_press)
from explorer.sensor_evaluation.variants import DEFAULT, sensor_variants
from explorer.sim_profile import SimProfile, get_profile
from sensor.sim_sensor import SimulatedSensorConfig

REFERENCE_MEAN_NORMAL_ERROR_DEG = 7.3
"""Mean normal error of the reference hardware sensor over 0-50 degrees of tilt, degrees."""


@dataclass(frozen=True)
class EvaluationConfig:
    """What to run.

    Attributes
    ----------
    presses : int
        Presses of the detection experiment (objects taken in turn).
    seed : int
        Root seed of every random choice and sensor.
    objects : tuple of str
        Objects of the detection experiment, from :data:`explorer.sensor_evaluation.scene.SUPPORTED_OBJECTS`.
    tilt_range_deg : (2,) float
        Surface tilts of the detection presses are drawn uniformly from this range, degrees.
    force_range_n : (2,) float
        Target press forces of the detection presses are drawn uniformly from this range, newtons.
    free_motion_trials : int
        Free-motion trials (nothing to touch) of the detection experiment.
    normal_tilts_deg : tuple of float
        Plane tilts of the normal experiment, degrees.
    normal_presses_per_tilt : int
        Presses per tilt, at evenly spaced azimuths.
    normal_force_n : float
        Target force of the normal experiment's presses, newtons.
    robot : str
        Robot from the registry.
    profile : SimProfile
        Simulation profile (:mod:`explorer.sim_profile`): the spring's friction, the pad's friction
        and, unless ``sensor`` is given, the sensor model. The arm's calibration errors do not enter
        (the presses follow one joint path and the normal comes from the IMU).
    sensor : SimulatedSensorConfig or None
        The sensor's default model (its variants come from :func:`sensor_variants`); None: the
        profile's.
    protocol : PressProtocol
    free_motion : FreeMotionProtocol
    robots_benchmark_s : float
        Simulated seconds for the robots package's speed benchmark; 0 skips it.
    """

    presses: int = 100
    seed: int = 0
    objects: tuple[str, ...] = SUPPORTED_OBJECTS
    tilt_range_deg: tuple[float, float] = (0.0, 50.0)
    force_range_n: tuple[float, float] = (0.5, 3.0)
    free_motion_trials: int = 10
    normal_tilts_deg: tuple[float, ...] = (0.0, 10.0, 20.0, 30.0, 40.0, 50.0)
    normal_presses_per_tilt: int = 10
    normal_force_n: float = 2.0
    robot: str = "armar3"
    profile: SimProfile = field(default_factory=lambda: get_profile(None))
    sensor: SimulatedSensorConfig | None = None
    protocol: PressProtocol = field(default_factory=PressProtocol)
    free_motion: FreeMotionProtocol = field(default_factory=FreeMotionProtocol)
    robots_benchmark_s: float = 5.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "profile", get_profile(self.profile))
        if self.sensor is None:
            object.__setattr__(self, "sensor", self.profile.sensor_config())
        if isinstance(self.presses, bool) or not isinstance(self.presses, (int, np.integer)) or self.presses < 0:
            raise ValueError(f"presses must be a whole number >= 0, got {self.presses!r}")
        for name in ("free_motion_trials", "normal_presses_per_tilt"):
            value = getattr(self, name)
            if not isinstance(value, (int, np.integer)) or value < 0:
                raise ValueError(f"{name} must be a whole number >= 0, got {value!r}")
        if not self.objects:
            raise ValueError("objects must name at least one test object")
        for name in self.objects:
            check_object_name(name)
        low, high = self.tilt_range_deg
        if not 0.0 <= low <= high < 90.0:
            raise ValueError(f"tilt_range_deg must satisfy 0 <= low <= high < 90, got {self.tilt_range_deg}")
        low, high = self.force_range_n
        if not 0.0 < low <= high:
            raise ValueError(f"force_range_n must satisfy 0 < low <= high N, got {self.force_range_n}")
        if any(not 0.0 <= t < 90.0 for t in self.normal_tilts_deg):
            raise ValueError(f"normal_tilts_deg must lie in [0, 90), got {self.normal_tilts_deg}")
        if not self.normal_force_n > 0.0:
            raise ValueError(f"normal_force_n must be > 0 N, got {self.normal_force_n}")
        if not (math.isfinite(self.robots_benchmark_s) and self.robots_benchmark_s >= 0.0):
            raise ValueError(f"robots_benchmark_s must be >= 0 s, got {self.robots_benchmark_s}")
        if self.presses + self.free_motion_trials == 0 and not (self.normal_tilts_deg and self.normal_presses_per_tilt):
            raise ValueError("nothing to run: no presses, no free-motion trials and no normal presses")


@dataclass(frozen=True)
class PressSummary:
    """How the detection presses went (ground truth).

    Attributes
    ----------
    presses : int
    guard_stops : int
        Approaches the live pressure detector stopped.
    held_force_n : (presses,) float
        Mean true force over each hold, newtons.
    other_link_contacts : int
        Presses where an arm link other than the pad touched the object.
    """

    presses: int
    guard_stops: int
    held_force_n: np.ndarray = field(repr=False)
    other_link_contacts: int


@dataclass(frozen=True)
class EvaluationReport:
    """Everything the evaluation measured (plain data).

    Attributes
    ----------
    config : EvaluationConfig
    detection : dict of str -> DetectorScore
        Per detector, on the default sensor's readings.
    press_summary : PressSummary
    normal : NormalAccuracy or None
        None when the normal experiment was not run.
    speed_realtime_factor : float
        Simulated / wall-clock seconds over all trials (arm, physics, sensor variants, recording).
    robots_benchmark : robots.benchmark.SpeedFigures or None
    machine : str
    wall_s : float
        Wall-clock duration of the whole evaluation, seconds.
    example_recordings : tuple of TrialRecording
        A few press trials and one free-motion trial, for figures.
    """

    config: EvaluationConfig
    detection: dict[str, DetectorScore]
    press_summary: PressSummary
    normal: NormalAccuracy | None
    speed_realtime_factor: float
    robots_benchmark: object | None
    machine: str
    wall_s: float
    example_recordings: tuple[TrialRecording, ...] = field(repr=False)


def detection_press_specs(config: EvaluationConfig, models: dict, rng: np.random.Generator) -> list[PressSpec]:
    """The detection experiment's presses: objects in turn, random sites, tilts, azimuths, forces."""
    specs = []
    for k in range(config.presses):
        name = config.objects[k % len(config.objects)]
        specs.append(PressSpec(
            object_name=name,
            site=random_touch_site(models[name], rng),
            tilt_rad=math.radians(rng.uniform(*config.tilt_range_deg)),
            azimuth_rad=rng.uniform(0.0, 2.0 * math.pi),
            spin_rad=rng.uniform(0.0, 2.0 * math.pi),
            target_force_n=rng.uniform(*config.force_range_n),
            sensor_seed=int(rng.integers(2**31)),
        ))
    return specs


def normal_press_specs(config: EvaluationConfig, flat, rng: np.random.Generator) -> list[PressSpec]:
    """The normal experiment's presses on the flat slab: each tilt at evenly spaced azimuths."""
    n = config.normal_presses_per_tilt
    return [
        PressSpec("flat", random_touch_site(flat, rng), math.radians(tilt), 2.0 * math.pi * (k + rng.uniform()) / n,
                  rng.uniform(0.0, 2.0 * math.pi), config.normal_force_n, int(rng.integers(2**31)))
        for tilt in config.normal_tilts_deg for k in range(n)
    ]


def run_evaluation(config: EvaluationConfig = EvaluationConfig(), rig: PressRig | None = None,
                   progress: Callable[[str], None] | None = None) -> EvaluationReport:
    """Run the experiments ``config`` asks for; see the module docstring.

    Parameters
    ----------
    config : EvaluationConfig
    rig : PressRig, optional
        A rig already built for ``config.robot`` (saves its IK).
    progress : callable (str) -> None, optional
        Receives one line per finished trial.
    """
    from robots.benchmark import machine_description

    started = time.perf_counter()
    say = progress or (lambda line: None)
    rig = rig if rig is not None else build_rig(config.robot)
    if rig.spec.name != config.robot:
        raise ValueError(f"rig is for robot {rig.spec.name!r} but the config asks for {config.robot!r}")
    rig = replace(rig, spec=config.profile.robot_spec(rig.spec), spring_friction_nm=config.profile.spring_friction_nm)
    variants = sensor_variants(config.sensor)
    live_only = {DEFAULT: variants[DEFAULT]}
    root = np.random.SeedSequence(config.seed)
    detection_rng, free_rng, normal_rng = (np.random.default_rng(s) for s in root.spawn(3))
    models = {name: objects.load(name) for name in set(config.objects) | {"flat"}}

    recordings: list[TrialRecording] = []
    for k, spec in enumerate(detection_press_specs(config, models, detection_rng)):
        recordings.append(run_press(rig, models[spec.object_name], spec, live_only, config.protocol))
        say(_press_line(f"detection press {k + 1}/{config.presses}", recordings[-1]))
    presses = [r for r in recordings if r.press is not None]
    for k in range(config.free_motion_trials):
        recordings.append(run_free_motion(rig, live_only, int(free_rng.integers(2**31)), config.free_motion))
        say(f"free motion {k + 1}/{config.free_motion_trials}: {recordings[-1].simulated_s:.1f} s simulated")
    detection = score_detectors(recordings, DEFAULT)

    normal_recordings = []
    specs = normal_press_specs(config, models["flat"], normal_rng)
    for k, spec in enumerate(specs):
        normal_recordings.append(run_press(rig, models["flat"], spec, variants, config.protocol))
        say(_press_line(f"normal press {k + 1}/{len(specs)}", normal_recordings[-1]))
    normal = summarize([normal_trial(r, list(variants)) for r in normal_recordings]) if normal_recordings else None

    every = recordings + normal_recordings
    wall = sum(r.wall_s for r in every)
    benchmark = None
    if config.robots_benchmark_s > 0.0:
        from robots.benchmark import measure

        benchmark = measure(config.robot, config.robots_benchmark_s)
    examples = tuple(presses[:3]) + tuple(r for r in recordings if r.kind == "free")[:1]
    return EvaluationReport(
        config=config,
        detection=detection,
        press_summary=PressSummary(
            presses=len(presses),
            guard_stops=sum(r.press.guard_stopped for r in presses),
            held_force_n=np.array([r.press.held_force_n for r in presses]),
            other_link_contacts=sum(bool(r.press.other_links_touching) for r in presses),
        ),
        normal=normal,
        speed_realtime_factor=sum(r.simulated_s for r in every) / wall if wall > 0.0 else math.nan,
        robots_benchmark=benchmark,
        machine=machine_description(),
        wall_s=time.perf_counter() - started,
        example_recordings=examples,
    )


def _press_line(label: str, recording: TrialRecording) -> str:
    press = recording.press
    return (f"{label}: {press.spec.object_name}, tilt {math.degrees(press.spec.tilt_rad):.1f} deg, "
            f"held {press.held_force_n:.2f} N, pad misaligned {math.degrees(press.body_misalignment_rad):.1f} deg, "
            f"{recording.simulated_s:.1f} s simulated in {recording.wall_s:.2f} s")
