"""Where to touch next: strategies behind one interface, chosen by name.

Every strategy proposes a ranked list of :class:`explorer.touch.Touch` in the object frame; the
loop plans them in order (and may weigh them by motion cost) and takes the first reachable one.

* ``uniform`` - directions evenly spread around the object (Fibonacci sphere, visited in
  farthest-point order), each a ray towards the prior centre;
* ``random`` - uniformly random directions, same rays;
* ``variance`` - the GPIS posterior variance is largest on / near the current 0-level set; the pad
  approaches along the inward normal of the current surface there (the uncertainty-reducing
  exploration of the reference work). Its first touches, before the GPIS has a surface, are
  ``uniform`` ones.
"""
from __future__ import annotations

import abc
from dataclasses import dataclass, field

import numpy as np

from explorer.touch import ObjectPrior, Touch
from reconstruction.gpis import GPIS


@dataclass
class ExplorationState:
    """What a strategy may look at.

    Attributes
    ----------
    prior : ObjectPrior
    gpis : GPIS or None
        The current reconstruction (object frame); None before the first contact.
    touches : int
        Touches tried so far (contacts and misses).
    unreachable_m : list of (3,) float
        Targets the planner could not reach; strategies avoid their neighbourhood.
    tried_m : list of (3,) float
        Targets already touched. ``variance`` avoids them too: where the pad lands away from the
        target (an edge, a tip) the variance at the target stays high, and without this it would
        be chosen again and again.
    """

    prior: ObjectPrior
    gpis: GPIS | None = None
    touches: int = 0
    unreachable_m: list[np.ndarray] = field(default_factory=list)
    tried_m: list[np.ndarray] = field(default_factory=list)


class TouchStrategy(abc.ABC):
    """Proposes touches, best first.

    The loop calls :meth:`propose` each step, :meth:`accepted` for the touch it then tries (and for
    every recorded touch when a run is resumed), and :meth:`surface_variance` to stop early on a
    variance threshold; the last two have defaults for strategies that keep no bookkeeping and
    estimate no variance.
    """

    name: str = ""

    @abc.abstractmethod
    def propose(self, state: ExplorationState, count: int) -> list[Touch]:
        """Up to ``count`` touches, best first."""

    def accepted(self, touch: Touch) -> None:
        """``touch`` (one this strategy proposed) is being tried; the default keeps no record."""

    def surface_variance(self, state: ExplorationState) -> tuple[np.ndarray, np.ndarray] | None:
        """Points near the current surface (k, 3) and their posterior variance (k,), object frame;
        None (the default) when the strategy has no variance estimate."""
        return None


def fibonacci_directions(n: int) -> np.ndarray:
    """(n, 3) unit vectors evenly spread over the sphere."""
    i = np.arange(n) + 0.5
    z = 1 - 2 * i / n
    phi = np.pi * (1 + 5**0.5) * i
    r = np.sqrt(1 - z**2)
    return np.column_stack([r * np.cos(phi), r * np.sin(phi), z])


def farthest_point_order(directions: np.ndarray, first: int = 0) -> np.ndarray:
    """Indices visiting the (n, 3) directions so that each is far from all visited before."""
    order = [first]
    nearest = np.linalg.norm(directions - directions[first], axis=1)
    for _ in range(len(directions) - 1):
        nxt = int(np.argmax(nearest))
        order.append(nxt)
        nearest = np.minimum(nearest, np.linalg.norm(directions - directions[nxt], axis=1))
    return np.array(order)


def ray_touch(prior: ObjectPrior, outward: np.ndarray, score: float, strategy: str) -> Touch:
    """A touch from the prior box surface along -outward, allowed to travel to the prior centre."""
    outward = outward / np.linalg.norm(outward)
    with np.errstate(divide="ignore"):
        scale = np.min(np.where(np.abs(outward) > 1e-12, prior.half_extent_m / np.abs(outward), np.inf))
    return Touch(prior.centre_m + scale * outward, -outward, score, strategy, depth_m=float(scale))


def _not_near(points: np.ndarray, avoid: list[np.ndarray], radius_m: float) -> np.ndarray:
    if not avoid:
        return np.ones(len(points), bool)
    avoid_arr = np.asarray(avoid)
    d = np.linalg.norm(points[:, None, :] - avoid_arr[None, :, :], axis=-1)
    return d.min(1) > radius_m


class UniformStrategy(TouchStrategy):
    """Evenly spread directions around the object, visited far-from-previous first.

    Parameters
    ----------
    directions : int
        Size of the direction set; it is cycled through if the budget is larger.
    """

    name = "uniform"

    def __init__(self, directions: int = 100, avoid_radius_m: float = 0.01):
        dirs = fibonacci_directions(directions)
        self._directions = dirs[farthest_point_order(dirs, first=int(np.argmax(dirs[:, 2])))]
        self._used = np.zeros(len(dirs), bool)
        self.avoid_radius_m = avoid_radius_m

    def propose(self, state: ExplorationState, count: int) -> list[Touch]:
        if self._used.all():  # every direction tried: go round again
            self._used[:] = False
        touches = []
        for k in np.flatnonzero(~self._used):
            touch = ray_touch(state.prior, self._directions[k], -float(k), self.name)
            if _not_near(touch.target_m[None], state.unreachable_m, self.avoid_radius_m)[0]:
                touches.append(touch)
            if len(touches) == count:
                break
        return touches

    def accepted(self, touch: Touch) -> None:
        """Mark the direction of ``touch`` as tried."""
        outward = -touch.approach_dir
        self._used[int(np.argmax(self._directions @ outward))] = True


class RandomStrategy(TouchStrategy):
    """Uniformly random directions (seeded)."""

    name = "random"

    def __init__(self, seed: int = 0):
        self._rng = np.random.default_rng(seed)

    def propose(self, state: ExplorationState, count: int) -> list[Touch]:
        dirs = self._rng.normal(size=(count, 3))
        return [ray_touch(state.prior, u, 0.0, self.name) for u in dirs]


class VarianceStrategy(TouchStrategy):
    """Touch where the GPIS is most uncertain on or near its current surface.

    Parameters
    ----------
    grid : int
        Candidate grid samples along the longest side of the padded prior box.
    initial_touches : int
        Touches taken from ``uniform`` before the GPIS is trusted.
    separation_m : float
        Proposed touches are at least this far apart (so the second choice is not the first's
        neighbour when the first is unreachable).
    avoid_radius_m : float
        Candidates this close to an unreachable target are skipped.
    min_gradient : float
        Below this gradient magnitude (about 1 on an observed surface) the approach aims at the
        prior centre instead of along the gradient.
    shortlist : int
        Highest-variance candidates projected onto the surface and checked per proposal.
    """

    name = "variance"

    def __init__(self, grid: int = 24, initial_touches: int = 6, separation_m: float = 0.015,
                 avoid_radius_m: float = 0.01, min_gradient: float = 0.5, shortlist: int = 400):
        self.grid = grid
        self.shortlist = shortlist
        self.min_gradient = min_gradient
        self.initial_touches = initial_touches
        self.separation_m = separation_m
        self.avoid_radius_m = avoid_radius_m
        self._uniform = UniformStrategy()
        self._tracker = None
        self._candidates: np.ndarray | None = None

    def accepted(self, touch: Touch) -> None:
        if touch.strategy == self._uniform.name:
            self._uniform.accepted(touch)

    def candidate_grid(self, prior: ObjectPrior) -> np.ndarray:
        """Grid over the prior box itself: the surface cannot lie outside it."""
        lo, hi = prior.bounds(padding=0.0)
        step = float(np.max(hi - lo)) / (self.grid - 1)
        axes = [np.arange(lo[i], hi[i] + 0.5 * step, step) for i in range(3)]
        return np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)

    def surface_variance(self, state: ExplorationState) -> tuple[np.ndarray, np.ndarray]:
        """Candidates near the current 0-level set (k, 3) and their posterior variance (k,)."""
        gp = state.gpis
        if self._candidates is None:
            self._candidates = self.candidate_grid(state.prior)
        if self._tracker is None or self._tracker.gpis is not gp:
            self._tracker = gp.variance_tracker(self._candidates)
        variance = self._tracker.variance()
        mean = gp.mean(self._candidates)
        step = float(np.linalg.norm(self._candidates[1] - self._candidates[0]))
        near = np.abs(mean) < step
        if not near.any():
            near = np.abs(mean) <= np.sort(np.abs(mean))[min(50, len(mean) - 1)]
        return self._candidates[near], variance[near]

    def propose(self, state: ExplorationState, count: int) -> list[Touch]:
        gp = state.gpis
        if gp is None or gp.n_contacts < self.initial_touches or state.touches < self.initial_touches:
            return self._uniform.propose(state, count)
        points, variance = self.surface_variance(state)
        order = np.argsort(-variance)[:self.shortlist]
        candidates = points[order]
        grads = gp.gradient(candidates).astype(float)
        values = gp.mean(candidates).astype(float)
        norms = np.linalg.norm(grads, axis=1)
        surface_like = norms >= self.min_gradient
        safe = np.where(surface_like, norms, 1.0)
        # Where a surface is taking shape: one Newton step onto f = 0 and approach along the
        # inward normal. Far from data the mean fades to 0 and its gradient says nothing: aim at
        # the prior centre from the candidate instead.
        targets = np.where(surface_like[:, None], candidates - (values / safe**2)[:, None] * grads,
                           candidates)
        towards = state.prior.centre_m - candidates
        approach = np.where(surface_like[:, None], grads / safe[:, None], towards)
        avoid = state.unreachable_m + state.tried_m
        keep = _not_near(targets, avoid, self.avoid_radius_m)
        touches: list[Touch] = []
        for i in np.flatnonzero(keep):
            if any(np.linalg.norm(targets[i] - t.target_m) < self.separation_m for t in touches):
                continue
            if np.linalg.norm(approach[i]) < 1e-9:
                continue
            touches.append(Touch(targets[i], approach[i], float(variance[order[i]]), self.name))
            if len(touches) == count:
                break
        return touches or self._uniform.propose(state, count)


STRATEGIES = {cls.name: cls for cls in (UniformStrategy, RandomStrategy, VarianceStrategy)}


def make_strategy(name: str, seed: int = 0) -> TouchStrategy:
    """A strategy by name: ``variance``, ``random`` or ``uniform``."""
    if name not in STRATEGIES:
        raise ValueError(f"unknown strategy {name!r}; choose one of {', '.join(STRATEGIES)}")
    if name == "random":
        return RandomStrategy(seed)
    return STRATEGIES[name]()
