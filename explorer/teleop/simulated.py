"""Simulation glue for teleoperation: scene, ready pose, device wiring, GUI drawing, outputs.

Only this module talks to PyBullet (key events and debug items, through the world's client);
devices and the session see plain callables and data.
"""
from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path
from types import SimpleNamespace
from typing import Callable

import numpy as np

from explorer.evaluation import jsonable
from explorer.loop import LOOP_SETTLING
from explorer.recording import RunRecorder
from explorer.run import object_prior
from explorer.simulation import build_scene
from explorer.teleop.devices import InputDevice
from explorer.teleop.session import TeleopConfig, TeleopContact, TeleopSession
from reconstruction.gpis import GPIS
from sensor.contact_detection import PressureContactDetector, PressureDetectorConfig
from sensor.normal_estimation import SettlingConfig

#: The arm starts with the pad this far outside the object's prior box ...
READY_CLEARANCE_M = 0.02
#: ... facing the object along this world direction (the side an ARMAR arm reaches best: away
#: from the robot and down).
READY_APPROACH = (0.9, 0.0, -0.45)


@dataclass(frozen=True)
class DeviceContext:
    """What a device factory may use.

    Attributes
    ----------
    clock : callable () -> float
        Simulation time, seconds.
    key_events : callable () -> dict {key code: state flags}
        The GUI's keyboard events (empty when headless).
    start_pad_m : (3,) float
        Pad position at the ready pose, world frame, metres.
    approach_dir : (3,) float
        The pad's face axis at the ready pose (into the object), world frame, unit.
    object_origin_m : (3,) float
        Object-frame origin in the world (stand at its home pose: no rotation), metres.
    """

    clock: Callable[[], float]
    key_events: Callable[[], dict]
    start_pad_m: np.ndarray
    approach_dir: np.ndarray
    object_origin_m: np.ndarray


@dataclass
class TeleopResult:
    """The recorded contacts (object frame), the suggested next touch, the final mesh and GPIS."""

    contacts: list[TeleopContact]
    suggestion_m: np.ndarray | None
    mesh: object
    out_dir: Path
    gpis: GPIS | None = None


def run_simulated_teleop(object_name: str, device_factory: Callable[[DeviceContext], InputDevice],
                         out_dir: Path, robot: str = "armar3", gui: bool = True,
                         config: TeleopConfig = TeleopConfig(), max_duration_s: float | None = None,
                         seed: int = 0, observer=None) -> TeleopResult:
    """Teleoperate the simulated arm on ``object_name``; write the session and outputs to ``out_dir``.

    Outputs: ``session/``, ``contacts.csv`` (object frame), ``reconstruction.ply`` and
    ``teleop.json`` (contacts, suggested next touch) once there are contacts. ``observer``
    (:class:`explorer.observer.RunObserver`) is shown the session as it is recorded.
    """
    from robots.ik import PadIK

    out_dir = Path(out_dir)
    with build_scene(object_name, robot, seed=seed, gui=gui) as scene:
        prior = object_prior(scene.object_model.mesh)
        approach = np.asarray(READY_APPROACH, float) / np.linalg.norm(READY_APPROACH)
        centre = scene.stand.to_world(prior.centre_m[None])[0]
        start = centre - (prior.radius_m + READY_CLEARANCE_M) * approach
        solution = PadIK(scene.kinematics).solve(start[None], approach[None])
        if not solution.success[0]:
            raise ValueError(f"robot {robot!r} cannot reach the ready pose above {object_name!r}")
        scene.arm.move_joints(solution.q_rad[0], speed_rad_s=1.0)
        scene.sensor.drain()  # the transfer is not part of the session
        pb = _pybullet() if gui else None
        key_events = (lambda: pb.getKeyboardEvents(physicsClientId=scene.world.client)) if gui else dict
        pad = scene.kinematics.forward_kinematics(scene.arm.joint_positions())
        context = DeviceContext(scene.arm.time_s, key_events, pad.position_m, pad.z_axis,
                                np.asarray(scene.stand.centre_m, float))
        detector_config, settling = PressureDetectorConfig(), SettlingConfig(**LOOP_SETTLING)
        # what tactile-reconstruct needs to detect the contacts again (explorer/replay.py)
        configuration = dict(mode="teleop", teleop=asdict(config), detector=asdict(detector_config),
                             settling=asdict(settling), stand_centre_m=scene.stand.centre_m,
                             prior=dict(centre_m=prior.centre_m, half_extent_m=prior.half_extent_m))
        metadata = dict(robot=robot, sensor="simulated BNO055 + BMP280 under polyurethane", object=object_name,
                        seed=None, backend="simulation", configuration=jsonable(configuration))
        recorder = RunRecorder(out_dir, metadata, observer=observer)
        drawer = _DebugDrawer(pb, scene.world.client) if gui else None
        session = TeleopSession(scene.arm, scene.sensor, scene.kinematics, scene.stand, prior, recorder,
                                config, on_update=drawer.draw if drawer else None,
                                detector=PressureContactDetector(detector_config), settling=settling)
        if observer is not None:
            observer.run_started(SimpleNamespace(kinematics=scene.kinematics, positioner=scene.stand,
                                                 reference=scene.object_model.mesh), session.gpis, metadata)
        error = None
        try:
            with device_factory(context) as device:
                session.run(device, max_duration_s)
        except BaseException as exc:
            error = exc
            raise
        finally:
            mesh = _finish(session, recorder, out_dir, error)
    return TeleopResult(session.contacts, session.suggestion_m, mesh, out_dir, session.gpis)


def _finish(session: TeleopSession, recorder: RunRecorder, out_dir: Path, error) -> object:
    mesh = None
    if session.gpis.n_contacts:
        mesh = session.snapshot()
        mesh.export(out_dir / "reconstruction.ply")
    summary = dict(contacts=[dict(index=c.index, position_m=c.position_m.tolist(), normal=c.normal.tolist())
                             for c in session.contacts],
                   suggested_touch_m=None if session.suggestion_m is None else session.suggestion_m.tolist(),
                   completed=error is None)
    (out_dir / "teleop.json").write_text(json.dumps(summary, indent=2))
    recorder.close(error)
    return mesh


def _pybullet():
    from robots.sim_world import import_pybullet

    return import_pybullet()


class _DebugDrawer:
    """Contacts (green points), normals (blue lines) and the suggested touch (red cross) in the GUI."""

    NORMAL_LENGTH_M = 0.02

    def __init__(self, pb, client: int):
        self._pb = pb
        self._client = client
        self._suggestion: list[int] = []

    def draw(self, session: TeleopSession) -> None:
        pb, client = self._pb, self._client
        latest = session.contacts[-1]
        p, n = session.to_world(latest.position_m[None], latest.normal[None])
        pb.addUserDebugPoints([p[0].tolist()], [[0.1, 0.8, 0.1]], pointSize=6, physicsClientId=client)
        pb.addUserDebugLine(p[0].tolist(), (p[0] + self.NORMAL_LENGTH_M * n[0]).tolist(), [0.1, 0.2, 0.9],
                            lineWidth=2, physicsClientId=client)
        for item in self._suggestion:
            pb.removeUserDebugItem(item, physicsClientId=client)
        self._suggestion = []
        if session.suggestion_m is not None:
            s = session.to_world(session.suggestion_m[None])[0]
            for axis in np.eye(3) * 0.006:
                self._suggestion.append(pb.addUserDebugLine((s - axis).tolist(), (s + axis).tolist(),
                                                            [0.9, 0.1, 0.1], lineWidth=3, physicsClientId=client))
            self._suggestion.append(pb.addUserDebugText("next touch?", (s + [0, 0, 0.01]).tolist(),
                                                        [0.9, 0.1, 0.1], textSize=1.2, physicsClientId=client))
