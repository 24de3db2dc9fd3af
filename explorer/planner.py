"""Turning a touch into arm motions: stand pose, standoff pose and a straight approach path.

For a :class:`explorer.touch.Touch` (object frame) the planner

1. ranks the stand poses by how reachable the resulting world approach direction is, using a
   reachability map of the arm (IK success over approach directions at the stand centre, computed
   once per planner);
2. solves batched IK (``robots.ik.PadIK``) for the standoff point and the waypoints of a straight
   approach line through the target, all seeded from the standoff solution so the path stays on
   one arm posture; a touch that leaves its depth to the planner probes on past the target through
   the prior box (at most ``probe_depth_m``), cut where IK or the posture gives out;
3. rejects plans whose joint path jumps (another IK branch), or whose arm links - upper arm and
   forearm, not the hand and fingertip that must get close - enter the object's prior box.

Works from the kinematics alone (the same URDF as the simulator), so it serves simulated and real
arms alike.
"""
from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from explorer.positioner import Positioner, StandPose
from explorer.strategies import fibonacci_directions
from explorer.touch import ObjectPrior, Touch


#: Arm spheres this close to the tool point (the finger that carries the fingertip) are left out of
#: the free-move check: at a standoff they sit within centimetres of the object, as the pad does.
FINGER_EXEMPT_M = 0.04


@dataclass(frozen=True)
class PlannerConfig:
    """Approach geometry and limits (metres, radians).

    Attributes
    ----------
    standoff_m : float
        Pad distance before the target where the guarded move starts.
    depth_m : float
        How far beyond the target the guarded move may go before the touch counts as a miss, at
        least (a touch may set its own; ``press_reserve_m`` is added).
    probe_depth_m : float
        A touch that leaves its depth to the planner (``Touch.depth_m`` None: the ``variance`` and
        ``efficient`` proposals) goes on past the target until it leaves the prior box, at most this
        far, wherever the arm can follow the line (the path is cut at the first waypoint IK or the
        joint-step check fails, but never shorter than ``depth_m``). The GPIS's surface is a guess:
        inside a cup or a bowl the real surface lies centimetres behind the lid the GPIS closes over
        the opening, and a probe that stops 3 cm past it is a miss. ``depth_m`` switches it off.
    press_reserve_m : float
        The line goes on this far beyond its depth (or probe), so that a contact found at its very
        end still leaves the loop's press and re-press their travel (``LoopConfig.press_depth_m``
        each). Without it a pad that met the surface on the line's last millimetres stopped at a
        fraction of the press force and was rejected as a press on the pad's side.
    waypoint_spacing_m : float
        Spacing of IK waypoints along the approach line (the last one is at the line's end).
    max_joint_step_rad : float
        Largest joint change between consecutive waypoints (larger = IK jumped branch).
    reach_map_directions : int
        Approach directions in the reachability map.
    reach_cone_rad : float
        A stand pose scores by the reachable map directions within this angle of its approach.
    poses_to_try : int
        Stand poses tried (best reachability first) before a touch counts as unreachable.
    arm_clearance_m : float
        Minimum distance of the upper-arm and forearm links from the prior box.
    retreat_offsets_m : tuple of (3,) float
        Candidate pad positions of the rest pose relative to the stand centre (world frame: back
        towards the robot, out to the arm's side, up); the arm waits there while the stand turns.
    approach_tilts_rad : tuple of float
        When no stand pose gives a plan along the touch's own approach, approaches tilted this far
        from it are tried (the spring turns the pad onto the surface; the touch keeps its intended
        approach, so the realign rule still compares the measured normal with it). Undersides,
        insides and the far side of tall parts are often out of reach head-on and within reach
        tilted. Empty (the default): head-on only; e.g. ``(radians(20), radians(35))`` turns the
        fallback on (off by default: the contact quality of tilted presses is unmeasured, and on the
        emulated hardware rig they pressed to 27 N against a 7 N bound).
    tilt_azimuths : int
        Tilted directions per tilt angle (evenly spread around the approach).
    tilted_to_try : int
        Tilted directions planned (best reachability first) before the touch counts as unreachable.
    free_move_clearance_m : float or None
        Free moves (transfers, the move to rest) keep the arm up to the hand this far outside the
        prior box where the straight joint path would not (:meth:`ApproachPlanner.transfer_path`,
        :mod:`explorer.free_path`); None: straight joint paths only (the loop before this check).
    hand_clearance_m : float or None
        A plan whose standoff pose puts the arm, shoulder to hand (its exact collision primitives,
        :class:`robots.link_shapes.ArmShapes`; not the finger that carries the pad), closer than
        this to a point the pad has touched is rejected (``touched_m`` of :meth:`ApproachPlanner.plan`):
        the hand would sit on the object there, every transfer to the standoff would be blocked and
        the touch lost ("blocked"). Rejected at planning, the loop tries its next proposal instead,
        at no cost to the budget. Chosen on the tuning split (BENCHMARKS.md); None: no check.
    """

    standoff_m: float = 0.03
    depth_m: float = 0.03
    probe_depth_m: float = 0.15
    press_reserve_m: float = 0.005
    waypoint_spacing_m: float = 0.01
    max_joint_step_rad: float = 0.25
    reach_map_directions: int = 160
    reach_cone_rad: float = np.radians(20.0)
    poses_to_try: int = 3
    arm_clearance_m: float = 0.04
    retreat_offsets_m: tuple = ((-0.1, -0.1, 0.15), (0.0, -0.15, 0.15), (-0.15, 0.0, 0.05))
    approach_tilts_rad: tuple = ()
    tilt_azimuths: int = 8
    tilted_to_try: int = 4
    free_move_clearance_m: float | None = 0.02
    hand_clearance_m: float | None = 0.005


@dataclass(frozen=True)
class ApproachPlan:
    """A reachable touch.

    Attributes
    ----------
    touch : Touch
        The touch (object frame); its ``approach_dir`` is the intended one (the inward normal the
        strategy expects), which ``approach_world`` may differ from by a tilt.
    stand : StandPose
        Stand pose to use.
    target_world_m, approach_world : (3,) float
        Target and approach direction in the world at that pose.
    path_q : (k, dof) float
        Joint waypoints: standoff first, then along the approach line to ``depth_m`` beyond the target.
    path_world_m : (k, 3) float
        Pad positions of the waypoints (world).
    tilt_rad : float
        Angle between the pad's travel and the touch's intended approach (0: head-on).
    """

    touch: Touch
    stand: StandPose
    target_world_m: np.ndarray
    approach_world: np.ndarray
    path_q: np.ndarray
    path_world_m: np.ndarray
    tilt_rad: float = 0.0

    @property
    def standoff_q(self) -> np.ndarray:
        return self.path_q[0]

    def along_line(self, points_world_m: np.ndarray) -> np.ndarray:
        """How far ``points_world_m`` ((3,) or (k, 3), world) lie along the approach line from the
        standoff, metres: () or (k,)."""
        return (np.asarray(points_world_m, float) - self.path_world_m[0]) @ self.approach_world

    def off_line_m(self, point_world_m: np.ndarray) -> float:
        """Distance of a (3,) world point from the approach line, metres."""
        offset = np.asarray(point_world_m, float) - self.path_world_m[0]
        return float(np.linalg.norm(offset - (offset @ self.approach_world) * self.approach_world))


def approach_line(target_m: np.ndarray, approach_dir: np.ndarray, config: PlannerConfig,
                  depth_m: float | None = None) -> np.ndarray:
    """(k, 3) pad positions of a touch's approach: ``standoff_m`` before the target to ``depth_m``
    (default ``config.depth_m``) plus ``press_reserve_m`` beyond it, every ``waypoint_spacing_m``
    and at the end itself; in the frame of the inputs.

    The loop's guarded move follows these; a miss sweeps them free.
    """
    end = (config.depth_m if depth_m is None else depth_m) + config.press_reserve_m
    offsets = np.arange(-config.standoff_m, end, config.waypoint_spacing_m)
    offsets = np.append(offsets[offsets < end - 1e-6], end)
    return target_m + offsets[:, None] * approach_dir


class ApproachPlanner:
    """Plans touches for one arm and one stand.

    Parameters
    ----------
    kinematics : robots.kinematics.ArmKinematics
    ik : robots.ik.PadIK
    positioner : Positioner
    prior : ObjectPrior
        Object frame.
    config : PlannerConfig
    rest_q : (dof,) float
        The arm's resting configuration (seed for the first IK, and the transfer pose).
    collision_links : tuple of str
        Links kept ``arm_clearance_m`` away from the prior box (default: the links before the wrist).
    obstacles : sequence of ((3,), (3,)) float
        Fixed boxes in the world frame, (centre, half extent), metres, that free moves keep
        ``free_move_clearance_m`` away from as from the prior box (:attr:`explorer.rig.Rig.obstacles`).
    """

    def __init__(self, kinematics, ik, positioner: Positioner, prior: ObjectPrior,
                 config: PlannerConfig = PlannerConfig(), rest_q=None, collision_links=None, obstacles=()):
        self.kin = kinematics
        self.obstacles = tuple(obstacles)
        self.ik = ik
        self.positioner = positioner
        self.prior = prior
        self.config = config
        names = list(kinematics.link_names)
        if collision_links is None:  # shoulder to wrist: everything before the hand
            collision_links = names[1:names.index(kinematics.spec.tool_link) - 1]
        self.collision_links = tuple(collision_links)
        self._free_paths = None  # built on the first transfer_path (reads the URDF's collision shapes)
        self._hand = None  # built on the first plan with touched points
        self.rest_q = self._retreat_pose() if rest_q is None else np.asarray(rest_q, float)
        self._reach_dirs, self._reachable = self._reachability_map()

    def _retreat_pose(self) -> np.ndarray:
        """A rest pose clear of the stand (the first reachable of ``retreat_offsets_m``), or home."""
        home = np.asarray(self.kin.spec.home_q, float)
        offsets = np.asarray(self.config.retreat_offsets_m, float)
        approach = np.tile([1.0, 0.0, -0.3], (len(offsets), 1))
        result = self.ik.solve(self.positioner.centre_m + offsets, approach, home)
        ok = np.flatnonzero(result.success)
        return result.q_rad[ok[0]] if len(ok) else home

    # ------------------------------------------------------------------ reachability
    def _reachability_map(self) -> tuple[np.ndarray, np.ndarray]:
        """IK success for pads approaching the stand centre from evenly spread directions."""
        dirs = fibonacci_directions(self.config.reach_map_directions)
        radius = float(np.min(self.prior.half_extent_m))
        result = self.ik.solve(self.positioner.centre_m - radius * dirs, dirs, self.rest_q)
        return dirs, result.success.copy()

    def pose_scores(self, approach_object: np.ndarray) -> list[tuple[float, StandPose]]:
        """Stand poses ranked by the reachable map fraction around the world approach direction."""
        scores = []
        cos_cone = np.cos(self.config.reach_cone_rad)
        current = self.positioner.pose()
        for pose in self.positioner.poses:
            _, a_w = self.positioner.to_world(np.zeros((1, 3)), approach_object[None], pose)
            near = self._reach_dirs @ a_w[0] >= cos_cone
            score = float(self._reachable[near].mean()) if near.any() else 0.0
            scores.append((score + (1e-3 if pose == current else 0.0), pose))
        scores.sort(key=lambda s: -s[0])
        return scores

    # ------------------------------------------------------------------ planning
    def plan(self, touch: Touch, seed_q=None, tilted: bool = True, touched_m=None) -> ApproachPlan | None:
        """A plan for ``touch``, or None when no stand pose makes it reachable (head-on, or with
        ``tilted`` along one of the tilted approaches, see :class:`PlannerConfig`).

        ``touched_m`` : (n, 3) float, object frame, metres, optional
            Points the pad has touched (contacts, presses on its side): standoffs that put the
            hand on one are not reachable (``PlannerConfig.hand_clearance_m``).
        """
        cfg = self.config
        touched = None if touched_m is None else np.asarray(touched_m, float).reshape(-1, 3)
        seed = self.rest_q if seed_q is None else np.asarray(seed_q, float)
        seed = np.clip(seed, self.kin.lower_rad, self.kin.upper_rad)  # encoders may read past a limit
        for score, pose in self.pose_scores(touch.approach_dir)[:cfg.poses_to_try]:
            if score <= 0.0:
                break
            plan = self._plan_at(touch, pose, seed, touch.approach_dir, touched_m=touched)
            if plan is not None:
                return plan
        if not tilted:
            return None
        # Head-on failed: the tilted directions whose best stand pose scores highest.
        ranked = []
        for tilt, direction in self.tilted_approaches(touch.approach_dir):
            score, pose = self.pose_scores(direction)[0]
            if score > 0.0:
                ranked.append((-score, tilt, len(ranked), direction, pose))
        ranked.sort(key=lambda r: r[:3])
        for _, tilt, _, direction, pose in ranked[:cfg.tilted_to_try]:
            plan = self._plan_at(touch, pose, seed, direction, tilt, touched_m=touched)
            if plan is not None:
                return plan
        return None

    def tilted_approaches(self, approach: np.ndarray) -> list[tuple[float, np.ndarray]]:
        """(tilt, unit direction) pairs around ``approach`` (object frame), smaller tilts first."""
        a = np.asarray(approach, float) / np.linalg.norm(approach)
        helper = np.array([1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        u = np.cross(a, helper)
        u /= np.linalg.norm(u)
        v = np.cross(a, u)
        out = []
        for tilt in self.config.approach_tilts_rad:
            for phi in 2 * np.pi * np.arange(self.config.tilt_azimuths) / self.config.tilt_azimuths:
                out.append((float(tilt), np.cos(tilt) * a + np.sin(tilt) * (np.cos(phi) * u + np.sin(phi) * v)))
        return out

    def _plan_at(self, touch: Touch, pose: StandPose, seed: np.ndarray, approach_object: np.ndarray,
                 tilt_rad: float = 0.0, touched_m: np.ndarray | None = None) -> ApproachPlan | None:
        cfg = self.config
        target_w, approach_w = self.positioner.to_world(touch.target_m[None], np.asarray(approach_object)[None], pose)
        target_w, approach_w = target_w[0], approach_w[0]
        depth = cfg.depth_m if touch.depth_m is None else touch.depth_m
        probe = depth
        if touch.depth_m is None:
            probe = max(depth, min(cfg.probe_depth_m, self.prior_exit_m(touch.target_m, approach_object)))
        points = approach_line(target_w, approach_w, cfg, probe)
        required = int(np.count_nonzero((points - target_w) @ approach_w <= depth + 1e-9))
        standoff = self.ik.solve(points[:1], approach_w[None], seed)
        if not standoff.success[0]:
            return None
        path = self.ik.solve(points, np.repeat(approach_w[None], len(points), 0), standoff.q_rad[0])
        q = path.q_rad
        jumps = np.r_[False, np.max(np.abs(np.diff(q, axis=0)), axis=1) > cfg.max_joint_step_rad]
        followed = path.success & ~jumps
        usable = len(points) if followed.all() else int(np.argmin(followed))
        if usable < required:
            return None
        q, points = q[:usable], points[:usable]
        if self.arm_intrudes(q[0], pose) or self.hand_on_touched(q[0], pose, touched_m):
            return None
        return ApproachPlan(touch, pose, target_w, approach_w, q, points, tilt_rad)

    def retreat_path(self, q: np.ndarray, distance_m: float = 0.15, step_m: float = 0.01) -> np.ndarray:
        """(k, dof) joint path that takes the pad from ``q`` straight back along its face axis (the
        way an approach came in), as far as IK follows it up to ``distance_m``; k = 0 when no step
        can be followed. For a recovery: a joint-space move to rest from close to the object can
        sweep the hand through it. ``q`` may lie past the joint limits (a contact pushed the
        joints there); the path starts from ``q`` clipped into them."""
        q = np.clip(np.asarray(q, float), self.kin.lower_rad, self.kin.upper_rad)
        pose = self.kin.forward_kinematics(q)
        steps = np.arange(1, int(round(distance_m / step_m)) + 1) * step_m
        points = pose.position_m - steps[:, None] * pose.z_axis
        result = self.ik.solve(points, np.tile(pose.z_axis, (len(points), 1)), q)
        path = np.vstack([q[None], result.q_rad])
        jumps = np.max(np.abs(np.diff(path, axis=0)), axis=1) > self.config.max_joint_step_rad
        followed = result.success & ~jumps
        usable = len(points) if followed.all() else int(np.argmin(followed))
        return result.q_rad[:usable]

    def transfer_path(self, q_from: np.ndarray, q_to: np.ndarray) -> np.ndarray | None:
        """(k, dof) waypoints of a free move from ``q_from`` to ``q_to`` (the last row) at the current
        stand pose: around the prior box when the straight joint path would take the arm (shoulder
        to hand, :class:`robots.link_spheres.ArmSpheres`) within ``free_move_clearance_m`` of it
        (:class:`explorer.free_path.FreePathPlanner`); ``q_to[None]`` when the straight path is
        clear or the check is off. None when no clear path is known: ``q_from`` or ``q_to`` is
        itself within the clearance (e.g. a standoff inside a bowl), or the search found none."""
        q_to = np.asarray(q_to, float)
        if self.config.free_move_clearance_m is None:
            return q_to[None]
        if self._free_paths is None:
            self._free_paths = self._free_path_planner()
        if self._free_paths is False:
            return q_to[None]
        return self._free_paths.plan(q_from, q_to, self.positioner.object_to_world())

    def _free_path_planner(self):
        """The free-move planner over the arm's spheres, shoulder to hand, without the finger next
        to the tool point (:data:`FINGER_EXEMPT_M`); False (one warning) when the URDF has no
        sphere model, e.g. mesh collision shapes: free moves then stay straight."""
        from explorer.free_path import FreePathConfig, FreePathPlanner
        from robots.link_spheres import ArmSpheres

        names = list(self.kin.link_names)
        try:
            spheres = ArmSpheres(self.kin, names[1:names.index(self.kin.spec.tool_link)])
        except ValueError as err:
            warnings.warn(f"{err}; free moves go straight in joint space", stacklevel=3)
            return False
        home = np.asarray(self.kin.spec.home_q_rad, float)
        tool = self.kin.pose_of_one(home, link=self.kin.spec.tool_link)[0]
        spheres = spheres.subset(np.linalg.norm(spheres.centres_m(home[None])[0] - tool, axis=1) > FINGER_EXEMPT_M)
        return FreePathPlanner(spheres, self.prior, self.kin.lower_rad, self.kin.upper_rad,
                               FreePathConfig(clearance_m=self.config.free_move_clearance_m), self.obstacles)

    def rest_clearance_m(self) -> float:
        """Smallest gap (metres) between the arm waiting at ``rest_q`` (its spheres, shoulder to hand)
        and the prior box over every stand pose; negative when the stand would turn the object into
        the waiting arm (an object too large for the rig). Infinite without a sphere model."""
        if self._free_paths is None:
            self._free_paths = self._free_path_planner()
        if self._free_paths is False:
            return float("inf")
        return min(float(np.min(self._free_paths.prior_clearance_m(self.rest_q[None], self.positioner.object_to_world(pose))))
                   for pose in self.positioner.poses)

    def prior_exit_m(self, target_m: np.ndarray, approach_dir: np.ndarray) -> float:
        """Distance (metres) from ``target_m`` along ``approach_dir`` (object frame) to where the line
        leaves the prior box; 0 when it has left it already (or never meets it)."""
        lo, hi = self.prior.bounds(padding=0.0)
        d = np.asarray(approach_dir, float)
        with np.errstate(divide="ignore", invalid="ignore"):
            far = np.where(d > 0, (hi - target_m) / d, (lo - target_m) / d)
        far = np.where(np.abs(d) > 1e-12, far, np.inf)
        return float(max(np.min(far), 0.0))

    def hand_on_touched(self, q: np.ndarray, pose: StandPose, touched_m: np.ndarray | None) -> bool:
        """True when the arm at ``q`` (shoulder to hand, exact primitives) comes within
        ``hand_clearance_m`` of one of ``touched_m`` ((n, 3) object frame, metres) at ``pose``."""
        if self.config.hand_clearance_m is None or touched_m is None or not len(touched_m):
            return False
        if self._hand is None:
            self._hand = self._hand_shapes()
        if self._hand is False:
            return False
        points_w = self.positioner.to_world(touched_m, pose=pose)
        return bool(self._hand.signed_distance_m(q[None], points_w)[0] < self.config.hand_clearance_m)

    def _hand_shapes(self):
        """The arm's exact primitives from the shoulder to the link before the tool (the finger);
        False (one warning) when the URDF has other collision shapes: no check then."""
        from robots.link_shapes import ArmShapes

        names = list(self.kin.link_names)
        try:
            return ArmShapes(self.kin, names[1:names.index(self.kin.spec.tool_link)])
        except ValueError as err:
            warnings.warn(f"{err}; standoffs are not checked against touched points", stacklevel=3)
            return False

    def arm_points(self, q: np.ndarray, per_segment: int = 5) -> np.ndarray:
        """(k, 3) world points along the arm from the shoulder to the wrist (segments sampled)."""
        origins = np.array([self.kin.forward_kinematics(q, link=link).position_m
                            for link in self.collision_links])
        s = np.linspace(0.0, 1.0, per_segment, endpoint=False)
        segments = origins[:-1, None, :] + s[None, :, None] * (origins[1:] - origins[:-1])[:, None, :]
        return np.vstack([segments.reshape(-1, 3), origins[-1:]])

    def arm_intrudes(self, q: np.ndarray, pose: StandPose) -> bool:
        """True when the arm from shoulder to wrist comes within clearance of the prior box."""
        R, t = self.positioner.object_to_world(pose)
        p_obj = (self.arm_points(q) - t) @ R - self.prior.centre_m
        excess = np.maximum(np.abs(p_obj) - self.prior.half_extent_m, 0.0)
        return bool(np.min(np.linalg.norm(excess, axis=1)) < self.config.arm_clearance_m)
