"""Where to touch next: strategies behind one interface, chosen by name.

Every strategy proposes a ranked list of :class:`explorer.touch.Touch` in the object frame; the
loop plans them in order (and may weigh them by motion cost) and takes the first reachable one.

* ``uniform`` - directions evenly spread around the object (Fibonacci sphere, visited in
  farthest-point order), each a ray towards the prior centre;
* ``random`` - uniformly random directions, same rays;
* ``variance`` - the GPIS posterior variance is largest on / near the current 0-level set; the pad
  approaches along the inward normal of the current surface there (the uncertainty-reducing
  exploration of the reference work), or, where the GPIS has no normal yet, along the free way in
  nearest to the prior centre's direction (:func:`clear_approach`). Its first touches, before the
  GPIS has a surface, are ``uniform`` ones.
"""
from __future__ import annotations

import abc
from dataclasses import dataclass, field

import numpy as np

from common.directions import fibonacci_directions, perpendicular_frame  # noqa: F401 (re-exported)
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
    passed_m : list of (3,) float
        Points a pad went through beyond its target on the way to a contact (where the GPIS had put
        the surface but there was none). ``variance`` avoids them: the guessed surface stays until
        evidence removes it, and each probe through it lands beside the last one.
    motion : explorer.motion_time.MotionTimeEstimator or None
        Expected seconds of candidate touches from the current arm and stand (``efficient``
        divides by it); None: every touch is taken to cost the same.
    """

    prior: ObjectPrior
    gpis: GPIS | None = None
    touches: int = 0
    unreachable_m: list[np.ndarray] = field(default_factory=list)
    tried_m: list[np.ndarray] = field(default_factory=list)
    passed_m: list[np.ndarray] = field(default_factory=list)
    motion: object | None = None


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


def clear_approach(gp: GPIS, target: np.ndarray, preferred: np.ndarray, path_m: float = 0.045,
                   pad_half_width_m: float = 0.009, directions: int = 64, samples: int = 8) -> np.ndarray:
    """The approach to ``target`` nearest to ``preferred`` whose way in the GPIS calls free.

    Where the GPIS gradient says nothing (a region it has not resolved, such as the inside of a
    cup it has filled in), the loop used to aim at the prior centre; from outside a cup that line
    meets the cup's outer wall, already touched, before it reaches the target. Here the pad's way
    in, from ``path_m`` before the target to a few millimetres before it (the centre line and the
    pad's four edge midpoints, ``pad_half_width_m`` to each side), must have a negative posterior
    mean everywhere (outside the current reconstruction), among ``preferred`` and ``directions``
    Fibonacci directions; the one nearest to ``preferred`` is taken. Where none is free (a cavity
    the GPIS has filled), the way in with the lowest largest mean: the least solid one.

    Parameters
    ----------
    gp : GPIS
    target : (3,) float
        Object frame, metres.
    preferred : (3,) float
        Direction of travel wanted when it is free (need not be unit length).
    path_m : float
        Length of the way in that must be free: the planner's standoff (30 mm) plus the pad's height.

    Returns
    -------
    (3,) float
        Unit direction of travel.
    """
    preferred = np.asarray(preferred, float) / np.linalg.norm(preferred)
    candidates = np.vstack([preferred[None], fibonacci_directions(directions)])
    side_1, side_2 = perpendicular_frame(candidates)
    offsets = np.stack([np.zeros_like(side_1), side_1, -side_1, side_2, -side_2], 1) * pad_half_width_m
    back = np.linspace(0.15 * path_m, path_m, samples)
    points = (target[None, None, None] - back[None, None, :, None] * candidates[:, None, None]
              + offsets[:, :, None])                                       # (d, 5, samples, 3)
    clearance = gp.mean(points.reshape(-1, 3)).astype(float).reshape(len(candidates), -1).max(1)
    free = np.flatnonzero(clearance < 0.0)
    if len(free) == 0:
        return candidates[int(np.argmin(clearance))]
    return candidates[free[np.argmax(candidates[free] @ preferred)]]


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
    passed_radius_m : float
        Candidates this close to a point a pad went through (``ExplorationState.passed_m``) are
        skipped: about the pad's width.
    min_gradient : float
        Below this gradient magnitude (about 1 on an observed surface) the approach aims at the
        prior centre instead of along the gradient.
    shortlist : int
        Highest-variance candidates projected onto the surface and checked at a time; when the
        avoided and passed points rule out too many of them, the next ``shortlist`` are checked
        (until ``count`` touches or no candidate is left), so the strategy never runs dry while
        near-surface candidates remain.
    clear_unresolved : bool
        Where the gradient is below ``min_gradient``, approach along :func:`clear_approach` (the
        free way in nearest to the prior centre's direction) instead of straight at the centre.
    """

    name = "variance"

    def __init__(self, grid: int = 24, initial_touches: int = 6, separation_m: float = 0.015,
                 avoid_radius_m: float = 0.01, min_gradient: float = 0.5, shortlist: int = 400,
                 passed_radius_m: float = 0.018, clear_unresolved: bool = True):
        self.grid = grid
        self.clear_unresolved = clear_unresolved
        self.passed_radius_m = passed_radius_m
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

    def projected_candidates(self, state: ExplorationState, start: int = 0
                             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The ``shortlist`` most uncertain near-surface candidates from rank ``start``, moved onto the surface.

        Returns
        -------
        targets : (k, 3) float
            Candidates after one Newton step onto f = 0 (where a surface is taking shape), object frame.
        approach : (k, 3) float
            Inward unit normal there, or the vector to the prior centre where the gradient says
            nothing (not normalised; zero at the centre itself).
        variance : (k,) float
            Posterior variance at the candidate before the step, largest first.
        surface : (m, 3) float
            All near-surface candidates (the surface the variance is integrated over).
        resolved : (k,) bool
            Where the gradient was large enough to give the approach (False: aimed at the centre).
        """
        gp = state.gpis
        points, variance = self.surface_variance(state)
        order = np.argsort(-variance)[start:start + self.shortlist]
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
        return targets, approach, variance[order], points, surface_like

    def _ranked_touches(self, targets, approach, scores, state: ExplorationState, count: int,
                        resolved: np.ndarray | None = None, chosen: list[Touch] | None = None) -> list[Touch]:
        """Touches in descending ``scores``, away from avoided targets and from each other.

        A touch whose approach the gradient did not give (``resolved`` False) comes in along
        :func:`clear_approach` when ``clear_unresolved`` is set. ``chosen``: touches already
        proposed (kept first, and kept apart from); the list returned extends them to ``count``.
        """
        avoid = state.unreachable_m + state.tried_m
        keep = (_not_near(targets, avoid, self.avoid_radius_m) & _not_near(targets, state.passed_m, self.passed_radius_m)
                & (np.linalg.norm(approach, axis=1) > 1e-9))
        touches: list[Touch] = list(chosen or [])
        if len(touches) >= count:
            return touches
        for i in np.flatnonzero(keep)[np.argsort(-scores[keep], kind="stable")]:
            if any(np.linalg.norm(targets[i] - t.target_m) < self.separation_m for t in touches):
                continue
            direction = approach[i]
            if self.clear_unresolved and resolved is not None and not resolved[i]:
                direction = clear_approach(state.gpis, targets[i], direction)
            touches.append(Touch(targets[i], direction, float(scores[i]), self.name))
            if len(touches) == count:
                break
        return touches

    def propose(self, state: ExplorationState, count: int) -> list[Touch]:
        gp = state.gpis
        if gp is None or gp.n_contacts < self.initial_touches or state.touches < self.initial_touches:
            return self._uniform.propose(state, count)
        def candidates_from(start):
            targets, approach, variance, surface, resolved = self.projected_candidates(state, start)
            return targets, approach, variance, resolved, len(surface)
        return self._touches_by_shortlist(state, count, candidates_from) or self._uniform.propose(state, count)

    def _touches_by_shortlist(self, state: ExplorationState, count: int, candidates_from) -> list[Touch]:
        """Up to ``count`` ranked touches from ``candidates_from(start)`` (targets, approach, scores,
        resolved or None, and the number of near-surface candidates), taking the next shortlist
        while the avoided and passed points leave fewer than ``count``."""
        touches: list[Touch] = []
        start = 0
        while len(touches) < count:
            targets, approach, scores, resolved, candidates = candidates_from(start)
            touches = self._ranked_touches(targets, approach, scores, state, count, resolved, touches)
            start += self.shortlist
            if start >= candidates:
                break
        return touches


def contact_rows_noise(gp: GPIS, targets: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """(k, c) noise variances of the rows a contact at each target would add (c = 4 with normals:
    value, then the gradient; 1 without), as :meth:`GPIS.add` would give them."""
    if not gp.use_normals:
        return np.full((len(targets), 1), gp.noise**2)
    normal_std = np.full(len(targets), gp.normal_noise)
    if gp.opposing_normal_noise is not None and gp.n_contacts:
        points, normals_in = gp.contact_points, gp.contact_normals
        near = np.linalg.norm(targets[:, None] - points[None], axis=-1) <= gp.opposing_radius_m
        opposing = near & (normals @ normals_in.T < -0.5)
        normal_std[opposing.any(1)] = gp.opposing_normal_noise
    return np.column_stack([np.full(len(targets), gp.noise**2), np.repeat(normal_std[:, None] ** 2, 3, 1)])


def expected_variance_reduction(gp: GPIS, targets: np.ndarray, normals: np.ndarray,
                                surface: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Integrated posterior variance removed by a contact at each target, before taking it.

    A contact at ``c`` adds rows ``y_c`` (value, and the gradient with normals). With the current
    factor ``L`` and whitened cross-covariances ``W = L^-1 K(D, .)`` the posterior covariances are
    ``S_cc = K_cc + N_c - W_c^T W_c`` and ``S_sc = K_sc - W_s^T W_c``; the variance at a surface
    point ``s`` falls by ``S_sc S_cc^-1 S_cs``, summed over ``surface``.

    Parameters
    ----------
    gp : GPIS
        Positive definite (a Cholesky factor).
    targets, normals : (k, 3) float
        Hypothetical contacts and their expected outward normals, object frame.
    surface : (m, 3) float
        Points the variance is integrated over.

    Returns
    -------
    reduction : (k,) float
        Sum over ``surface`` of the variance decrease (units of f squared).
    gradient_variance : (k,) float
        Trace of the posterior covariance of the gradient at each target (0 without normals).
    """
    targets = np.asarray(targets, float)
    c = 4 if gp.use_normals else 1
    k, rows = len(targets), gp.n_rows
    w_s = gp.whiten(gp.cross_covariance(surface))                                   # (rows, m)
    w_c = gp.whiten(gp.joint_cross_covariance(targets)[:, :, :c].reshape(rows, k * c)).reshape(rows, k, c)
    prior = gp.prior_joint_covariance(targets, targets)                             # (k, 4, k, 4)
    idx = np.arange(k)
    prior_cc = prior[idx, :c, idx, :c]                                              # (k, c, c)
    post_cc = prior_cc - np.einsum("rka,rkb->kab", w_c, w_c)
    gradient_variance = np.trace(post_cc[:, 1:, 1:], axis1=1, axis2=2) if c == 4 else np.zeros(k)
    s_cc = post_cc + np.einsum("ka,ab->kab", contact_rows_noise(gp, targets, normals), np.eye(c))
    prior_sc = gp.prior_joint_covariance(surface, targets)[:, 0, :, :c]             # (m, k, c)
    s_sc = prior_sc - np.einsum("rm,rkc->mkc", w_s, w_c)
    solved = np.linalg.solve(s_cc, s_sc.transpose(1, 2, 0))                          # (k, c, m)
    reduction = np.einsum("mkc,kcm->k", s_sc, solved)
    return reduction, gradient_variance


def normal_spread_rad(gp: GPIS, targets: np.ndarray, inward: np.ndarray, radius_m: float,
                      directions: int = 6) -> np.ndarray:
    """(k,) largest angle between the GPIS normal at each target and at points ``radius_m`` away
    on the surface (one Newton step), radians: large on edges, rims and tight curvature, where a
    pad of that radius does not lie flat."""
    t1, t2 = perpendicular_frame(inward)
    angles = 2 * np.pi * np.arange(directions) / directions
    ring = targets[:, None] + radius_m * (np.cos(angles)[None, :, None] * t1[:, None]
                                          + np.sin(angles)[None, :, None] * t2[:, None])
    flat = ring.reshape(-1, 3)
    lo, hi = gp.region
    flat = np.clip(flat, lo, hi)
    g = gp.gradient(flat).astype(float)
    f = gp.mean(flat).astype(float)
    g2 = np.maximum(np.sum(g * g, axis=1), 1e-12)
    flat = np.clip(flat - (f / g2)[:, None] * g, lo, hi)
    g = gp.gradient(flat).astype(float)
    g /= np.maximum(np.linalg.norm(g, axis=1, keepdims=True), 1e-12)
    cosines = np.einsum("kdj,kj->kd", g.reshape(len(targets), directions, 3), inward)
    return np.arccos(np.clip(cosines.min(1), -1.0, 1.0))


def planar_approach(points: np.ndarray, normals: np.ndarray, targets: np.ndarray, inward: np.ndarray,
                    radius_m: float, max_angle_rad: float = np.radians(12.0), max_residual_m: float = 0.0015,
                    max_offset_m: float = 0.012, min_contacts: int = 3) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Approach along the plane of the nearby contacts where they say the surface is flat there.

    Where the GPIS is still a smooth blob its normal can be 30-80 deg off a flat face (a plate,
    a box side), and a pad that meets a face that obliquely lands on its rim, millimetres off.
    For each target the measured contacts within ``radius_m`` whose normals face the same side
    (within 60 deg of the GPIS normal) are taken; if there are ``min_contacts`` of them, their
    normals lie within ``max_angle_rad`` of their mean, their positions within ``max_residual_m``
    of the plane through their centroid with that normal, and the target within ``max_offset_m``
    of it, the target moves onto that plane and the approach follows its inward normal.

    Parameters
    ----------
    points, normals : (n, 3) float
        Contacts and their outward normals, object frame.
    targets, inward : (k, 3) float
        Candidate targets and their (unit) GPIS approach directions.

    Returns
    -------
    targets, approach : (k, 3) float
        Unchanged where no plane applies.
    planar : (k,) bool
        Where one did.
    """
    targets, approach = targets.copy(), inward.copy()
    planar = np.zeros(len(targets), bool)
    if len(points) < min_contacts:
        return targets, approach, planar
    distance = np.linalg.norm(targets[:, None] - points[None], axis=-1)
    facing = (-inward) @ normals.T > 0.5
    for i in np.flatnonzero(((distance < radius_m) & facing).sum(1) >= min_contacts):
        near = (distance[i] < radius_m) & facing[i]
        mean = normals[near].sum(0)
        mean /= np.linalg.norm(mean)
        if np.min(normals[near] @ mean) < np.cos(max_angle_rad):
            continue
        centroid = points[near].mean(0)
        if np.max(np.abs((points[near] - centroid) @ mean)) > max_residual_m:
            continue
        offset = float((targets[i] - centroid) @ mean)
        if abs(offset) > max_offset_m:
            continue
        targets[i] = targets[i] - offset * mean
        approach[i] = -mean
        planar[i] = True
    return targets, approach, planar


def thin_axis_approach(prior: ObjectPrior, approach: np.ndarray, where: np.ndarray, thin_ratio: float,
                       cone_rad: float) -> np.ndarray:
    """Approach a thin object's broad faces along its thin axis.

    When the prior box's smallest half extent is below ``thin_ratio`` times its largest (a plate,
    a tray, a lid), its broad faces face that axis; approaches (k, 3) within ``cone_rad`` of it
    (either sign) turn onto it, at the rows selected by the (k,) bool ``where``. Before the top
    and bottom are covered, the GPIS of a plate is a rounded blob whose normals are 40-80 deg off
    the faces, and the pad meets the face at a grazing angle, on its rim.
    """
    half = prior.half_extent_m
    if half.min() >= thin_ratio * half.max():
        return approach
    axis = np.eye(3)[int(np.argmin(half))]
    along = approach @ axis
    turn = where & (np.abs(along) >= np.cos(cone_rad))
    out = approach.copy()
    out[turn] = np.sign(along[turn])[:, None] * axis
    return out


class EfficientStrategy(VarianceStrategy):
    """The touch that removes the most surface uncertainty per expected second.

    For the ``shortlist`` most uncertain near-surface candidates (as ``variance``, moved onto the
    current surface) the score is

        expected integrated variance reduction x edge factor x reach factor / expected time.

    * reduction: :func:`expected_variance_reduction` over the near-surface candidate grid (at most
      ``surface_samples`` of it): what the contact would do to the whole surface, not just the
      variance at its own point (a touch between two unknown regions beats one at an isolated peak);
    * edge factor ``1 - edge_weight p_edge``: ``p_edge`` grows from 0 to 1 as the GPIS normals within
      ``pad_radius_m`` of the target turn by ``edge_angles_rad`` (rims, edges, tight curvature: the
      pad does not lie flat there and its contact is off by millimetres);
    * reach factor ``1 - exp(-d^2 / 2 reach_radius_m^2)``, ``d`` the distance to the nearest target the
      planner could not reach (or that was blocked);
    * approach: along the GPIS normal, or, where the nearby contacts say the surface is flat, along
      their plane's normal (:func:`planar_approach`, within ``plane_radius_m``; 0 switches it off),
      and on a thin object (prior box thinner than ``thin_ratio``) along its thin axis where the
      GPIS normal is within ``thin_cone_rad`` of it (:func:`thin_axis_approach`; 0 switches it off);
    * time: the state's motion estimate (stand change, arm travel, press; :mod:`explorer.motion_time`)
      plus a realign's cost times its probability: the chance that the true normal is more than
      ``realign_angle_rad`` off the approach, from the posterior gradient covariance at the target.

    The first touches go straight at the six faces of the prior box (:meth:`face_touches`), then
    ``uniform`` ones until ``initial_touches`` contacts.

    Parameters as :class:`VarianceStrategy`, and the weights above; ``press_s`` and
    ``realign_angle_rad`` as in :class:`explorer.motion_time.TouchTimeModel` and the loop.
    """

    name = "efficient"

    def __init__(self, grid: int = 24, initial_touches: int = 6, separation_m: float = 0.015,
                 avoid_radius_m: float = 0.01, min_gradient: float = 0.5, shortlist: int = 120,
                 surface_samples: int = 800, pad_radius_m: float = 0.009,
                 edge_angles_rad: tuple[float, float] = (np.radians(15.0), np.radians(45.0)),
                 edge_weight: float = 0.5, reach_radius_m: float = 0.02, press_s: float = 3.5,
                 realign_angle_rad: float = np.radians(15.0), plane_radius_m: float = 0.05,
                 thin_ratio: float = 0.25, thin_cone_rad: float = np.radians(75.0)):
        super().__init__(grid, initial_touches, separation_m, avoid_radius_m, min_gradient, shortlist)
        self.surface_samples = surface_samples
        self.pad_radius_m = pad_radius_m
        self.edge_angles_rad = edge_angles_rad
        self.edge_weight = edge_weight
        self.reach_radius_m = reach_radius_m
        self.press_s = press_s
        self.realign_angle_rad = realign_angle_rad
        self.plane_radius_m = plane_radius_m
        self.thin_ratio = thin_ratio
        self.thin_cone_rad = thin_cone_rad
        self.last_scores: dict[str, np.ndarray] = {}
        self._faces_touched = np.zeros(len(self.FACE_AXES), bool)

    #: Outward normals of the prior box's faces, in the order the first touches take them.
    FACE_AXES = np.array([[0, 0, 1], [0, 0, -1], [1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0]], float)

    def face_touches(self, state: ExplorationState, count: int) -> list[Touch]:
        """Touches at the centres of the prior box's faces, along their inward normals, not yet taken.

        The first touches: straight at each face of the box the object fills, so a flat or boxy
        object is met head on (rays from evenly spread directions meet a plate at grazing angles,
        where the pad lands on its rim and the contact is off by millimetres).
        """
        touches = []
        for k in np.flatnonzero(~self._faces_touched):
            touch = ray_touch(state.prior, self.FACE_AXES[k], -float(k), self.name)
            if _not_near(touch.target_m[None], state.unreachable_m, self.avoid_radius_m)[0]:
                touches.append(touch)
        return touches[:count]

    def accepted(self, touch: Touch) -> None:
        super().accepted(touch)
        if touch.strategy == self.name:
            face = self.FACE_AXES @ -touch.approach_dir > 1 - 1e-9
            self._faces_touched |= face

    def propose(self, state: ExplorationState, count: int) -> list[Touch]:
        gp = state.gpis
        if (gp is None or gp.n_contacts < self.initial_touches or state.touches < self.initial_touches
                or not gp.positive_definite):
            return self.face_touches(state, count) or super().propose(state, count)
        def candidates_from(start):
            targets, approach, scores, candidates = self.scored_candidates(state, start)
            return targets, approach, scores, None, candidates
        return self._touches_by_shortlist(state, count, candidates_from) or self._uniform.propose(state, count)

    def scored_candidates(self, state: ExplorationState, start: int = 0
                          ) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
        """Targets (k, 3), unit approach directions (k, 3) and scores (k,) of the ``shortlist``
        most uncertain near-surface candidates from rank ``start``; and how many near-surface
        candidates there are. Sets :attr:`last_scores` to this shortlist's terms."""
        gp = state.gpis
        targets, approach, _, surface, _ = self.projected_candidates(state, start)
        candidates = len(surface)
        length = np.linalg.norm(approach, axis=1)
        targets, approach = targets[length > 1e-9], approach[length > 1e-9] / length[length > 1e-9, None]
        if len(surface) > self.surface_samples:
            surface = surface[np.linspace(0, len(surface) - 1, self.surface_samples).astype(int)]
        lo, hi = gp.region
        spread = normal_spread_rad(gp, np.clip(targets, lo, hi), approach, self.pad_radius_m)
        planar = np.zeros(len(targets), bool)
        if self.plane_radius_m > 0 and gp.use_normals:
            targets, approach, planar = planar_approach(gp.contact_points, gp.contact_normals, targets,
                                                        approach, self.plane_radius_m)
        approach = thin_axis_approach(state.prior, approach, ~planar, self.thin_ratio, self.thin_cone_rad)
        targets = np.clip(targets, lo, hi)
        reduction, gradient_variance = expected_variance_reduction(gp, targets, -approach, surface)
        reduction = np.maximum(reduction, 0.0)
        a0, a1 = self.edge_angles_rad
        p_edge = np.clip((spread - a0) / (a1 - a0), 0.0, 1.0)
        edge_factor = 1.0 - self.edge_weight * p_edge
        reach_factor = np.ones(len(targets))
        if state.unreachable_m:
            d = np.linalg.norm(targets[:, None] - np.asarray(state.unreachable_m)[None], axis=-1).min(1)
            reach_factor = 1.0 - np.exp(-0.5 * (d / self.reach_radius_m) ** 2)
        gradient_norm = np.maximum(np.linalg.norm(gp.gradient(targets).astype(float), axis=1), 1e-6)
        sigma = np.sqrt(0.5 * np.maximum(gradient_variance, 0.0)) / gradient_norm
        p_realign = np.exp(-0.5 * (self.realign_angle_rad / np.maximum(sigma, 1e-9)) ** 2)
        last = state.tried_m[-1] if state.tried_m else None
        if state.motion is not None:
            seconds = state.motion.time_s(targets, approach, last)
        else:
            seconds = np.full(len(targets), self.press_s)
        seconds = seconds + p_realign * self.press_s
        scores = reduction * edge_factor * reach_factor / seconds
        self.last_scores = dict(targets=targets, planar=planar, reduction=reduction, p_edge=p_edge, reach=reach_factor,
                                p_realign=p_realign, seconds=seconds, score=scores)
        return targets, approach, scores, candidates


STRATEGIES = {cls.name: cls for cls in (UniformStrategy, RandomStrategy, VarianceStrategy,
                                          EfficientStrategy)}


def make_strategy(name: str, seed: int = 0) -> TouchStrategy:
    """A strategy by name: ``efficient``, ``variance``, ``random`` or ``uniform``."""
    if name not in STRATEGIES:
        raise ValueError(f"unknown strategy {name!r}; choose one of {', '.join(STRATEGIES)}")
    if name == "random":
        return RandomStrategy(seed)
    return STRATEGIES[name]()
