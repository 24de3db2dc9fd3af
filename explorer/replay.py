"""Offline replay of a recorded session: detect contacts again, refit the GPIS, write the outputs.

An exploration session holds the raw sensor stream, the encoder joint states and the touch events
(docs/SESSION_FORMAT.md). Replay runs the pressure contact detector over the stream with new
thresholds, recomputes each contact from the readings and the forward kinematics of the recorded
encoders, carries it into the object frame with the stand angles of its touch event, fits a GPIS
with new settings and writes what an exploration run writes (``contacts.csv``,
``reconstruction.ply``, ``metrics.json``, figures).

Where a press begins and ends is not an event in the session; it is read from the joint-state
stream. The loop logs one joint state per poll of the sensor, and it polls every control tick only
during a guarded approach, the press and the hold, so each press is a *dense run* of joint-state
rows between free moves (retract, stand turn, transfer), which leave gaps. The detector is reset at
the first row of a run (as the loop resets it after arriving at the standoff) and sees the readings
up to the run's last row (the end of the hold, whose encoder reading the loop's forward kinematics
used).
"""
from __future__ import annotations

import json
import warnings
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path

import numpy as np

from explorer import loop
from explorer.loop import LoopConfig
from explorer.planner import PlannerConfig
from explorer.positioner import StandPose, stand_rotation
from explorer.evaluation import jsonable, reconstruction_errors
from explorer.recording import CONTACTS_HEADER
from explorer.session import SessionReader
from reconstruction.gpis import GPIS, KERNEL_NAMES
from sensor.contact_detection import PressureContactDetector, PressureDetectorConfig
from sensor.normal_estimation import OrientationNotSettledError, SettlingConfig, oriented_contact
from sensor.oriented_contact import OrientedContact

#: The settling criterion the exploration loop uses (``ExplorationLoop`` default; not recorded).
LOOP_SETTLING = SettlingConfig(**loop.LOOP_SETTLING)
#: Touch results whose press is in the recorded streams (the others never reached the standoff).
PRESSED_RESULTS = ("contact", "realign", "miss", "no_normal")
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
        Joint-state gap that separates two presses, seconds; None: ``GAP_IN_SPACINGS`` x the
        median spacing of the joint states.
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
    figures: bool = True

    def __post_init__(self):
        if self.kernel not in KERNEL_NAMES:
            raise ValueError(f"unknown kernel {self.kernel!r}; choose one of {', '.join(KERNEL_NAMES)}")
        if self.mesh_resolution is not None and self.mesh_resolution < 8:
            raise ValueError(f"mesh_resolution must be >= 8, got {self.mesh_resolution}")
        if self.segment_gap_s is not None and not self.segment_gap_s > 0:
            raise ValueError(f"segment_gap_s must be > 0 s, got {self.segment_gap_s}")


@dataclass
class ReplayedTouch:
    """One recorded press, detected again (object frame unless stated).

    Attributes
    ----------
    index : int
        Touch index in the session.
    kind : str
        Replay outcome: ``contact`` (used), ``set_aside`` (normal too far from the approach: the
        loop's realign rule), ``no_normal`` (orientation never settled) or ``miss``.
    recorded_kind : str
        What the loop recorded for this touch.
    target_m, approach_dir : (3,) float
        The touch as planned.
    stand_yaw_rad, stand_tilt_rad : float
    contact : OrientedContact or None
        World frame, as measured.
    position_m, normal : (3,) float or None
        Surface point (pad compression added back) and outward unit normal.
    baseline_pa : float or None
        Detector baseline at the contact start, pascals.
    """

    index: int
    kind: str
    recorded_kind: str
    target_m: np.ndarray
    approach_dir: np.ndarray
    stand_yaw_rad: float
    stand_tilt_rad: float
    contact: OrientedContact | None = None
    position_m: np.ndarray | None = None
    normal: np.ndarray | None = None
    baseline_pa: float | None = None


@dataclass
class ReplayResult:
    touches: list[ReplayedTouch]
    gpis: GPIS
    metrics: dict
    out_dir: Path | None
    notes: list[str] = field(default_factory=list)

    @property
    def contacts(self) -> list[ReplayedTouch]:
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
    """Joint-state rows ``first..last`` (inclusive) of one press and their times, seconds."""

    first: int
    last: int
    t_start_s: float
    t_end_s: float


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
        import objects
        import robots
        from robots.kinematics import ArmKinematics

        session_dir = Path(session_dir)
        if (session_dir / "session" / "metadata.json").is_file():
            session_dir = session_dir / "session"
        reader = SessionReader(session_dir)
        self.directory = session_dir
        self.metadata = reader.metadata
        self.truncated_files = reader.truncated_files
        self.readings = reader.readings()
        self.joint_states = reader.joint_states()
        self.events = reader.events()
        configuration = self.metadata.get("configuration") or {}
        self.configuration = configuration
        self.loop_config = _config(LoopConfig, configuration.get("loop"))
        self.planner_config = _config(PlannerConfig, configuration.get("planner"))
        robot = self.metadata["robot"]
        robot_name = robot if isinstance(robot, str) else robot.get("name")
        spec = robots.load(robot_name)
        self.kinematics = ArmKinematics(spec)
        if self.joint_states.dof not in (0, spec.dof):
            raise ValueError(f"{session_dir}: joint_states.csv has {self.joint_states.dof} joints but "
                             f"robot {robot_name!r} has {spec.dof}")
        # The simulated stand sits at the robot's workspace centre (explorer.simulation.build_scene).
        self.stand_centre_m = np.asarray(spec.workspace_center_m, float)
        self.truth = None
        self.prior = None
        object_name = self.metadata.get("object")
        if isinstance(object_name, str):
            try:
                self.truth = objects.load(object_name).mesh
            except (ValueError, FileNotFoundError):
                self.truth = None
        if self.truth is not None:
            from explorer.run import object_prior

            self.prior = object_prior(self.truth)

    # ------------------------------------------------------------------ replay
    def run(self, settings: ReplaySettings = ReplaySettings(), out_dir: Path | None = None) -> ReplayResult:
        """Detect, recompute, refit; write the outputs to ``out_dir`` when given."""
        notes: list[str] = []
        if self.truncated_files:
            notes.append("cut off mid-record (last incomplete line ignored): " + ", ".join(self.truncated_files))
        detector_config = self._detector_config(settings)
        touches = []
        for event, span in self._pressed_touches(settings, notes):
            touches.append(self._replay_touch(event, span, detector_config))
        use_normals = (self.configuration.get("use_normals", True) if settings.use_normals is None
                       else settings.use_normals)
        gpis = self._fit(touches, settings, use_normals)
        metrics = self._metrics(touches, gpis, settings, detector_config, use_normals, notes)
        result = ReplayResult(touches, gpis, metrics, None if out_dir is None else Path(out_dir), notes)
        if out_dir is not None:
            self._write(result, settings, use_normals)
        return result

    def _detector_config(self, settings: ReplaySettings) -> PressureDetectorConfig:
        recorded = _config(PressureDetectorConfig, self.configuration.get("detector"))
        start = recorded.start_threshold_pa if settings.start_threshold_pa is None else settings.start_threshold_pa
        end = recorded.end_threshold_pa if settings.end_threshold_pa is None else settings.end_threshold_pa
        if settings.end_threshold_pa is None and end > start:  # only the start was lowered
            end = start
        return PressureDetectorConfig(**{**asdict(recorded), "start_threshold_pa": start, "end_threshold_pa": end})

    def _pressed_touches(self, settings: ReplaySettings, notes: list[str]):
        """(touch event, press span) pairs, in order, for every touch that pressed."""
        spans = press_spans(self.joint_states.t_s, settings.segment_gap_s)
        starts = np.array([s.t_start_s for s in spans])
        last_reading_s = self.readings.t_s[-1] if len(self.readings) else -np.inf
        used = set()
        for event in self.events:
            if event.fields.get("result") not in PRESSED_RESULTS or "target_m" not in event.fields:
                continue
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

    def _replay_touch(self, event, span: PressSpan, detector_config) -> ReplayedTouch:
        f = event.fields
        touch = ReplayedTouch(int(f.get("index", -1)), "miss", f["result"], np.asarray(f["target_m"], float),
                              np.asarray(f["approach_dir"], float), float(f.get("stand_yaw_rad", 0.0)),
                              float(f.get("stand_tilt_rad", 0.0)))
        t = self.readings.t_s
        first = int(np.searchsorted(t, span.t_start_s, side="right"))
        stop = int(np.searchsorted(t, span.t_end_s, side="right"))
        detector = PressureContactDetector(detector_config)
        start = end = None
        for i in range(first, stop):
            event_i = detector.update(self.readings[i])
            if event_i is None:
                continue
            if event_i.kind == "start" and start is None:
                start, touch.baseline_pa = i, event_i.baseline_pa
            elif event_i.kind == "end" and start is not None:
                end = i  # the pad came off: later readings are not this contact's
                break
        if start is None:
            return touch
        readings = [self.readings[i] for i in range(start, stop if end is None else end)]
        pivot = self.kinematics.forward_kinematics(self.joint_states.q[span.last].copy(),
                                                   link=self.kinematics.spec.pivot_link).position_m
        try:
            contact = oriented_contact(readings, pivot, self.kinematics.pivot_to_pad_in_body,
                                       touch.baseline_pa, settling=LOOP_SETTLING)
        except (OrientationNotSettledError, ValueError):  # ValueError: pressure saturated
            touch.kind = "no_normal"
            return touch
        surface = contact.position_m + contact.normal * contact.force_n * self.loop_config.pad_compliance_m_per_n
        rotation = stand_rotation(StandPose(touch.stand_yaw_rad, touch.stand_tilt_rad))
        touch.contact = contact
        touch.position_m = (surface - self.stand_centre_m) @ rotation
        normal = contact.normal @ rotation
        touch.normal = normal / np.linalg.norm(normal)
        aligned = float(np.dot(touch.normal, -touch.approach_dir)) >= np.cos(self.loop_config.realign_angle_rad)
        touch.kind = "contact" if aligned else "set_aside"
        return touch

    # ------------------------------------------------------------------ reconstruction
    def _fit(self, touches: list[ReplayedTouch], settings: ReplaySettings, use_normals: bool) -> GPIS:
        """The GPIS, updated in the loop's order: contacts one by one, misses as free space."""
        options = {k: v for k, v in (("noise", settings.noise), ("normal_noise", settings.normal_noise))
                   if v is not None}
        gpis = GPIS(kernel=settings.kernel, use_normals=use_normals,
                    bounds=None if self.prior is None else self.prior.bounds(), **options)
        pending: list[np.ndarray] = []
        for touch in touches:
            if touch.kind == "contact":
                gpis.add(touch.position_m, touch.normal)
                if pending:
                    self._add_free_space(gpis, np.vstack(pending))
                    pending = []
            elif touch.kind == "miss":
                swept = self._swept_line(touch, gpis)
                if len(swept) and gpis.n_contacts:
                    self._add_free_space(gpis, swept)
                elif len(swept):
                    pending.append(swept)
        return gpis

    def _swept_line(self, touch: ReplayedTouch, gpis: GPIS) -> np.ndarray:
        """The approach path of a missed touch, object frame, inside the GPIS bounds (as the planner)."""
        cfg = self.planner_config
        offsets = np.arange(-cfg.standoff_m, cfg.depth_m + 1e-9, cfg.waypoint_spacing_m)
        points = touch.target_m + offsets[:, None] * touch.approach_dir
        if gpis.bounds is not None:
            lo, hi = gpis.bounds
            points = points[np.all((points > lo) & (points < hi), axis=1)]
        return points

    def _add_free_space(self, gpis: GPIS, points: np.ndarray) -> None:
        values = np.full(len(points), self.loop_config.free_space_value)
        gpis.add_values(points, values, noise=self.loop_config.free_space_noise)

    # ------------------------------------------------------------------ outputs
    def _metrics(self, touches, gpis, settings, detector_config, use_normals, notes) -> dict:
        kinds = [t.kind for t in touches]
        recorded = [t.recorded_kind for t in touches]
        return dict(
            source_session=str(self.directory), object=self.metadata.get("object"),
            robot=self.metadata.get("robot"), replay=dict(
                asdict(settings), start_threshold_pa=detector_config.start_threshold_pa,
                end_threshold_pa=detector_config.end_threshold_pa, use_normals=use_normals),
            touches=len(touches), contacts=kinds.count("contact"), misses=kinds.count("miss"),
            set_aside=kinds.count("set_aside"), no_normal=kinds.count("no_normal"),
            recorded_contacts=recorded.count("contact"), n_contacts_fitted=gpis.n_contacts,
            notes=list(notes),
        )

    def _write(self, result: ReplayResult, settings: ReplaySettings, use_normals: bool) -> None:
        out = result.out_dir
        out.mkdir(parents=True, exist_ok=True)
        with open(out / "contacts.csv", "w", encoding="utf-8") as f:
            f.write(CONTACTS_HEADER)
            for t in result.contacts:
                values = [*t.position_m, *t.normal, t.contact.t_s, t.contact.force_n,
                          t.stand_yaw_rad, t.stand_tilt_rad]
                f.write(f"{t.index}," + ",".join(repr(float(v)) for v in values) + "\n")
        metrics = result.metrics
        mesh = None
        if result.gpis.n_contacts:
            resolution = settings.mesh_resolution or int(self.configuration.get("mesh_resolution", 96))
            try:
                mesh = result.gpis.mesh(resolution=resolution)
                mesh.export(out / "reconstruction.ply")
            except ValueError as exc:
                metrics["reconstruction_error"] = str(exc)
        if mesh is not None and self.truth is not None:
            metrics.update(reconstruction_errors(mesh, self.truth, result.points_m, result.normals))
        (out / "metrics.json").write_text(json.dumps(jsonable(metrics), indent=2))
        if mesh is not None and self.truth is not None and settings.figures:
            from reconstruction import figures

            figures.error_coloured_views(mesh, self.truth, result.points_m, out / "reconstruction_error.png")
            figures.potential_slice(result.gpis if use_normals else None, None if use_normals else result.gpis,
                                    self.truth, path=out / "potential_slice.png")


def replay(session_dir: Path, settings: ReplaySettings = ReplaySettings(),
           out_dir: Path | None = None) -> ReplayResult:
    """Replay the session in ``session_dir`` with ``settings``; write outputs to ``out_dir`` if given."""
    with warnings.catch_warnings():  # a cut-off file is reported in the result's notes instead
        from explorer.session import SessionTruncatedWarning

        warnings.simplefilter("ignore", SessionTruncatedWarning)
        session = SessionReplay(session_dir)
    return session.run(settings, out_dir)
