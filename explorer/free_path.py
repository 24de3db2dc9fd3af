"""Joint paths for free moves that keep the arm clear of the object's rough box and the table (issue 11).

A free move (a transfer between touches, the move to rest) went straight in joint space. Between
two poses on opposite sides of the object that line can sweep the hand or the forearm through the
object; the arm's protective stop then ends the move and the touch is lost (a third of the touches
of ARMAR-6 on the cereal box). The loop knows only the object's rough box (:class:`ObjectPrior`),
which contains the object, so a path whose arm spheres (:class:`robots.link_spheres.ArmSpheres`)
keep ``clearance_m`` outside that box cannot meet the object.

:class:`FreePathPlanner` keeps the straight line when it is clear; otherwise it searches with
RRT-connect (Kuffner & LaValle, ICRA 2000: two trees, from start and goal, each grown toward
random joint configurations and greedily toward the other) and shortens the result by random
shortcuts. Written here rather than taken from OMPL or pybullet-planning: those need the robot in
their own collision world, while this test is the boxes the loop knows (the prior box and the rig's
fixed obstacles, e.g. the table), the same in simulation and on hardware, and 100 lines of numpy.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class FreePathConfig:
    """How free paths are checked and searched.

    Attributes
    ----------
    clearance_m : float
        Every arm sphere stays at least this far outside the prior box, metres.
    check_step_rad : float
        A path segment is checked at configurations at most this far apart (largest joint), radians.
    extend_rad : float
        Longest step a tree grows in one extension (largest joint), radians.
    max_samples : int
        Random configurations drawn before the search gives up.
    shortcut_rounds : int
        Random shortcut attempts on the path found.
    seed : int
        Seed of the search's random draws (a plan is reproducible).
    """

    clearance_m: float = 0.02
    check_step_rad: float = 0.03
    extend_rad: float = 0.3
    max_samples: int = 400
    shortcut_rounds: int = 30
    seed: int = 0

    def __post_init__(self):
        if not self.clearance_m >= 0:
            raise ValueError(f"FreePathConfig.clearance_m must be >= 0, got {self.clearance_m}")
        for name in ("check_step_rad", "extend_rad"):
            if not getattr(self, name) > 0:
                raise ValueError(f"FreePathConfig.{name} must be positive, got {getattr(self, name)}")
        if self.max_samples < 1 or self.shortcut_rounds < 0:
            raise ValueError("FreePathConfig.max_samples must be >= 1 and shortcut_rounds >= 0")


def box_signed_distance_m(points_m: np.ndarray, centre_m: np.ndarray, half_extent_m: np.ndarray) -> np.ndarray:
    """Signed distance (..., ) of ``points_m`` (..., 3) to an axis-aligned box, metres (negative inside)."""
    d = np.abs(np.asarray(points_m, float) - centre_m) - half_extent_m
    outside = np.linalg.norm(np.maximum(d, 0.0), axis=-1)
    inside = np.minimum(np.max(d, axis=-1), 0.0)
    return outside + inside


class FreePathPlanner:
    """Joint paths whose arm spheres keep clear of the prior box at one stand pose.

    Parameters
    ----------
    spheres : robots.link_spheres.ArmSpheres
        The arm links to keep clear (the fingertip is left out: it goes into the box to touch).
    prior : ObjectPrior
        The object's rough box, object frame.
    lower_rad, upper_rad : (dof,) float
        Joint limits (infinite limits are searched over +-pi).
    config : FreePathConfig
    obstacles : sequence of ((3,), (3,)) float
        Fixed boxes in the world frame, (centre, half extent) in metres, kept clear as the prior
        box is (a table: :attr:`explorer.rig.Rig.obstacles`).
    """

    def __init__(self, spheres, prior, lower_rad, upper_rad, config: FreePathConfig = FreePathConfig(),
                 obstacles=()):
        self.spheres = spheres
        self.prior = prior
        self.lower_rad = np.where(np.isfinite(lower_rad), lower_rad, -math.pi)
        self.upper_rad = np.where(np.isfinite(upper_rad), upper_rad, math.pi)
        self.config = config
        self.obstacles = [(np.asarray(c, float).reshape(3), np.asarray(h, float).reshape(3)) for c, h in obstacles]

    def prior_clearance_m(self, q: np.ndarray, object_to_world) -> np.ndarray:
        """(B, S) gap between each arm sphere and the prior box for configurations ``q`` (B, dof),
        metres (negative: the sphere reaches into it). ``object_to_world`` = (R, t) of the stand."""
        rotation, origin = object_to_world
        centres = (self.spheres.centres_m(q) - origin) @ rotation  # object frame
        return box_signed_distance_m(centres, self.prior.centre_m, self.prior.half_extent_m) - self.spheres.radii_m

    def clearance_m(self, q: np.ndarray, object_to_world) -> np.ndarray:
        """(B,) smallest gap between an arm sphere and the prior box or an obstacle for
        configurations ``q`` (B, dof), metres (negative: a sphere reaches into one).
        ``object_to_world`` = (R, t) of the stand."""
        world = self.spheres.centres_m(q)
        gaps = self.prior_clearance_m(q, object_to_world)
        for centre, half in self.obstacles:
            gaps = np.minimum(gaps, box_signed_distance_m(world, centre, half) - self.spheres.radii_m)
        return gaps.min(axis=1) if gaps.shape[1] else np.full(len(world), np.inf)

    def clear(self, q: np.ndarray, object_to_world) -> np.ndarray:
        """(B,) whether each configuration keeps ``clearance_m``."""
        return self.clearance_m(q, object_to_world) >= self.config.clearance_m

    def segment_clear(self, q0: np.ndarray, q1: np.ndarray, object_to_world) -> bool:
        """Whether the straight joint path from ``q0`` to ``q1`` keeps clear (checked every ``check_step_rad``)."""
        steps = max(1, math.ceil(float(np.max(np.abs(q1 - q0))) / self.config.check_step_rad))
        s = np.linspace(0.0, 1.0, steps + 1)[:, None]
        return bool(np.all(self.clear(q0 + s * (q1 - q0), object_to_world)))

    def plan(self, start_q, goal_q, object_to_world) -> np.ndarray | None:
        """(k, dof) waypoints from ``start_q`` (not included) to ``goal_q`` (the last row), each
        segment clear; ``goal_q[None]`` when the straight line is clear. None when no clear path
        was found, or start or goal themselves are not clear (the caller then moves straight)."""
        cfg = self.config
        start = np.clip(np.asarray(start_q, float), self.lower_rad, self.upper_rad)
        goal = np.asarray(goal_q, float)
        if self.segment_clear(start, goal, object_to_world):
            return goal[None]
        if not np.all(self.clear(np.stack([start, goal]), object_to_world)):
            return None
        rng = np.random.default_rng(cfg.seed)
        trees = [_Tree(start), _Tree(goal)]
        for _ in range(cfg.max_samples):
            sample = rng.uniform(self.lower_rad, self.upper_rad)
            grown = self._extend(trees[0], sample, object_to_world)
            if grown is not None:
                met = self._connect(trees[1], trees[0].nodes[grown], object_to_world)
                if met is not None:
                    first, second = trees[0].branch(grown), trees[1].branch(met)
                    path = first[::-1] + second[1:]
                    if trees[0].nodes[0] is not start:
                        path = path[::-1]
                    return self._shortcut(np.array(path), rng, object_to_world)[1:]
            trees.reverse()
        return None

    def _extend(self, tree: "_Tree", target: np.ndarray, object_to_world) -> int | None:
        """Grow ``tree`` one step toward ``target``; the new node's index, or None when blocked."""
        near = tree.nearest(target)
        base = tree.nodes[near]
        delta = target - base
        reach = float(np.max(np.abs(delta)))
        new = target if reach <= self.config.extend_rad else base + delta * (self.config.extend_rad / reach)
        if not self.segment_clear(base, new, object_to_world):
            return None
        return tree.add(new, near)

    def _connect(self, tree: "_Tree", target: np.ndarray, object_to_world) -> int | None:
        """Grow ``tree`` toward ``target`` until it gets there (its index) or is blocked (None)."""
        while True:
            index = self._extend(tree, target, object_to_world)
            if index is None:
                return None
            if np.array_equal(tree.nodes[index], target):
                return index

    def _shortcut(self, path: np.ndarray, rng, object_to_world) -> np.ndarray:
        """``path`` with random clear shortcuts taken (fewer, straighter segments)."""
        path = list(path)
        for _ in range(self.config.shortcut_rounds):
            if len(path) < 3:
                break
            i, j = sorted(rng.choice(len(path), size=2, replace=False))
            if j - i > 1 and self.segment_clear(path[i], path[j], object_to_world):
                path = path[:i + 1] + path[j:]
        return np.array(path)


class _Tree:
    """Nodes of one RRT tree with their parents."""

    def __init__(self, root: np.ndarray):
        self.nodes = [root]
        self.parents = [-1]

    def nearest(self, q: np.ndarray) -> int:
        return int(np.argmin(np.linalg.norm(np.asarray(self.nodes) - q, axis=1)))

    def add(self, q: np.ndarray, parent: int) -> int:
        self.nodes.append(q)
        self.parents.append(parent)
        return len(self.nodes) - 1

    def branch(self, index: int) -> list[np.ndarray]:
        """Nodes from ``index`` back to the root."""
        out = []
        while index >= 0:
            out.append(self.nodes[index])
            index = self.parents[index]
        return out
