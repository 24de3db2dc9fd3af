"""Offline replay of a recorded session: detect contacts again, refit the GPIS, write the outputs.

An exploration session holds the raw sensor stream, the encoder joint states and the touch events
(docs/SESSION_FORMAT.md). Replay runs the pressure contact detector over the stream with new
thresholds, recomputes each contact from the readings and the forward kinematics of the recorded
encoders, carries it into the object frame with the stand angles of its touch event, fits a GPIS
with new settings and writes what an exploration run writes (``contacts.csv``,
``reconstruction.ply``, ``metrics.json``, figures).

Which readings belong to a touch. Each touch event that pressed carries ``press_t_s = [t0, t1]``:
the press is the readings with ``t0 < t <= t1`` and its pose is the last joint state at or before
``t1``. Replay does not copy the recorded contacts: it re-runs the detector over the raw stream
and keeps the recorded spans, which say where the *arm* was pressing (the loop's motion, or where
the operator held the pad still), not what the detector decided. How the detector sees the stream
follows the run:

* **Autonomous** runs reset the detector when the arm arrives at the standoff, so replay resets it
  at ``t0`` and feeds it the press's readings; the contact runs from the detected start to
  ``t1`` (or to a detected end). ``t1`` is the end of the hold. The loop's realign rule applies as
  the loop applied it: to every touch but a realign repeat (recorded ``strategy: realign``).
* **Teleop** runs (``configuration.mode == "teleop"``) keep one detector over the whole stream, so
  replay runs one detector from the first reading to the last and, for each touch, takes the
  contact in progress at ``t1``: its readings after ``t0`` (when the pad came to rest) up to
  ``t1`` (when the contact was recorded). A contact the new thresholds do not see is a ``miss``
  but adds no free space (the operator's path is not a planned line); two touches that fall in one
  detected contact (the pad never came off at the new end threshold) keep the first
  (``same_press``), as teleop records a contact once per press. Teleop has no realign rule.

Each contact is measured by the loop's own pipeline (:mod:`explorer.contact`) with the recorded pad
calibration and settling test, the GPIS is fed through the loop's :class:`SurfaceEvidence` (a
recorded miss adds the free space it recorded), and the outputs are the run's
(:mod:`explorer.outputs`, :func:`explorer.recording.contacts_csv_row`). Replayed with the recorded
settings a session gives back its recorded contacts; every touch whose outcome differs from the
recorded one is named in the result's ``notes``.

Sessions written before ``press_t_s`` existed (autonomous only) fall back to the joint-state
stream: the loop logs one joint state per poll of the sensor, and it polls every control tick only
during a guarded approach, the press and the hold, so each press is a *dense run* of joint-state
rows between free moves (retract, stand turn, transfer), which leave gaps (:func:`press_spans`).
"""
from __future__ import annotations

import warnings
from dataclasses import asdict, dataclass, field, fields, replace
from pathlib import Path

import numpy as np

import objects
from explorer import outputs
from explorer.arm_calibration import with_fitted_link_lengths
from explorer.contact import (LOOP_SETTLING, ContactPipeline, DoubtRule, NoContactMeasured, ObjectFrame, PressReleased,
                              wants_realign)
from explorer.evaluation import jsonable
from explorer.loop import LoopConfig
from explorer.outputs import add_errors, kept_contacts, reconstruction_counts, write_figures, write_mesh
from explorer.planner import PlannerConfig, approach_line
from explorer.recording import CONTACTS_HEADER, contacts_csv_row
from explorer.session import SessionReader
from explorer.session.checks import require_replay_files, usable_readings
from explorer.touch import ObjectPrior, TouchOutcome, left_line_counts
from reconstruction.gpis import GPIS, KERNEL_NAMES
from sensor.contact_detection import PressureContactDetector, PressureDetectorConfig
from sensor.normal_estimation import SettlingConfig
from sensor.pad_calibration import PadCalibration

#: Touch results whose press is in the recorded streams (the others never reached the standoff).
PRESSED_RESULTS = ("contact", "realign", "miss", "no_normal")
#: Two positions closer than this are the same contact, metres (the recording rounds nothing).
SAME_POSITION_M = 1e-9
#: A joint-state gap longer than this many typical spacings separates two presses.
GAP_IN_SPACINGS = 4.0


@dataclass(frozen=True)
class ReplaySettings:
    """What to change when replaying; ``None`` keeps the recorded (or default) value.

    Attributes
    ----------
    start_threshold_pa, end_threshold_pa : float or None
        Pressure detector thresholds, pascals (default: the detector's, 100 and 50 Pa).
    kernel : str
        GPIS kernel name, one of ``reconstruction.gpis.KERNEL_NAMES``.
    noise, normal_noise : float or None
        GPIS observation noise (m) and normal noise (unitless); None: the GPIS defaults.
    use_normals : bool or None
        Fit normals; None: as recorded.
    mesh_resolution : int or None
        Grid samples of the output mesh along the longest side; None: as recorded.
    segment_gap_s : float or None
        Joint-state gap that separates two presses, seconds, for sessions without ``press_t_s``;
        None: ``GAP_IN_SPACINGS`` x the median spacing of the joint states.
    side_presses : bool or None
        Give the GPIS a value row at the pad-face centre of each press on the pad's side
        (``LoopConfig.side_press_value`` / ``side_press_noise``, the recorded ones or else the
        defaults); None: as recorded (sessions recorded before these rows: none).
    bridge_concave_contacts : bool or None
        Move contacts on concave surfaces in by the height their pad bridged before meshing
        (``LoopConfig.bridge_concave_contacts``); None: as recorded (sessions recorded before: off).
    indent_convex_contacts : bool or None
        Move contacts on surfaces curving away in every direction out by what the pad sank further
        there (``LoopConfig.indent_convex_contacts``); None: as recorded (sessions recorded before: off).
    point_compliance_m_per_n : float or None
        The pad's compression per newton on one point to indent with, metres per newton
        (``PadCalibration.point_compliance_m_per_n``); None: as recorded (sessions recorded before
        2026-12-08 have none, and are not indented without it).
    reconstruction_symmetry : bool or None
        Mesh with the contacts' images under the symmetry they support
        (``LoopConfig.reconstruction_symmetry``); None: as recorded (sessions recorded before: off).
    figures : bool
        Write the PNG figures.
    """

    start_threshold_pa: float | None = None
    end_threshold_pa: float | None = None
    kernel: str = "thin_plate"
    noise: float | None = None
    normal_noise: float | None = None
    use_normals: bool | None = None
    mesh_resolution: int | None = None
    segment_gap_s: float | None = None
    side_presses: bool | None = None
    bridge_concave_contacts: bool | None = None
    indent_convex_contacts: bool | None = None
    point_compliance_m_per_n: float | None = None
    reconstruction_symmetry: bool | None = None
    figures: bool = True

    def __post_init__(self):
        if self.kernel not in KERNEL_NAMES:
            raise ValueError(f"unknown kernel {self.kernel!r}; choose one of {', '.join(KERNEL_NAMES)}")
        if self.mesh_resolution is not None and self.mesh_resolution < 8:
            raise ValueError(f"mesh_resolution must be >= 8, got {self.mesh_resolution}")
        if self.segment_gap_s is not None and not self.segment_gap_s > 0:
            raise ValueError(f"segment_gap_s must be > 0 s, got {self.segment_gap_s}")


@dataclass
class ReplayResult:
    """The replayed touches (kinds as the loop's, see ``explorer.touch.TOUCH_KINDS``), the refitted
    GPIS, the metrics and the notes (every touch whose outcome differs from the recorded one)."""

    touches: list[TouchOutcome]
    gpis: GPIS
    metrics: dict
    out_dir: Path | None
    notes: list[str] = field(default_factory=list)

    @property
    def contacts(self) -> list[TouchOutcome]:
        return [t for t in self.touches if t.kind == "contact"]

    @property
    def points_m(self) -> np.ndarray:
        """(n, 3) contact points used, object frame, metres."""
        return np.array([t.position_m for t in self.contacts]).reshape(-1, 3)

    @property
    def normals(self) -> np.ndarray:
        """(n, 3) outward unit normals of the contacts used, object frame."""
        return np.array([t.normal for t in self.contacts]).reshape(-1, 3)


@dataclass(frozen=True)
class PressSpan:
    """Joint-state rows ``first..last`` (inclusive) of one press and their times, seconds.

    The press's readings are those with ``t_start_s < t <= t_end_s``; ``last`` is the joint state
    whose encoders give its pose.
    """

    first: int
    last: int
    t_start_s: float
    t_end_s: float


@dataclass(frozen=True)
class DetectedPress:
    """One contact the detector found in a whole stream: readings ``start`` up to ``end`` (excluded).

    ``end`` is the reading that ended it, or the stream length when it never ended.
    """

    start: int
    end: int
    baseline_pa: float


def press_spans(t_s: np.ndarray, gap_s: float | None = None) -> list[PressSpan]:
    """Dense runs of joint-state times (at least two rows, consecutive gaps <= ``gap_s``).

    Parameters
    ----------
    t_s : (k,) float
        Joint-state times, seconds, non-decreasing.
    gap_s : float, optional
        Default: ``GAP_IN_SPACINGS`` x the median spacing.
    """
    t_s = np.asarray(t_s, float)
    if len(t_s) < 2:
        return []
    spacing = np.diff(t_s)
    if gap_s is None:
        gap_s = GAP_IN_SPACINGS * float(np.median(spacing))
    breaks = np.flatnonzero(spacing > gap_s)
    firsts = np.r_[0, breaks + 1]
    lasts = np.r_[breaks, len(t_s) - 1]
    return [PressSpan(int(a), int(b), float(t_s[a]), float(t_s[b])) for a, b in zip(firsts, lasts) if b > a]


def detect_presses(readings, config: PressureDetectorConfig) -> list[DetectedPress]:
    """Every contact one detector finds over a whole stream, in order (as teleop runs it).

    Parameters
    ----------
    readings : explorer.session.Readings
        The session's raw stream.
    """
    detector = PressureContactDetector(config)
    presses: list[DetectedPress] = []
    start = baseline = None
    for i in range(len(readings)):
        event = detector.update(readings[i])
        if event is None:
            continue
        if event.kind == "start":
            start, baseline = i, event.baseline_pa
        elif event.kind == "end" and start is not None:
            presses.append(DetectedPress(start, i, baseline))
            start = None
    if start is not None:
        presses.append(DetectedPress(start, len(readings), baseline))
    return presses


def _touch_from_event(event) -> TouchOutcome:
    """A touch event as a not-yet-detected outcome (kind ``miss`` until a contact is found)."""
    f = event.fields
    free_space = f.get("free_space_m") if f.get("result") == "miss" else None
    left_line = f.get("left_line_m")
    return TouchOutcome(int(f.get("index", -1)), "miss", np.asarray(f["target_m"], float),
                        np.asarray(f["approach_dir"], float), float(f.get("stand_yaw_rad", 0.0)),
                        float(f.get("stand_tilt_rad", 0.0)), strategy=str(f.get("strategy", "")),
                        free_space_m=None if free_space is None else np.asarray(free_space, float).reshape(-1, 3),
                        left_line_m=None if left_line is None else np.asarray(left_line, float))


def recorded_pad(configuration: dict) -> PadCalibration:
    """The pad calibration a session was recorded with (sessions before it was recorded: their
    ``pad_compliance_m_per_n`` and the nominal pad)."""
    if "pad" in configuration:
        return PadCalibration.from_dict(configuration["pad"])
    legacy = configuration.get("teleop") if configuration.get("mode") == "teleop" else configuration.get("loop")
    compliance = (legacy or {}).get("pad_compliance_m_per_n")
    return PadCalibration() if compliance is None else PadCalibration(compliance_m_per_n=float(compliance))


def _config(cls, recorded: dict | None):
    """A config dataclass from the recorded dict (unknown keys ignored, lists as tuples)."""
    names = {f.name for f in fields(cls)}
    values = {k: tuple(map(tuple, v)) if k == "retreat_offsets_m" else v
              for k, v in (recorded or {}).items() if k in names}
    return cls(**values)


class SessionReplay:
    """Reads a session once; :meth:`run` replays it with given settings (repeatable).

    Parameters
    ----------
    session_dir : Path
        The ``session/`` directory of a run (or the run's output directory that holds it).
    """

    def __init__(self, session_dir: Path):
        import robots
        from robots.kinematics import ArmKinematics

        session_dir = Path(session_dir)
        if (session_dir / "session" / "metadata.json").is_file():
            session_dir = session_dir / "session"
        require_replay_files(session_dir)
        reader = SessionReader(session_dir)
        self.directory = session_dir
        self.metadata = reader.metadata
        self.truncated_files = reader.truncated_files
        self.readings, self.reading_notes = usable_readings(reader.readings())
        self.joint_states = reader.joint_states()
        self.events = reader.events()
        configuration = self.metadata.get("configuration") or {}
        self.configuration = configuration
        self.teleop = configuration.get("mode") == "teleop"
        self.loop_config = _config(LoopConfig, configuration.get("loop"))
        self.planner_config = _config(PlannerConfig, configuration.get("planner"))
        self.settling = (_config(SettlingConfig, configuration["settling"]) if "settling" in configuration
                         else LOOP_SETTLING)
        self.pad = recorded_pad(configuration)
        robot = self.metadata["robot"]
        robot_name = robot if isinstance(robot, str) else robot.get("name")
        spec = robots.load(robot_name)
        # the recorded joint angles are already corrected by a calibration's offsets, not by its lengths
        calibration = self.metadata.get("calibration") or {}
        self.kinematics = with_fitted_link_lengths(ArmKinematics(spec), calibration.get("link_length_error_m") or {})
        # Sessions recorded before issue 11 measured contacts at the pad-face centre (their pad
        # calibration has no spring stiffness), had no doubtful contacts and set aside every
        # misaligned one: replayed as they were recorded. Teleop uses the default rule.
        recorded_loop = configuration.get("loop") or {}
        centre_of_pressure = "spring_stiffness_nm_per_rad" in (configuration.get("pad") or {})
        self.legacy_contacts = not self.teleop and "max_realign_fraction" not in recorded_loop
        if "side_contact_force_n" not in recorded_loop:  # recorded before the side test
            self.loop_config = replace(self.loop_config, side_contact_force_n=0.0)
        if "side_press_noise" not in recorded_loop:  # side presses added nothing to the GPIS then
            self.loop_config = replace(self.loop_config, side_press_noise=None)
        if "drop_released_presses" not in recorded_loop:  # recorded before the release test
            self.loop_config = replace(self.loop_config, drop_released_presses=False)
        if "release_at_contact_threshold" not in recorded_loop:  # released below the end threshold then
            self.loop_config = replace(self.loop_config, release_at_contact_threshold=False)
        if "swept_free_space" not in recorded_loop:  # recorded before the swept lines counted
            self.loop_config = replace(self.loop_config, swept_free_space=False)
        if "loose_settle_deviation_rad" not in recorded_loop:  # recorded before the loose fallback
            self.loop_config = replace(self.loop_config, loose_settle_deviation_rad=None)
        if "reconstruction_symmetry" not in recorded_loop:  # meshed without symmetric images then
            self.loop_config = replace(self.loop_config, reconstruction_symmetry=False)
        if "reconstruction_free_space_noise" not in recorded_loop:  # meshed with the loop's free-space noise
            self.loop_config = replace(self.loop_config, reconstruction_free_space_noise=None)
        if "reconstruction_gates_misses" not in recorded_loop:  # meshed with the loop's miss rows
            self.loop_config = replace(self.loop_config, reconstruction_gates_misses=False)
        if "reconstruction_tightens_doubtful" not in recorded_loop:  # a doubtful contact kept its floor
            self.loop_config = replace(self.loop_config, reconstruction_tightens_doubtful=False)
        if "reconstruction_doubtful_normal_noise" not in recorded_loop:  # meshed with the loop's floor
            self.loop_config = replace(self.loop_config, reconstruction_doubtful_normal_noise=None)
        if "reconstruction_wall_gain" not in recorded_loop:  # meshed with thin walls as the loop added them
            self.loop_config = replace(self.loop_config, reconstruction_wall_gain=None)
        if "probe_corridor_m" not in recorded_loop:  # recorded before the loop's field took probe corridors
            self.loop_config = replace(self.loop_config, probe_corridor_m=None)
        if "reconstruction_sets_aside_rim_standoffs" not in recorded_loop:  # every contact was fitted
            self.loop_config = replace(self.loop_config, reconstruction_sets_aside_rim_standoffs=False)
        if "bridge_concave_contacts" not in recorded_loop:  # meshed with the contacts as measured
            self.loop_config = replace(self.loop_config, bridge_concave_contacts=False)
        if "indent_convex_contacts" not in recorded_loop:
            self.loop_config = replace(self.loop_config, indent_convex_contacts=False)
        doubt = (DoubtRule() if self.teleop else DoubtRule(-np.inf) if self.legacy_contacts
                 else self.loop_config.doubt_rule())
        self.pipeline = ContactPipeline(self.kinematics, self.pad, self.settling,
                                        centre_of_pressure=centre_of_pressure, doubt=doubt,
                                        loose_settling=None if self.teleop else self.loop_config.loose_settling(self.settling))
        if self.joint_states.dof not in (0, spec.dof):
            raise ValueError(f"{session_dir}: joint_states.csv has {self.joint_states.dof} joints but "
                             f"robot {robot_name!r} has {spec.dof}")
        # The simulated stand sits at the robot's workspace centre (explorer.simulation.build_scene).
        self.stand_centre_m = np.asarray(configuration.get("stand_centre_m", spec.workspace_center_m), float)
        self.truth = None
        self.truth_note = None
        self.prior = None
        object_name = self.metadata.get("object")
        if isinstance(object_name, str):
            try:
                self.truth = objects.load_as_recorded(object_name, self.metadata).mesh
            except (ValueError, FileNotFoundError) as error:
                self.truth_note = (f"object {object_name!r} not loaded ({error}): no errors against the truth; "
                                   "a mesh file named relative to where the run was made loads from there")
        recorded_prior = configuration.get("prior")
        if recorded_prior is not None:  # the box the run's GPIS was bounded by
            self.prior = ObjectPrior(recorded_prior["centre_m"], recorded_prior["half_extent_m"])
        elif self.truth is not None:
            from explorer.rig import object_prior

            self.prior = object_prior(self.truth)

    # ------------------------------------------------------------------ replay
    def run(self, settings: ReplaySettings = ReplaySettings(), out_dir: Path | None = None) -> ReplayResult:
        """Detect, recompute, refit; write the outputs to ``out_dir`` when given."""
        notes: list[str] = list(self.reading_notes)
        if self.truth_note is not None and self.metadata.get("backend", "simulation") == "simulation":
            notes.append(self.truth_note)
        if self.truncated_files:
            notes.append("cut off mid-record (last incomplete line ignored): " + ", ".join(self.truncated_files))
        detector_config = self._detector_config(settings)
        self.pipeline.release_threshold_pa = (None if self.teleop
                                              else self.loop_config.release_threshold_pa(detector_config))
        touches = []
        if self.teleop:
            detected = detect_presses(self.readings, detector_config)
            used: dict[int, int] = {}  # detected press -> the touch that took it
            for event, span in self._pressed_touches(settings, notes):
                touches.append(self._replay_teleop_touch(event, span, detected, used, notes))
        else:
            for event, span in self._pressed_touches(settings, notes):
                realigns = sum(t.kind == "realign" for t in touches)
                touches.append(self._replay_touch(event, span, detector_config, realigns))
        use_normals = self.use_normals(settings)
        gpis = self._fit(touches, settings, use_normals, notes)
        notes += self._differences(touches)
        metrics = self._metrics(touches, gpis, settings, detector_config, use_normals, notes)
        result = ReplayResult(touches, gpis, metrics, None if out_dir is None else Path(out_dir), notes)
        if out_dir is not None:
            self._write(result, settings, use_normals)
        return result

    def _detector_config(self, settings: ReplaySettings) -> PressureDetectorConfig:
        recorded_dict = dict(self.configuration.get("detector") or {})
        if recorded_dict and "baseline_hold_pa" not in recorded_dict:
            recorded_dict["baseline_hold_pa"] = None  # recorded before the setting existed: the whole rise tracked
        recorded = _config(PressureDetectorConfig, recorded_dict)
        start = recorded.start_threshold_pa if settings.start_threshold_pa is None else settings.start_threshold_pa
        end = recorded.end_threshold_pa if settings.end_threshold_pa is None else settings.end_threshold_pa
        if settings.end_threshold_pa is None and end > start:  # only the start was lowered
            end = start
        return PressureDetectorConfig(**{**asdict(recorded), "start_threshold_pa": start, "end_threshold_pa": end})

    def _pressed_touches(self, settings: ReplaySettings, notes: list[str]):
        """(touch event, press span) pairs, in order, for every touch that pressed."""
        events = [e for e in self.events
                  if e.fields.get("result") in PRESSED_RESULTS and "target_m" in e.fields]
        if all("press_t_s" in e.fields for e in events):
            yield from self._recorded_spans(events, notes)
        elif self.teleop:
            raise ValueError(f"{self.directory}: a teleop touch event has no press_t_s (sessions "
                             "recorded before it existed cannot be replayed)")
        else:
            yield from self._spans_from_gaps(events, settings, notes)

    def _recorded_spans(self, events, notes: list[str]):
        t_joints = self.joint_states.t_s
        last_reading_s = self.readings.t_s[-1] if len(self.readings) else -np.inf
        for event in events:
            t0, t1 = (float(v) for v in event.fields["press_t_s"])
            last = int(np.searchsorted(t_joints, t1, side="right")) - 1
            if t1 > last_reading_s:
                notes.append(f"touch {event.fields.get('index')}: readings.csv ends before its press does; skipped")
                continue
            if last < 0 or t_joints[last] < t0:
                notes.append(f"touch {event.fields.get('index')}: no joint state during its press; skipped")
                continue
            first = int(np.searchsorted(t_joints, t0, side="left"))
            yield event, PressSpan(first, last, t0, t1)

    def _spans_from_gaps(self, events, settings: ReplaySettings, notes: list[str]):
        spans = press_spans(self.joint_states.t_s, settings.segment_gap_s)
        starts = np.array([s.t_start_s for s in spans])
        last_reading_s = self.readings.t_s[-1] if len(self.readings) else -np.inf
        used = set()
        for event in events:
            i = int(np.searchsorted(starts, event.t_s, side="right")) - 1
            tolerance = 0.5 * (spans[i].t_end_s - spans[i].t_start_s) if i >= 0 else 0.0
            if i < 0 or event.t_s > spans[i].t_end_s + tolerance or i in used:
                notes.append(f"touch {event.fields.get('index')}: no press found in joint_states.csv; skipped")
                continue
            if spans[i].t_end_s > last_reading_s:
                notes.append(f"touch {event.fields.get('index')}: readings.csv ends before its press does; skipped")
                continue
            used.add(i)
            yield event, spans[i]
        for i in sorted(set(range(len(spans))) - used):
            notes.append(f"press at t = {spans[i].t_start_s:.3f} s has no touch event (cut off?); skipped")

    def _replay_touch(self, event, span: PressSpan, detector_config, realigns_so_far: int = 0) -> TouchOutcome:
        """An autonomous touch: the detector reset at the span's start sees its readings."""
        touch = _touch_from_event(event)
        t = self.readings.t_s
        first = int(np.searchsorted(t, span.t_start_s, side="right"))
        stop = int(np.searchsorted(t, span.t_end_s, side="right"))
        detector = PressureContactDetector(detector_config)
        start = None
        for i in range(first, stop):
            event_i = detector.update(self.readings[i])
            if event_i is not None and event_i.kind == "start":
                start, touch.baseline_pa = i, event_i.baseline_pa
                break
        if start is None:
            return touch
        repress = event.fields.get("repress_t_s")
        if repress is not None:  # the loop pressed on and measured the second press
            touch.repress_t_s = float(repress)
            start = max(start, int(np.searchsorted(t, float(repress), side="right")))
        # Every reading from the start to the press's end, as the loop keeps them: also those after
        # a dip below the detector's end threshold (the pad slipping while it settles).
        self._measure(touch, range(start, stop), span)
        cfg = self.loop_config
        if (touch.kind == "contact" and touch.strategy != "realign"
                and wants_realign(None if self.legacy_contacts else touch.quality, touch.normal,
                                  touch.approach_dir, cfg.realign_angle_rad, realigns_so_far, self._max_realigns())):
            touch.kind = "realign"  # set aside, as the loop did; the repeat is the next touch
        return touch

    def _replay_teleop_touch(self, event, span: PressSpan, detected: list[DetectedPress],
                             used: dict[int, int], notes: list[str]) -> TouchOutcome:
        """A teleop touch: the contact in progress at the span's end, from its readings after the start."""
        touch = _touch_from_event(event)
        t = self.readings.t_s
        first = int(np.searchsorted(t, span.t_start_s, side="right"))
        stop = int(np.searchsorted(t, span.t_end_s, side="right"))
        starts = np.array([d.start for d in detected], int)
        k = int(np.searchsorted(starts, stop, side="left")) - 1  # the last contact started before stop
        if k < 0 or detected[k].end < stop:
            return touch
        if k in used:
            touch.kind = "same_press"
            notes.append(f"touch {touch.index}: in the same detected contact as touch {used[k]} "
                         "(the pad never came off at these thresholds); recorded once")
            return touch
        used[k] = touch.index
        touch.baseline_pa = detected[k].baseline_pa
        self._measure(touch, range(max(first, detected[k].start), stop), span)
        return touch

    def _measure(self, touch: TouchOutcome, rows: range, span: PressSpan) -> None:
        """Contact from readings ``rows`` and the encoders at ``span.last`` (the loop's pipeline);
        kind ``contact`` or ``no_normal`` (with the pad's place, ``side_m``)."""
        readings = [self.readings[i] for i in rows]
        frame = ObjectFrame.of_stand(self.stand_centre_m, touch.stand_yaw_rad, touch.stand_tilt_rad)
        q = self.joint_states.q[span.last].copy()
        try:
            measured = self.pipeline.measure(readings, touch.baseline_pa, q, frame, touch.approach_dir)
        except NoContactMeasured as err:
            touch.kind = "no_normal"
            touch.side_m = None if isinstance(err, PressReleased) else self.pipeline.pad_centre(q, frame)
            return
        touch.contact = measured.world
        touch.position_m = measured.position_m
        touch.normal = measured.normal
        touch.quality = measured.quality
        touch.t_s = measured.world.t_s
        touch.kind = "contact"

    # ------------------------------------------------------------------ reconstruction
    def _fit(self, touches: list[TouchOutcome], settings: ReplaySettings, use_normals: bool,
             notes: list[str]) -> GPIS:
        """The GPIS, updated in the loop's order: contacts one by one, misses as free space."""
        options = {k: v for k, v in (("noise", settings.noise), ("normal_noise", settings.normal_noise))
                   if v is not None}
        gpis = GPIS(kernel=settings.kernel, use_normals=use_normals,
                    bounds=None if self.prior is None else self.prior.bounds(), **options)
        evidence = self._loop_config(settings).evidence(gpis)
        for touch in touches:
            if touch.kind == "miss":
                if self.teleop:  # a teleop path is not a planned line
                    continue
                if touch.free_space_m is None:
                    touch.free_space_m = evidence.inside_bounds(self._swept_line(touch))
            try:
                evidence.add_touch(touch, self.loop_config.doubtful_normal_noise)
            except ValueError as err:  # a contact outside the prior box (teleop keeps such contacts unmodelled)
                touch.kind = "not_modelled"
                notes.append(f"touch {touch.index}: not modelled: {err}")
        return gpis

    def _loop_config(self, settings: ReplaySettings) -> LoopConfig:
        """The recorded loop settings, with the side presses, the bridged contacts and the symmetric
        images as ``settings`` asks."""
        config = self.loop_config
        if settings.side_presses is not None:
            side_noise = (config.side_press_noise or LoopConfig.side_press_noise) if settings.side_presses else None
            config = replace(config, side_press_noise=side_noise)
        if settings.bridge_concave_contacts is not None:
            config = replace(config, bridge_concave_contacts=settings.bridge_concave_contacts)
        if settings.indent_convex_contacts is not None:
            config = replace(config, indent_convex_contacts=settings.indent_convex_contacts)
        if settings.reconstruction_symmetry is not None:
            config = replace(config, reconstruction_symmetry=settings.reconstruction_symmetry)
        return config

    def _max_realigns(self) -> int:
        """The loop's realign budget; sessions recorded before it existed had none (every
        misaligned touch was set aside)."""
        if self.legacy_contacts:
            return 1 << 30
        budget = self.configuration.get("touches", self.loop_config.touches)  # the run's --touches
        resumed = [e.fields["touches"] for e in self.events if e.kind == "resumed" and "touches" in e.fields]
        budget = int(resumed[-1]) if resumed else int(budget)  # a resumed run's last budget
        return LoopConfig(touches=budget, max_realign_fraction=self.loop_config.max_realign_fraction).max_realigns

    def _swept_line(self, touch: TouchOutcome) -> np.ndarray:
        """The approach line of a touch the loop did not record as a miss, object frame (the
        planner's line, to its default depth: a touch's own depth is not recorded)."""
        return approach_line(touch.target_m, touch.approach_dir, self.planner_config)

    def _differences(self, touches: list[TouchOutcome]) -> list[str]:
        """A note for every touch whose replayed outcome is not the recorded one."""
        recorded = {int(e.fields["index"]): e.fields for e in self.events
                    if e.fields.get("result") in PRESSED_RESULTS and "index" in e.fields}
        notes = []
        for touch in touches:
            fields = recorded.get(touch.index)
            if fields is None:
                continue
            if fields["result"] != touch.kind:
                notes.append(f"touch {touch.index}: recorded {fields['result']}, replayed {touch.kind}")
            elif touch.position_m is not None and fields.get("position_m") is not None:
                moved = float(np.linalg.norm(touch.position_m - np.asarray(fields["position_m"], float)))
                if moved > SAME_POSITION_M:
                    notes.append(f"touch {touch.index}: contact {moved * 1e3:.3f} mm from the recorded one")
        return notes

    # ------------------------------------------------------------------ outputs
    def _metrics(self, touches, gpis, settings, detector_config, use_normals, notes) -> dict:
        kinds = [t.kind for t in touches]
        recorded = [e.fields.get("result") for e in self.events if e.fields.get("result") in PRESSED_RESULTS]
        shift = {key: self.metadata[key] for key in [objects.FILE_SHIFT_KEY] if key in self.metadata}
        return dict(
            source_session=str(self.directory), object=self.metadata.get("object"), **shift,
            robot=self.metadata.get("robot"), replay=dict(
                asdict(settings), start_threshold_pa=detector_config.start_threshold_pa,
                end_threshold_pa=detector_config.end_threshold_pa, use_normals=use_normals),
            touches=len(touches), contacts=kinds.count("contact"), misses=kinds.count("miss"),
            realign=kinds.count("realign"), no_normal=kinds.count("no_normal"),
            doubtful=sum(bool(getattr(t.quality, "doubtful", False)) for t in touches if t.kind == "contact"),
            **left_line_counts(touches),
            same_press=kinds.count("same_press"), not_modelled=kinds.count("not_modelled"),
            recorded_contacts=recorded.count("contact"), n_contacts_fitted=gpis.n_contacts,
            notes=list(notes),
        )

    def mesh_resolution(self, settings: ReplaySettings = ReplaySettings()) -> int:
        """Grid cells per axis the reconstruction is meshed at: ``settings``' or the run's."""
        return settings.mesh_resolution or int(self.configuration.get("mesh_resolution", 96))

    def use_normals(self, settings: ReplaySettings = ReplaySettings()) -> bool:
        """Whether the GPIS fits the normals: ``settings``' choice or the run's."""
        return self.configuration.get("use_normals", True) if settings.use_normals is None else settings.use_normals

    def refit(self, touches: list[TouchOutcome], settings: ReplaySettings = ReplaySettings()) -> GPIS:
        """The field the run's reconstruction is meshed from, fitted to ``touches`` (a replay's
        :attr:`ReplayResult.touches`, or edited copies of them, object frame) with the recorded
        settings and ``settings``: contacts and misses in order as :meth:`run` adds them, then as
        ``LoopConfig.reconstruction_field`` takes them (bridged contacts, swept free space) where the
        run did. Mesh it at :meth:`mesh_resolution` to compare with the run. ``touches`` may be
        changed as :meth:`run` changes them (a miss's free space filled in, a contact outside the
        prior box made ``not_modelled``)."""
        gpis = self._fit(touches, settings, self.use_normals(settings), [])
        return self._reconstruction_field(gpis, touches, settings)[0]

    def _reconstruction_field(self, gpis: GPIS, touches: list[TouchOutcome],
                              settings: ReplaySettings) -> tuple[GPIS, dict]:
        """``gpis`` as the run's reconstruction had it (``LoopConfig.reconstruction``: bridged
        contacts, swept free space, contacts set aside) and its counts for ``metrics.json``
        (:func:`explorer.outputs.reconstruction_counts`; none for teleoperation)."""
        if self.teleop:
            return gpis, {}
        config = self._loop_config(settings)
        pad = self.pad if settings.point_compliance_m_per_n is None else replace(
            self.pad, point_compliance_m_per_n=settings.point_compliance_m_per_n)
        built = config.reconstruction(gpis, touches, pad)
        counts = reconstruction_counts(built)
        if not config.swept_free_space:
            del counts["swept_free_space_rows"]
        return built.field, counts

    def _write(self, result: ReplayResult, settings: ReplaySettings, use_normals: bool) -> None:
        out = result.out_dir
        out.mkdir(parents=True, exist_ok=True)
        outputs.write_text(out / "contacts.csv", CONTACTS_HEADER + "".join(
            contacts_csv_row(t, t.contact.t_s, t.contact.force_n) for t in result.contacts))
        metrics = result.metrics
        field, counts = self._reconstruction_field(result.gpis, result.touches, settings)
        metrics.update(counts)
        config = self._loop_config(settings)
        mesh = write_mesh(field, self.mesh_resolution(settings), out, metrics, config.reconstruction_symmetry,
                          config.reconstruction_refine_steps)
        add_errors(metrics, mesh, self.truth, result.points_m, result.normals,
                   kept_contacts(result.contacts, counts.get("rim_standoff_touches", ())))
        outputs.write_json(out / "metrics.json", jsonable(metrics))
        if mesh is not None and self.truth is not None and settings.figures:
            write_figures(out, field, mesh, self.truth, result.points_m, use_normals)


def replay(session_dir: Path, settings: ReplaySettings = ReplaySettings(),
           out_dir: Path | None = None) -> ReplayResult:
    """Replay the session in ``session_dir`` with ``settings``; write outputs to ``out_dir`` if given."""
    with warnings.catch_warnings():  # a cut-off file is reported in the result's notes instead
        from explorer.session import SessionTruncatedWarning

        warnings.simplefilter("ignore", SessionTruncatedWarning)
        session = SessionReplay(session_dir)
    return session.run(settings, out_dir)
