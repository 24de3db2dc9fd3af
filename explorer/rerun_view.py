"""A run in Rerun (``--rerun [FILE.rrd]``): the 3-D scene and the sensor streams on one clock.

:class:`RerunObserver` is a :class:`explorer.observer.RunObserver`: give it to
:func:`explorer.run.run_on_rig` (or a :class:`explorer.recording.RunRecorder`) and it logs, on the
``session_time`` timeline (the run's simulated or device clock, seconds):

=================================  ==========================================================
entity                             what
=================================  ==========================================================
``world/object``                   Transform3D object -> world (the stand's pose)
``world/object/truth``             Mesh3D, the true surface (static; when known)
``world/object/gpis``              Mesh3D, the GPIS mean surface coloured by its variance
                                   (blue low, yellow high), every ``surface_every`` touches
``world/object/reconstruction``    Mesh3D, the final surface of the run
``world/object/targets``           Points3D, every touch's target so far, coloured by outcome
``world/object/approaches``        Arrows3D, every touch's approach direction (5 cm)
``world/object/contacts``          Points3D, the contacts so far
``world/object/normals``           Arrows3D, their measured outward normals (1 cm)
``world/object/suggestion``        Arrows3D, the strategy's suggested next touch
``world/pad/path``                 LineStrips3D, the pad's path (world frame, FK of the joints)
``touches``                        TextLog, one line per touch: index, outcome, strategy
``sensor/pressure_pa``             Scalars, barometer pressure, Pa
``sensor/compensated_pa``          Scalars, pressure above the detector's drift baseline, Pa
``sensor/in_contact``              Scalars, the pressure detector's state (1 in contact)
``sensor/orientation/{w,x,y,z}``   Scalars, the IMU quaternion
=================================  ==========================================================

:func:`log_session` writes the same from a recorded session (``tactile-reconstruct --rerun``).
Rerun is the optional extra ``viz`` (``pip install -e .[viz]``); nothing here imports it before
:func:`open_stream`.
"""
from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from explorer.observer import RunObserver

TIMELINE = "session_time"
INSTALL_HINT = "pip install -e .[viz]"
OUTCOME_COLOURS = {"contact": (40, 180, 60), "miss": (220, 60, 50), "unreachable": (150, 150, 150),
                   "realign": (240, 170, 30), "no_normal": (160, 80, 200), "blocked": (90, 90, 90)}
APPROACH_LENGTH_M = 0.05
NORMAL_LENGTH_M = 0.01
FLUSH_EVERY_S = 1.0


class RerunMissingError(RuntimeError):
    """rerun-sdk is not installed; the message names the install command."""


def require_rerun():
    """The ``rerun`` module, or :class:`RerunMissingError` naming ``pip install -e .[viz]``."""
    try:
        import rerun
    except ImportError as error:
        raise RerunMissingError(f"--rerun needs the rerun-sdk package ({error}); install it with: "
                                f"{INSTALL_HINT}") from None
    return rerun


def open_stream(path: Path | None, application: str = "tactile-explore"):
    """A Rerun recording stream writing to ``path`` (.rrd), or to a spawned viewer when None."""
    rr = require_rerun()
    stream = rr.RecordingStream(application)
    if path is None:
        stream.spawn()
    else:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        stream.save(str(path))
    return stream


class RerunObserver(RunObserver):
    """Logs a run to a Rerun recording stream (see the module docstring for the entities).

    Sensor readings and joint states are buffered and sent in columns at each touch, every
    ``FLUSH_EVERY_S`` of session time between touches (a live viewer keeps up with a slow
    operator) and at the end, so logging costs a few calls per touch rather than per reading.

    Parameters
    ----------
    stream : rerun.RecordingStream
        From :func:`open_stream`; closed (flushed) by :meth:`close`.
    surface_every : int
        Log the GPIS surface every this many touches (and after the last); 0: never.
    surface_resolution : int
        Meshing samples along the longest side for those surfaces.
    pad_path_step_s : float
        The pad's path keeps at most one joint state per this many seconds.
    detector_config : sensor.contact_detection.PressureDetectorConfig, optional
        For the compensated pressure and detector state; default: the run's recorded detector
        settings, else the defaults.
    """

    def __init__(self, stream, surface_every: int = 1, surface_resolution: int = 32,
                 pad_path_step_s: float = 0.02, detector_config=None):
        if surface_every < 0 or surface_resolution < 8 or not pad_path_step_s > 0:
            raise ValueError("surface_every >= 0, surface_resolution >= 8 and pad_path_step_s > 0 are needed")
        self.rr = require_rerun()
        self.stream = stream
        self.surface_every = int(surface_every)
        self.surface_resolution = int(surface_resolution)
        self.pad_path_step_s = float(pad_path_step_s)
        self._detector_config = detector_config
        self._detector = None
        self.kinematics = None
        self.positioner = None
        self.gpis = None
        self._readings: list = []
        self._joints: list[tuple[float, np.ndarray]] = []
        self._path: list[np.ndarray] = []
        self._last_path_t = -math.inf
        self._targets: list[tuple[np.ndarray, np.ndarray, str]] = []
        self._contacts: list[tuple[np.ndarray, np.ndarray]] = []
        self._touches = 0
        self._surface_at = -1
        self._last_t = 0.0

    # ------------------------------------------------------------------ RunObserver
    def run_started(self, rig, gpis, metadata: dict) -> None:
        from sensor.contact_detection import PressureContactDetector, PressureDetectorConfig

        self.kinematics = getattr(rig, "kinematics", None)
        self.positioner = getattr(rig, "positioner", None)
        self.gpis = gpis
        config = self._detector_config
        recorded = (metadata.get("configuration") or {}).get("detector")
        if config is None and isinstance(recorded, dict):
            try:
                config = PressureDetectorConfig(**recorded)
            except TypeError:
                config = None
        self._detector = PressureContactDetector(config or PressureDetectorConfig())
        rr = self.rr
        self.stream.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        truth = getattr(rig, "reference", None)
        if truth is not None:
            self.stream.log("world/object/truth", rr.Mesh3D(
                vertex_positions=np.asarray(truth.vertices, np.float32),
                triangle_indices=np.asarray(truth.faces, np.uint32),
                vertex_normals=np.asarray(truth.vertex_normals, np.float32),
                albedo_factor=(200, 200, 200, 90)), static=True)
        if self.positioner is not None:
            self._set_time(0.0)
            self._log_stand(self.positioner.pose())

    def readings(self, readings: list) -> None:
        self._readings.extend(readings)
        if self._readings and self._readings[-1].t_s - self._readings[0].t_s >= FLUSH_EVERY_S:
            self._flush_streams()

    def joint_state(self, t_s: float, q: np.ndarray) -> None:
        if t_s - self._last_path_t >= self.pad_path_step_s:
            self._joints.append((t_s, np.array(q, float)))
            self._last_path_t = t_s

    def touch(self, record, t_s: float) -> None:
        self._flush_streams()
        self._set_time(t_s)
        rr, log = self.rr, self.stream.log
        self._touches += 1
        if self.positioner is not None:
            from explorer.positioner import StandPose

            self._log_stand(StandPose(record.stand_yaw_rad, record.stand_tilt_rad))
        self._targets.append((np.asarray(record.target_m, float), np.asarray(record.approach_dir, float),
                              record.kind))
        targets = np.array([t for t, _, _ in self._targets])
        colours = [OUTCOME_COLOURS.get(kind, (255, 255, 255)) for _, _, kind in self._targets]
        log("world/object/targets", rr.Points3D(targets, colors=colours, radii=0.002))
        log("world/object/approaches", rr.Arrows3D(
            origins=targets - APPROACH_LENGTH_M * np.array([a for _, a, _ in self._targets]),
            vectors=APPROACH_LENGTH_M * np.array([a for _, a, _ in self._targets]), colors=colours))
        log("touches", rr.TextLog(f"touch {record.index}: {record.kind}"
                                  + (f" ({record.strategy})" if getattr(record, "strategy", "") else "")))
        if record.kind == "contact":
            self._contacts.append((np.asarray(record.position_m, float), np.asarray(record.normal, float)))
            points = np.array([p for p, _ in self._contacts])
            log("world/object/contacts", rr.Points3D(points, colors=(40, 180, 60), radii=0.0025))
            log("world/object/normals", rr.Arrows3D(
                origins=points, vectors=NORMAL_LENGTH_M * np.array([n for _, n in self._contacts]),
                colors=(40, 120, 220)))
        if self.surface_every and self._touches % self.surface_every == 0:
            self._log_surface()

    def suggestion(self, touch, t_s: float) -> None:
        self._log_suggestion(np.asarray(touch.target_m, float), np.asarray(touch.approach_dir, float), t_s)

    def event(self, kind: str, t_s: float, fields: dict) -> None:
        if kind == "suggested_touch" and "point_m" in fields:  # teleoperation: a point, no approach
            self._set_time(t_s)
            self.stream.log("world/object/suggestion", self.rr.Points3D(
                [fields["point_m"]], colors=(250, 200, 0), radii=0.004))

    def reconstruction(self, mesh, n_contacts: int, t_s: float) -> None:
        self._set_time(t_s)
        self.stream.log("world/object/reconstruction", self.rr.Mesh3D(
            vertex_positions=np.asarray(mesh.vertices, np.float32),
            triangle_indices=np.asarray(mesh.faces, np.uint32),
            vertex_normals=np.asarray(mesh.vertex_normals, np.float32), albedo_factor=(90, 160, 230)))

    def close(self) -> None:
        self._flush_streams()
        if self.surface_every and self._surface_at != self._touches:
            self._set_time(self._last_t)
            self._log_surface()
        self.stream.flush()

    # ------------------------------------------------------------------ pieces
    def _set_time(self, t_s: float) -> None:
        self._last_t = max(self._last_t, float(t_s))
        self.stream.set_time(TIMELINE, duration=float(t_s))

    def _log_stand(self, pose) -> None:
        rotation, centre = self.positioner.object_to_world(pose)
        self.stream.log("world/object", self.rr.Transform3D(translation=centre, mat3x3=rotation))

    def _log_suggestion(self, target: np.ndarray, approach: np.ndarray, t_s: float) -> None:
        self._set_time(t_s)
        self.stream.log("world/object/suggestion", self.rr.Arrows3D(
            origins=[target - APPROACH_LENGTH_M * approach], vectors=[APPROACH_LENGTH_M * approach],
            colors=(250, 200, 0), radii=0.0015))

    def _log_surface(self) -> None:
        """The GPIS mean surface coloured by the GPIS variance at its vertices."""
        self._surface_at = self._touches
        if self.gpis is None or self.gpis.n_contacts < 2:
            return
        try:
            mesh = self.gpis.mesh(resolution=self.surface_resolution)
        except ValueError:  # no zero level set yet
            return
        variance = np.asarray(self.gpis.variance(np.asarray(mesh.vertices, float)), float)
        self.stream.log("world/object/gpis", self.rr.Mesh3D(
            vertex_positions=np.asarray(mesh.vertices, np.float32),
            triangle_indices=np.asarray(mesh.faces, np.uint32),
            vertex_normals=np.asarray(mesh.vertex_normals, np.float32),
            vertex_colors=_variance_colours(variance)))

    def _flush_streams(self) -> None:
        """Send the buffered readings and the pad path since the last touch."""
        if self._readings:
            readings, self._readings = self._readings, []
            self.log_readings(np.array([r.t_s for r in readings]), np.array([r.pressure_pa for r in readings]),
                              np.array([r.quat_wxyz for r in readings]).reshape(-1, 4))
        if self._joints:
            joints, self._joints = self._joints, []
            self.log_joint_states(np.array([t for t, _ in joints]), np.array([q for _, q in joints]))

    def log_readings(self, t_s: np.ndarray, pressure_pa: np.ndarray, quat_wxyz: np.ndarray) -> None:
        """Sensor streams as columns: pressure, compensated pressure, detector state, orientation."""
        from sensor.contact_detection import PressureContactDetector
        from sensor.reading import Reading

        if self._detector is None:
            self._detector = PressureContactDetector(self._detector_config)
        rr = self.rr
        compensated, state = np.empty(len(t_s)), np.empty(len(t_s))
        zero = np.zeros(3)
        for i in range(len(t_s)):
            reading = Reading(float(t_s[i]), float(pressure_pa[i]), quat_wxyz[i], zero, zero)
            self._detector.update(reading)
            compensated[i] = self._detector.rise_pa(reading)
            state[i] = float(self._detector.in_contact)
        index = [rr.TimeColumn(TIMELINE, duration=np.asarray(t_s, float))]
        columns = {"sensor/pressure_pa": pressure_pa, "sensor/compensated_pa": compensated,
                   "sensor/in_contact": state}
        columns.update({f"sensor/orientation/{axis}": quat_wxyz[:, k] for k, axis in enumerate("wxyz")})
        for entity, values in columns.items():
            self.stream.send_columns(entity, indexes=index,
                                     columns=rr.Scalars.columns(scalars=np.asarray(values, float)))

    def log_joint_states(self, t_s: np.ndarray, q: np.ndarray) -> None:
        """Extend the pad's path (world frame) by the pad positions of these joint states."""
        if self.kinematics is None or not len(t_s):
            return
        self._path.extend(np.asarray(self.kinematics.forward_kinematics(q).position_m, float).reshape(-1, 3))
        self._set_time(float(t_s[-1]))
        self.stream.log("world/pad/path", self.rr.LineStrips3D([np.array(self._path)], colors=(230, 120, 30),
                                                              radii=0.0008))


def _variance_colours(variance: np.ndarray) -> np.ndarray:
    """(n, 3) uint8 colours, viridis over the snapshot's own variance range."""
    from matplotlib import colormaps

    lo, hi = float(np.min(variance)), float(np.max(variance))
    scaled = (variance - lo) / (hi - lo) if hi > lo else np.zeros_like(variance)
    return (255 * colormaps["viridis"](scaled)[:, :3]).astype(np.uint8)


def log_session(session_dir: Path, observer: RerunObserver, use_normals: bool | None = None) -> int:
    """Log a recorded session as the run would have: streams, touches, GPIS after each touch.

    The GPIS is refitted as the loop updated it: the recorded contacts (object frame) and, for
    misses, the free space their approach swept, with the recorded prior, normals and free-space
    settings; the truth is the registry object or mesh file the metadata names, when it
    still loads. Returns the number of touches logged.
    """
    import objects
    import robots
    from explorer.evidence import SurfaceEvidence
    from explorer.loop import LoopConfig
    from explorer.positioner import FixedStand
    from explorer.session import read_session
    from explorer.touch import ObjectPrior
    from reconstruction.gpis import GPIS
    from robots.kinematics import ArmKinematics

    session_dir = Path(session_dir)
    if (session_dir / "session" / "metadata.json").is_file():
        session_dir = session_dir / "session"
    session = read_session(session_dir)
    metadata = session.metadata
    configuration = metadata.get("configuration") or {}
    kinematics = None
    try:
        from explorer.arm_calibration import with_fitted_link_lengths

        lengths = (metadata.get("calibration") or {}).get("link_length_error_m") or {}
        kinematics = with_fitted_link_lengths(ArmKinematics(robots.load(metadata["robot"])), lengths)
    except (KeyError, ValueError, OSError):
        pass
    truth = None
    try:
        truth = objects.load(metadata["object"]).mesh
    except (KeyError, ValueError, OSError, TypeError):
        pass
    centre = configuration.get("stand_centre_m")
    positioner = FixedStand(np.asarray(centre, float)) if centre is not None else None
    prior_cfg = configuration.get("prior")
    bounds = None
    if prior_cfg:
        prior = ObjectPrior(np.asarray(prior_cfg["centre_m"], float), np.asarray(prior_cfg["half_extent_m"], float))
        bounds = prior.bounds()
    normals = configuration.get("use_normals", True) if use_normals is None else use_normals
    gpis = GPIS(bounds=bounds, use_normals=normals)
    loop = configuration.get("loop") or {}
    evidence = SurfaceEvidence(gpis, float(loop.get("free_space_value", LoopConfig.free_space_value)),
                               float(loop.get("free_space_noise", LoopConfig.free_space_noise)))
    observer.run_started(SimpleNamespace(kinematics=kinematics, positioner=positioner, reference=truth),
                         gpis, metadata)

    readings, joints = session.readings, session.joint_states
    touches = 0
    r0 = j0 = 0
    kinds = {"touch": "contact", "miss": "miss"}
    for event in session.events:
        if "target_m" not in event.fields or "result" not in event.fields:
            observer.event(event.kind, event.t_s, dict(event.fields))
            continue
        r1 = int(np.searchsorted(readings.t_s, event.t_s, side="right"))
        j1 = int(np.searchsorted(joints.t_s, event.t_s, side="right"))
        if r1 > r0:
            observer.log_readings(readings.t_s[r0:r1], readings.pressure_pa[r0:r1], readings.quat_wxyz[r0:r1])
        if j1 > j0:
            keep = _thin(joints.t_s[j0:j1], observer.pad_path_step_s)
            observer.log_joint_states(joints.t_s[j0:j1][keep], joints.q[j0:j1][keep])
        r0, j0 = r1, j1
        f = event.fields
        record = SimpleNamespace(
            index=int(f.get("index", touches)), kind=str(f["result"]) if event.kind not in kinds else kinds[event.kind],
            target_m=np.asarray(f["target_m"], float), approach_dir=np.asarray(f["approach_dir"], float),
            position_m=None if f.get("position_m") is None else np.asarray(f["position_m"], float),
            normal=None if f.get("normal") is None else np.asarray(f["normal"], float),
            stand_yaw_rad=float(f.get("stand_yaw_rad", 0.0)), stand_tilt_rad=float(f.get("stand_tilt_rad", 0.0)),
            strategy=str(f.get("strategy", "")))
        if record.kind == "contact" and record.position_m is not None:
            evidence.add_contact(record.position_m[None], record.normal[None] if normals else None)
        elif record.kind == "miss" and f.get("free_space_m") is not None:
            evidence.add_free_space(np.asarray(f["free_space_m"], float).reshape(-1, 3))
        observer.touch(record, event.t_s)
        touches += 1
    if r0 < len(readings):
        observer.log_readings(readings.t_s[r0:], readings.pressure_pa[r0:], readings.quat_wxyz[r0:])
    if j0 < len(joints):
        keep = _thin(joints.t_s[j0:], observer.pad_path_step_s)
        observer.log_joint_states(joints.t_s[j0:][keep], joints.q[j0:][keep])
    for snapshot in session.reconstructions[-1:]:
        import trimesh

        observer.reconstruction(trimesh.load(snapshot.path, process=False), snapshot.n_contacts, snapshot.t_s)
    observer.close()
    return touches


def _thin(t_s: np.ndarray, step_s: float) -> np.ndarray:
    """Indices keeping at most one time per ``step_s`` (the first of each)."""
    keep, last = [], -math.inf
    for i, t in enumerate(t_s):
        if t - last >= step_s:
            keep.append(i)
            last = t
    return np.array(keep, int)


def add_rerun_argument(parser) -> None:
    """``--rerun [FILE.rrd]`` on an argparse parser (no file: spawn a viewer)."""
    parser.add_argument("--rerun", nargs="?", const="", metavar="FILE.rrd",
                        help="log the run to Rerun: into FILE.rrd, or without a file to a spawned viewer "
                             f"(needs the viz extra: {INSTALL_HINT})")


def check_rerun_argument(parser, value: str | None) -> None:
    """Refuse a ``--rerun`` value that cannot work, before anything is opened or written.

    A file that does not end in .rrd, or rerun-sdk missing: one line (naming ``pip install -e .[viz]``
    for the latter) and exit status 2. No flag: nothing to check.
    """
    if value is None:
        return
    if value and Path(value).suffix != ".rrd":
        parser.exit(2, f"{parser.prog}: error: --rerun {value}: the file must end in .rrd\n")
    try:
        require_rerun()
    except RerunMissingError as error:
        parser.exit(2, f"{parser.prog}: error: {error}\n")


def observer_from_argument(parser, value: str | None, application: str, surface_every: int = 1):
    """The :class:`RerunObserver` a ``--rerun`` value asks for, None without the flag.

    The value is checked first (:func:`check_rerun_argument`); the stream (file or viewer) is opened
    only then.
    """
    check_rerun_argument(parser, value)
    if value is None:
        return None
    return RerunObserver(open_stream(Path(value) if value else None, application), surface_every=surface_every)
