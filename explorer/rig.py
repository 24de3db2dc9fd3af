"""What a run explores with: the devices, the object's rough location and the sensor's pad.

Simulated, emulated and hardware rigs are built the same way (:func:`explorer.run.explore` for the
simulation on a turning stand, :func:`explorer.backends.open_rig` from a configuration file) and
the loop, teleoperation and the run only see a :class:`Rig`.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from explorer.touch import ObjectPrior
from sensor.pad_calibration import PadCalibration

#: The prior box: the object's bounding box grown by this fraction of its size plus a centimetre
#: (a rough location and size; an over-estimate is safe).
PRIOR_GROWTH = 0.1
PRIOR_MARGIN_M = 0.01


@dataclass
class Rig:
    """The devices of one run and what is known beforehand.

    Attributes
    ----------
    robot : robots.interface.Robot
    sensor : sensor.interface.TactileSensor
        Opened by whoever built the rig.
    kinematics : robots.kinematics.ArmKinematics
        Of the robot's URDF.
    positioner : explorer.positioner.Positioner
        Holds the object; its pose carries contacts into the object frame.
    prior : ObjectPrior
        The object's rough location and size, object frame.
    reference : trimesh.Trimesh or None
        The true surface, object frame, metres, for error metrics (None on hardware without one).
    description : dict
        Session metadata: ``robot``, ``sensor``, ``object``, ``backend``.
    pad : PadCalibration
        The sensor's pad: force model, compliance and IMU mounting (the simulated pad's in
        simulation, the sensor calibration's on hardware).
    obstacles : tuple of ((3,), (3,)) float
        What else is fixed in the workspace, as axis-aligned boxes in the world frame, (centre, half
        extent) in metres: the table (the simulated one's :meth:`robots.sim_world.TableSpec.box_m`;
        on hardware the configuration's ``robot.obstacles_m``). Free moves keep clear of them as of
        the prior box; empty: nothing is known.
    """

    robot: object
    sensor: object
    kinematics: object
    positioner: object
    prior: ObjectPrior
    reference: object | None
    description: dict
    pad: PadCalibration = field(default_factory=PadCalibration)
    obstacles: tuple = ()


def object_prior(mesh) -> ObjectPrior:
    """The rough location and size the loop is given (object frame)."""
    lo, hi = mesh.bounds
    return ObjectPrior(0.5 * (lo + hi), 0.5 * (hi - lo) * (1 + PRIOR_GROWTH) + PRIOR_MARGIN_M)
