"""Batched inverse kinematics for the pad: reach a point with the pad face along an approach axis.

Task (5 constraints, roll about the approach axis free): put the pad face centre at ``p*`` and
turn the pad's +z face axis along the approach direction ``a*`` (into the surface). Springs are
held at 0 (the commanded pose).

Method: Levenberg-Marquardt in torch (float64), batched over targets x candidates, with joint
limits enforced by clamping plus an active set (joints pressed against a limit are frozen for the
step). Each target gets ``n_roll_candidates`` starts from the seed that are first pulled towards
full poses with evenly spaced roll angles about ``a*`` (the first keeps the seed's own roll),
spreading the solutions over rolls and arm postures, then freed; plus ``n_random_seeds`` uniformly
random starts. A candidate stops when converged or stalled; once one has converged, only the
seed-roll start goes on (``patience_iterations``), since it usually gives the nearest solution.
Per target the successful candidate closest to the seed is returned; when none succeeds the best
one is returned with ``success = False``. Unsolved targets get further rounds of random starts.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np
import torch

from robots.kinematics import DTYPE, ArmKinematics

POLISH_FRACTION = 0.01
"""A candidate stops iterating once within this fraction of both tolerances."""

STALL_ITERATIONS = 8
STALL_RELATIVE_GAIN = 1e-6
"""A candidate whose cost has not dropped by this fraction for STALL_ITERATIONS iterations stops."""


@dataclass(frozen=True)
class IKOptions:
    """Solver settings (lengths in metres, angles in radians).

    Attributes
    ----------
    n_roll_candidates : int
        Starts per target pulled towards evenly spaced roll angles about the approach axis.
    n_random_seeds : int
        Extra uniformly random starts per target.
    roll_guided_iterations : int
        Iterations spent pulling roll candidates towards their roll before freeing the roll.
    max_iterations : int
        Iteration budget per round.
    max_rounds : int
        Rounds; targets still unsolved after a round restart from fresh random configurations.
    patience_iterations : int
        After the roll-guided phase, how long a target keeps iterating for its seed-roll start
        (the preferred, nearest answer) once another candidate has converged.
    position_tolerance_m, angle_tolerance_rad : float
        Success thresholds on the pad position and approach-axis errors.
    orientation_scale_m : float
        Weight of 1 rad of orientation error relative to 1 m of position error.
    initial_damping : float
        Starting Levenberg-Marquardt damping (adapted per candidate).
    seed : int
        Seed for the random starts.
    """

    n_roll_candidates: int = 8
    n_random_seeds: int = 4
    roll_guided_iterations: int = 10
    max_iterations: int = 60
    max_rounds: int = 3
    patience_iterations: int = 15
    position_tolerance_m: float = 1e-3
    angle_tolerance_rad: float = math.radians(1.0)
    orientation_scale_m: float = 0.1
    initial_damping: float = 1e-2
    seed: int = 0

    def __post_init__(self) -> None:
        if self.n_roll_candidates < 0 or self.n_random_seeds < 0 or self.n_roll_candidates + self.n_random_seeds < 1:
            raise ValueError("IKOptions needs at least one candidate (roll candidates + random seeds)")
        if min(self.max_iterations, self.max_rounds) < 1 or min(self.roll_guided_iterations,
                                                                 self.patience_iterations) < 0:
            raise ValueError("max_iterations and max_rounds must be >= 1, roll_guided and patience iterations >= 0")
        if self.roll_guided_iterations >= self.max_iterations:
            raise ValueError("roll_guided_iterations must be below max_iterations")
        if not (self.position_tolerance_m > 0 and self.angle_tolerance_rad > 0 and self.orientation_scale_m > 0
                and self.initial_damping > 0):
            raise ValueError("IK tolerances, orientation scale and damping must be positive")


@dataclass(frozen=True)
class IKResult:
    """Per-target IK outcome.

    Attributes
    ----------
    q_rad : (n, dof) float
        Joint positions (the best candidate even when it failed), radians.
    success : (n,) bool
        Both errors within tolerance.
    position_error_m : (n,) float
        Distance from the pad face centre to the target, metres.
    angle_error_rad : (n,) float
        Angle between the pad's +z axis and the approach direction, radians.
    """

    q_rad: np.ndarray
    success: np.ndarray
    position_error_m: np.ndarray
    angle_error_rad: np.ndarray

    def __len__(self) -> int:
        return len(self.success)


def _rows3(values, name: str) -> np.ndarray:
    """(n, 3) finite float array from (3,) or (n, 3) input."""
    array = np.asarray(values, dtype=float)
    if array.ndim == 1:
        array = array[None]
    if array.ndim != 2 or array.shape[1] != 3 or not np.all(np.isfinite(array)):
        raise ValueError(f"{name} must have shape (n, 3) and be finite, got {np.shape(values)}")
    return array


def approach_frames(approach: torch.Tensor, roll_rad: torch.Tensor) -> torch.Tensor:
    """Rotation matrices (..., 3, 3) whose z column is ``approach`` (..., 3, unit) rolled by ``roll_rad``."""
    z = approach
    helper = torch.zeros_like(z)
    use_x = z[..., 0].abs() < 0.9
    helper[..., 0] = use_x.to(DTYPE)
    helper[..., 1] = (~use_x).to(DTYPE)
    x0 = torch.linalg.cross(helper, z)
    x0 = x0 / torch.linalg.norm(x0, dim=-1, keepdim=True)
    y0 = torch.linalg.cross(z, x0)
    c, s = torch.cos(roll_rad).unsqueeze(-1), torch.sin(roll_rad).unsqueeze(-1)
    x = c * x0 + s * y0
    y = torch.linalg.cross(z, x)
    return torch.stack([x, y, z], dim=-1)


def _rotation_vector(rot: torch.Tensor) -> torch.Tensor:
    """Axis-angle vectors (..., 3) of rotation matrices (..., 3, 3)."""
    skew = torch.stack([rot[..., 2, 1] - rot[..., 1, 2], rot[..., 0, 2] - rot[..., 2, 0],
                        rot[..., 1, 0] - rot[..., 0, 1]], dim=-1)
    cos = ((rot[..., 0, 0] + rot[..., 1, 1] + rot[..., 2, 2] - 1.0) / 2.0).clamp(-1.0, 1.0)
    sin = torch.linalg.norm(skew, dim=-1) / 2.0
    angle = torch.atan2(sin, cos)
    scale = torch.where(sin > 1e-9, angle / (2.0 * sin.clamp(min=1e-12)), torch.full_like(sin, 0.5))
    return skew * scale.unsqueeze(-1)


@dataclass
class _Candidates:
    """Per-candidate solver state (flat over the live candidates of one round).

    ``target``/``slot`` say whose candidate each row is; ``best_*`` hold the best iterate so far
    (q, pad position and z axis, weighted residual and Jacobian), ``stalled`` counts iterations
    without progress.
    """

    target: torch.Tensor
    slot: torch.Tensor
    target_p: torch.Tensor
    target_a: torch.Tensor
    target_r: torch.Tensor
    roll_weight: torch.Tensor
    damping: torch.Tensor
    best_cost: torch.Tensor
    stalled: torch.Tensor
    best_q: torch.Tensor
    best_p: torch.Tensor
    best_z: torch.Tensor
    best_res: torch.Tensor
    best_jac: torch.Tensor

    def update(self, trial, residual, jac, p, z) -> None:
        """Accept ``trial`` where it lowers the cost (then relax the damping, else stiffen it)."""
        cost = (residual**2).sum(-1)
        better = cost < self.best_cost
        progress = cost < self.best_cost * (1.0 - STALL_RELATIVE_GAIN)
        self.stalled = torch.where(progress, torch.zeros_like(self.stalled), self.stalled + 1)
        self.best_cost = torch.where(better, cost, self.best_cost)
        rows = better.unsqueeze(-1)
        self.best_q = torch.where(rows, trial, self.best_q)
        self.best_p = torch.where(rows, p, self.best_p)
        self.best_z = torch.where(rows, z, self.best_z)
        self.best_res = torch.where(rows, residual, self.best_res)
        self.best_jac = torch.where(better.reshape(-1, 1, 1), jac, self.best_jac)
        self.damping = torch.where(better, self.damping / 3.0, self.damping * 4.0).clamp(1e-9, 1e6)

    def subset(self, keep: torch.Tensor) -> "_Candidates":
        """The candidates where ``keep`` is True."""
        return _Candidates(**{f.name: getattr(self, f.name)[keep] for f in fields(self)})


class PadIK:
    """Batched pad IK for one robot; see the module docstring.

    Parameters
    ----------
    kinematics : ArmKinematics
    options : IKOptions
    """

    def __init__(self, kinematics: ArmKinematics, options: IKOptions = IKOptions()):
        self.kin = kinematics
        self.options = options
        self._lower = torch.as_tensor(kinematics.lower_rad, dtype=DTYPE)
        self._upper = torch.as_tensor(kinematics.upper_rad, dtype=DTYPE)
        self._pad = kinematics.link_index(kinematics.spec.pad_link)

    def _residual(self, transforms, target_p, target_a, target_r, roll_weight):
        """Weighted residual (M, 6) and Jacobian (M, 6, dof) at the current configurations."""
        pad = transforms[self._pad]
        p, rot = pad[:, :3, 3], pad[:, :3, :3]
        z = rot[:, :, 2]
        jac = self.kin.jacobian_tensor(transforms, self.kin.spec.pad_link)
        # rotation that turns z onto the approach direction (roll-free part) ...
        cross = torch.linalg.cross(z, target_a)
        sin = torch.linalg.norm(cross, dim=-1, keepdim=True)
        angle = torch.atan2(sin, (z * target_a).sum(-1, keepdim=True))
        tilt = torch.where(sin > 1e-12, cross / sin.clamp(min=1e-12) * angle, cross)
        # ... plus, for roll-guided candidates, the full rotation to the rolled target frame
        full = _rotation_vector(target_r @ rot.transpose(-1, -2))
        w = roll_weight.unsqueeze(-1)
        omega = w * full + (1.0 - w) * tilt
        project = torch.eye(3, dtype=DTYPE) - (1.0 - w).unsqueeze(-1) * z.unsqueeze(-1) * z.unsqueeze(-2)
        jac_w = project @ jac[:, 3:]
        scale = self.options.orientation_scale_m
        residual = torch.cat([target_p - p, scale * omega], dim=-1)
        jac = torch.cat([jac[:, :3], scale * jac_w], dim=1)
        return residual, jac, p, z

    def _step(self, q, residual, jac, damping):
        eye = torch.eye(q.shape[1], dtype=DTYPE)
        free = torch.ones_like(q)
        for _ in range(2):
            jac_free = jac * free.unsqueeze(1)
            lhs = jac_free.transpose(1, 2) @ jac_free + damping.reshape(-1, 1, 1) * eye
            rhs = (jac_free.transpose(1, 2) @ residual.unsqueeze(-1)).squeeze(-1)
            dq = torch.linalg.solve(lhs, rhs) * free
            at_upper = (q >= self._upper - 1e-9) & (dq > 0)
            at_lower = (q <= self._lower + 1e-9) & (dq < 0)
            blocked = at_upper | at_lower
            if not blocked.any():
                break
            free = free * (~blocked).to(DTYPE)
        return torch.minimum(torch.maximum(q + dq, self._lower), self._upper)

    def solve(self, positions_m, approach_dirs, q_seed=None) -> IKResult:
        """Solve for each target row.

        Parameters
        ----------
        positions_m : (n, 3) float
            Pad face centre targets, world frame, metres.
        approach_dirs : (n, 3) float
            Directions the pad's +z face axis should point along (into the surface); normalised here.
        q_seed : (dof,) or (n, dof) float or None
            Start configuration(s) and preferred solution (default: the spec's home), radians.
        """
        targets, approach, seed = self._checked_inputs(positions_m, approach_dirs, q_seed)
        n, dof = len(targets), self.kin.dof
        opts = self.options
        generator = torch.Generator().manual_seed(opts.seed)
        target_p = torch.as_tensor(targets, dtype=DTYPE)
        target_a = torch.as_tensor(approach, dtype=DTYPE)
        seed_t = torch.as_tensor(seed, dtype=DTYPE)
        best_q = seed_t.clone()
        best_score = torch.full((n,), math.inf, dtype=DTYPE)
        pos_err = torch.full((n,), math.inf, dtype=DTYPE)
        ang_err = torch.full((n,), math.inf, dtype=DTYPE)
        success = torch.zeros(n, dtype=torch.bool)
        unsolved = torch.arange(n)
        for round_index in range(opts.max_rounds):
            if len(unsolved) == 0:
                break
            k = len(unsolved)
            n_guided = opts.n_roll_candidates if round_index == 0 else 0
            n_random = opts.n_random_seeds + opts.n_roll_candidates - n_guided
            span = self._upper - self._lower
            random = self._lower + span * torch.rand(k, n_random, dof, generator=generator, dtype=DTYPE)
            starts = torch.cat([seed_t[unsolved].unsqueeze(1).expand(k, n_guided, dof), random], dim=1)
            q, ok, p_err, a_err = self._run(starts, target_p[unsolved], target_a[unsolved], n_guided)
            # per target: closest successful candidate to the seed, else the smallest error
            distance = torch.linalg.norm(q - seed_t[unsolved].unsqueeze(1), dim=-1)
            normalised = p_err / opts.position_tolerance_m + a_err / opts.angle_tolerance_rad
            score = torch.where(ok, distance, 1e6 + normalised)
            pick = score.argmin(dim=1)
            rows = torch.arange(k)
            improved = score[rows, pick] < best_score[unsolved]
            chosen = unsolved[improved]
            best_q[chosen] = q[rows, pick][improved]
            best_score[chosen] = score[rows, pick][improved]
            pos_err[chosen] = p_err[rows, pick][improved]
            ang_err[chosen] = a_err[rows, pick][improved]
            success[chosen] = ok[rows, pick][improved]
            unsolved = unsolved[~success[unsolved]]
        return IKResult(best_q.numpy().copy(), success.numpy().copy(), pos_err.numpy().copy(), ang_err.numpy().copy())

    def _checked_inputs(self, positions_m, approach_dirs, q_seed):
        targets = _rows3(positions_m, "positions_m")
        approach = _rows3(approach_dirs, "approach_dirs")
        if len(approach) != len(targets):
            raise ValueError(f"{len(targets)} positions but {len(approach)} approach directions")
        norms = np.linalg.norm(approach, axis=1)
        if np.any(norms < 1e-9):
            raise ValueError(f"approach_dirs rows {np.flatnonzero(norms < 1e-9).tolist()} are zero vectors")
        n, dof = len(targets), self.kin.dof
        seed = self.kin.spec.home_q if q_seed is None else np.asarray(q_seed, dtype=float)
        if seed.shape == (dof,):
            seed = np.broadcast_to(seed, (n, dof))
        if seed.shape != (n, dof) or not np.all(np.isfinite(seed)):
            raise ValueError(f"q_seed must have shape ({dof},) or ({n}, {dof}), got {np.shape(q_seed)}")
        if np.any(seed < self.kin.lower_rad - 1e-9) or np.any(seed > self.kin.upper_rad + 1e-9):
            raise ValueError("q_seed is outside the joint limits")
        return targets, approach / norms[:, None], np.array(seed)

    def _run(self, starts, target_p, target_a, n_guided):
        """Levenberg-Marquardt from ``starts`` (k, c, dof) towards k targets.

        Returns final q (k, c, dof), success (k, c), position and angle errors (k, c). A candidate
        stops when it has converged or stalled; once one of a target's candidates has converged,
        only the target's first candidate (started at the seed with the seed's roll, the
        preferred answer) goes on, for at most ``patience_iterations``.
        """
        opts = self.options
        k, c, dof = starts.shape
        live = self._initial_candidates(starts, target_p, target_a, n_guided)
        out_q = starts.clone()
        out_p_err = torch.full((k, c), math.inf, dtype=DTYPE)
        out_a_err = torch.full((k, c), math.inf, dtype=DTYPE)
        first_converged = torch.full((k,), -1, dtype=torch.long)
        trial = live.best_q.clone()
        guided_phase = n_guided > 0 and opts.roll_guided_iterations > 0
        with torch.no_grad():
            for iteration in range(opts.max_iterations + 1):
                if guided_phase and iteration == opts.roll_guided_iterations:
                    guided_phase = False
                    live.roll_weight = torch.zeros_like(live.roll_weight)
                    live.best_cost.fill_(math.inf)  # objective changed: re-evaluate from here
                live.update(trial, *self._residual(self.kin.link_transforms(trial), live.target_p, live.target_a,
                                                   live.target_r, live.roll_weight))
                if not guided_phase:
                    p_err, a_err = self._errors(live.best_p, live.best_z, live.target_p, live.target_a)
                    out_q[live.target, live.slot] = live.best_q
                    out_p_err[live.target, live.slot] = p_err
                    out_a_err[live.target, live.slot] = a_err
                    if iteration >= opts.max_iterations:
                        break
                    converged = ((p_err <= POLISH_FRACTION * opts.position_tolerance_m)
                                 & (a_err <= POLISH_FRACTION * opts.angle_tolerance_rad))
                    newly = live.target[converged][first_converged[live.target[converged]] < 0]
                    first_converged[newly] = iteration
                    waited = first_converged[live.target]
                    patience_over = iteration - waited >= opts.patience_iterations
                    others_done = (waited >= 0) & ((live.slot != 0) | patience_over | (n_guided == 0))
                    finished = converged | others_done | (live.stalled >= STALL_ITERATIONS)
                    if finished.all():
                        break
                    if finished.any():
                        live = live.subset(~finished)
                trial = self._step(live.best_q, live.best_res, live.best_jac, live.damping)
        ok = (out_p_err <= opts.position_tolerance_m) & (out_a_err <= opts.angle_tolerance_rad)
        return out_q, ok, out_p_err, out_a_err

    def _initial_candidates(self, starts, target_p, target_a, n_guided) -> "_Candidates":
        k, c, dof = starts.shape
        q = starts.reshape(-1, dof).clone()
        target = torch.arange(k).repeat_interleave(c)
        slot = torch.arange(c).repeat(k)
        t_a = target_a[target]
        # roll candidates are spread around the start's own roll, so that a start which already
        # solves the task stays where it is
        with torch.no_grad():
            start_x = self.kin.link_transforms(q)[self._pad][:, :3, 0]
        reference = approach_frames(t_a, torch.zeros(k * c, dtype=DTYPE))
        start_roll = torch.atan2((start_x * reference[:, :, 1]).sum(-1), (start_x * reference[:, :, 0]).sum(-1))
        offsets = torch.arange(c, dtype=DTYPE) * (2.0 * math.pi / max(n_guided, 1))
        m = k * c
        return _Candidates(
            target=target, slot=slot, target_p=target_p[target], target_a=t_a,
            target_r=approach_frames(t_a, start_roll + offsets[slot]),
            roll_weight=(slot < n_guided).to(DTYPE),
            damping=torch.full((m,), self.options.initial_damping, dtype=DTYPE),
            best_cost=torch.full((m,), math.inf, dtype=DTYPE),
            stalled=torch.zeros(m, dtype=torch.long),
            best_q=q, best_p=torch.zeros(m, 3, dtype=DTYPE), best_z=torch.zeros(m, 3, dtype=DTYPE),
            best_res=torch.zeros(m, 6, dtype=DTYPE), best_jac=torch.zeros(m, 6, dof, dtype=DTYPE),
        )

    def _errors(self, p, z, target_p, target_a):
        pos_err = torch.linalg.norm(p - target_p, dim=-1)
        cos = (z * target_a).sum(-1)
        ang_err = torch.atan2(torch.linalg.norm(torch.linalg.cross(z, target_a), dim=-1), cos)
        return pos_err, ang_err


def solve_pad_ik(kinematics: ArmKinematics, positions_m, approach_dirs, q_seed=None,
                 options: IKOptions = IKOptions()) -> IKResult:
    """One-call form of :meth:`PadIK.solve`."""
    return PadIK(kinematics, options).solve(positions_m, approach_dirs, q_seed)
