"""Joint-offset (and link-length) calibration by touching a known sphere, and a robot that applies it.

A lab calibrates its arm's encoder offsets the way the fingertip measures anything: it touches a
sphere of known centre and radius (a calibration ball on the table, measured once) at poses spread
over the arm's workspace. Each touch gives the encoder readings ``q_i`` and the sensor body's
orientation ``R_i`` from the IMU; the pad face centre the loop computes is
``p_i(o) = FK_pivot(q_i - o) + R_i a`` (``a``: pivot to pad, body frame) and must lie on the sphere.
The offsets ``o`` (encoder reading minus true angle) solve the nonlinear least squares

    min_o  sum_i (|p_i(o) - c| - r)^2   (+ a small ridge on o for unobservable directions)

(scipy's trust-region reflective solver). One residual per touch: use at least three touches per
offset and poses that turn every joint, or some combinations stay unobservable (the ridge then
keeps them at zero; ``FitResult.singular_values`` shows it).

With each touch's force ``f_i`` (the pad's pressure, :attr:`SphereTouches.force_n`) the pad's
compression on the ball is fitted too: the pad face sinks ``k f_i`` into the ball along the measured
normal ``n_i`` (outward, minus the pad's face axis), so the touched surface point is
``p_i(o) + k f_i n_i``. The presses of a physical calibration end at 0.1-3 N; unmodelled, the
1.5-3 mm per newton a soft pad sinks into a 5 cm ball reads as millimetres of arm error, and the
offsets bend to explain it (BENCHMARKS.md, issue 12).

With ``link_lengths`` the arm's link lengths are fitted too: the pad point becomes
``p_i(o, d) = FK_pivot(q_i - o) + R_i a + sum_j R_parent_j(q_i - o) u_j d_j``
(:mod:`robots.link_lengths`, exact), ``d`` with its own ridge. ``FitResult.parameter_std`` says how
well the touches determine each parameter (residual scatter through the Jacobian).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from robots.interface import GuardedMoveResult, Robot


@dataclass(frozen=True)
class SphereTouches:
    """Touches of a known sphere (world frame, metres).

    Attributes
    ----------
    q_rad : (n, dof) float
        Encoder readings at each settled touch, radians.
    body_quat_wxyz : (n, 4) float
        Sensor body orientation at each touch (IMU, aligned), world frame.
    centre_m : (3,) or (n, 3) float
        The sphere's centre, or each touch's sphere centre (several balls, or one ball moved
        between known places: more diverse poses).
    radius_m : float
    force_n : (n,) float, optional
        Each touch's settled contact force from the pad's pressure, newtons (a drifting baseline
        may read a light press slightly below zero). Given, the fit also estimates the pad's
        compression per newton (module docstring).
    """

    q_rad: np.ndarray
    body_quat_wxyz: np.ndarray
    centre_m: np.ndarray
    radius_m: float
    force_n: np.ndarray | None = None

    def __post_init__(self) -> None:
        q = np.asarray(self.q_rad, float)
        quats = np.asarray(self.body_quat_wxyz, float)
        if q.ndim != 2 or quats.shape != (len(q), 4):
            raise ValueError(f"q_rad must be (n, dof) and body_quat_wxyz (n, 4), got {q.shape}, {quats.shape}")
        if np.asarray(self.centre_m).shape not in ((3,), (len(q), 3)) or not self.radius_m > 0.0:
            raise ValueError("centre_m must be 3 numbers (or one row per touch) and radius_m > 0")
        if self.force_n is not None:
            force = np.asarray(self.force_n, float)
            if force.shape != (len(q),) or not np.all(np.isfinite(force)):
                raise ValueError(f"force_n must be {len(q)} finite forces in newtons (one per touch), "
                                 f"got shape {force.shape}")
            object.__setattr__(self, "force_n", force)
        object.__setattr__(self, "q_rad", q)
        object.__setattr__(self, "body_quat_wxyz", quats)
        object.__setattr__(self, "centre_m", np.asarray(self.centre_m, float))

    def subset(self, which) -> "SphereTouches":
        """The touches selected by ``which`` (a boolean mask or indices over the n touches)."""
        centres = self.centre_m if self.centre_m.ndim == 1 else self.centre_m[which]
        force = None if self.force_n is None else self.force_n[which]
        return SphereTouches(self.q_rad[which], self.body_quat_wxyz[which], centres, self.radius_m, force)

    def compression_directions(self) -> np.ndarray:
        """(n, 3) each touch's force times its measured outward normal (minus the pad's face axis,
        world frame), newtons: times the compliance (m/N), where the touched surface is from the pad face."""
        from common.rotations import quat_to_matrix

        force = np.zeros(len(self.q_rad)) if self.force_n is None else self.force_n
        return -force[:, None] * quat_to_matrix(self.body_quat_wxyz)[:, :, 2]


@dataclass(frozen=True)
class FitResult:
    """Outcome of :func:`fit_joint_offsets`.

    Attributes
    ----------
    offset_rad : (dof,) float
        Estimated encoder offsets (reading minus true angle), radians.
    residual_before_m, residual_after_m : (n,) float
        Signed distance of each computed pad point from the sphere, without and with the offsets.
    singular_values : (dof [+ k],) float
        Of the residuals' Jacobian at the solution (metres per radian, metres per metre for link
        lengths): a near-zero one marks a combination these touches cannot see.
    link_length_error_m : dict of str -> float
        Fitted link-length errors (true minus nominal, metres) by joint name; empty when not fitted.
    parameter_std : (dof [+ k] [+ 1],) float
        Standard error of each fitted parameter (radians, then metres, then metres per newton):
        the after-fit residual RMS through ``(J^T J + ridge)^-1``. A value as large as the
        parameters' spread means the touches do not determine it.
    pad_compliance_m_per_n : float or None
        The pad's fitted compression on the ball per newton, metres (None: not fitted).
    resolution : (dof [+ k] [+ 1],) float
        How much of each fitted parameter the touches determine, 0-1: the diagonal of the model
        resolution ``(J^T J + ridge)^-1 J^T J``. Near 1 the touches alone set it; near 0 the ridge
        holds it at zero whatever its true value, and ``parameter_std`` (which counts the ridge as
        information) understates its error. Ball touches see the pad only along the ball's radius,
        so the wrist joints, which turn the pad about points near it, come out near 0.
    """

    offset_rad: np.ndarray
    residual_before_m: np.ndarray
    residual_after_m: np.ndarray
    singular_values: np.ndarray
    link_length_error_m: dict = field(default_factory=dict)
    parameter_std: np.ndarray = field(default_factory=lambda: np.zeros(0))
    pad_compliance_m_per_n: float | None = None
    resolution: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def unresolved(self, below: float = 0.5) -> np.ndarray:
        """Indices of the joint offsets whose :attr:`resolution` is under ``below``."""
        return np.flatnonzero(self.resolution[:len(self.offset_rad)] < below)


def sphere_residuals_m(kinematics, touches: SphereTouches, offset_rad, link_length_error_m=None,
                       pad_compliance_m_per_n: float = 0.0) -> np.ndarray:
    """Signed distance (n,) of each touch's computed surface point from the sphere, metres.

    ``link_length_error_m`` (joint name -> metres, optional): the model's links are that much longer.
    ``pad_compliance_m_per_n``: the pad face sank that far per newton (needs ``touches.force_n``).
    """
    q = touches.q_rad - np.asarray(offset_rad, float)
    points = kinematics.pad_position_from_orientation(q, touches.body_quat_wxyz)
    if link_length_error_m:
        from robots.link_lengths import link_length_shift_m

        points = points + link_length_shift_m(kinematics, q, link_length_error_m)
    if pad_compliance_m_per_n:
        points = points + pad_compliance_m_per_n * touches.compression_directions()
    return np.linalg.norm(points - touches.centre_m, axis=1) - touches.radius_m


class _FastResiduals:
    """:func:`sphere_residuals_m` with one batched forward-kinematics call per evaluation (the fit
    evaluates it hundreds of times)."""

    def __init__(self, kinematics, touches: SphereTouches, links) -> None:
        from common.rotations import quat_to_matrix

        self.kinematics, self.touches, self.links = kinematics, touches, links
        self.pad_offset_m = quat_to_matrix(touches.body_quat_wxyz) @ kinematics.pivot_to_pad_in_body
        self.pivot = kinematics.link_index(kinematics.spec.pivot_link)
        self.parents = [kinematics.link_index(link.parent_link) for link in links]
        self.directions = np.array([link.direction for link in links]).reshape(-1, 3)
        self.compression = touches.compression_directions()

    def __call__(self, offset_rad, lengths_m, compliance_m_per_n: float = 0.0) -> np.ndarray:
        import torch

        q = torch.as_tensor(self.touches.q_rad - offset_rad, dtype=torch.float64)
        with torch.no_grad():
            transforms = self.kinematics.link_transforms(q).numpy()
        points = transforms[self.pivot, :, :3, 3] + self.pad_offset_m
        for parent, direction, length in zip(self.parents, self.directions, lengths_m):
            points = points + length * (transforms[parent, :, :3, :3] @ direction)
        points = points + compliance_m_per_n * self.compression
        return np.linalg.norm(points - self.touches.centre_m, axis=1) - self.touches.radius_m


#: Robust fit defaults (:func:`fit_joint_offsets` ``robust_scale_m``), chosen on the hardware-like
#: ball touches of ARMAR-6 and ARMAR-III at seed 0 and checked on seeds 1-3 (BENCHMARKS.md, issue
#: 12): the ridge with plain touches; the scale (0.5 -> 1 mm) once the fit models the pad's compression.
ROBUST_SCALE_M = 1e-3
ROBUST_RIDGE_M_PER_RAD = 0.2


def fit_joint_offsets(kinematics, touches: SphereTouches, ridge_m_per_rad: float = 0.02,
                      link_lengths: bool = False, ridge_m_per_m: float = 0.05,
                      robust_scale_m: float | None = None, pad_compliance: bool | None = None) -> FitResult:
    """Joint offsets (and link lengths) from sphere touches, least squares or robust (module docstring).

    Parameters
    ----------
    kinematics : robots.kinematics.ArmKinematics
        The nominal model the loop uses.
    touches : SphereTouches
    ridge_m_per_rad : float
        Weight of the ridge term pulling each offset towards zero (metres of residual per radian).
    link_lengths : bool
        Also fit the arm's link lengths (:func:`robots.link_lengths.arm_link_lengths`).
    ridge_m_per_m : float
        Weight of the ridge term on the link-length errors (metres of residual per metre).
    robust_scale_m : float, optional
        Fit with a Cauchy loss of this scale, metres, on every row, the ridge rows included,
        started at zero offsets. A pad that did not lie flat on the ball (friction stopped it
        turning, or it met the ball with its rim) is several millimetres off the sphere; least
        squares bends every offset towards such touches, the Cauchy loss lets them go. On the ridge
        rows the same loss is a heavy-tailed prior on each parameter (scale ``robust_scale_m /
        ridge``): a small pull towards zero that large offsets the touches demand can overcome.
        The touches see the pad only along the ball's radius, so directions that slide the pad
        over the ball stay unseen; that prior keeps them at zero. None: plain least squares.
    pad_compliance : bool, optional
        Also fit the pad's compression per newton (module docstring; no ridge). Default: when the
        touches carry their forces.
    """
    from scipy.optimize import least_squares

    if robust_scale_m is not None and not robust_scale_m > 0.0:
        raise ValueError(f"robust_scale_m must be positive metres, got {robust_scale_m}")
    if pad_compliance is None:
        pad_compliance = touches.force_n is not None
    elif pad_compliance and touches.force_n is None:
        raise ValueError("pad_compliance needs each touch's force (SphereTouches.force_n)")
    dof = touches.q_rad.shape[1]
    links = _arm_links(kinematics) if link_lengths else ()
    names = [link.joint for link in links]
    unknowns = dof + len(names) + int(pad_compliance)
    if len(touches.q_rad) < unknowns:
        links = f" and {len(names)} link lengths" if names else ""
        raise ValueError(f"{len(touches.q_rad)} touches cannot determine {dof} joint offsets{links}; touch at "
                         f"least {unknowns} (better 3 x {unknowns}) poses")
    lengths_end = dof + len(names)

    def split(x):
        return x[:dof], dict(zip(names, x[dof:lengths_end])), (float(x[-1]) if pad_compliance else 0.0)

    fast = _FastResiduals(kinematics, touches, links)

    def touch_residuals(x):
        return fast(x[:dof], x[dof:lengths_end], x[-1] if pad_compliance else 0.0)

    def residuals(x):
        return np.concatenate([touch_residuals(x), ridge_m_per_rad * x[:dof], ridge_m_per_m * x[dof:lengths_end]])

    scale = np.concatenate([np.full(dof, 0.01), np.full(len(names), 0.001), np.full(int(pad_compliance), 0.001)])
    loss = dict(loss="cauchy", f_scale=robust_scale_m) if robust_scale_m else {}
    solution = least_squares(residuals, np.zeros(unknowns), method="trf", x_scale=scale, diff_step=1e-6, **loss)
    n = len(touches.q_rad)
    jac = _touch_jacobian(touch_residuals, solution.x) if robust_scale_m else solution.jac[:n]  # unweighted rows
    singular = np.linalg.svd(jac, compute_uv=False)
    offset, lengths, compliance = split(solution.x)
    after = sphere_residuals_m(kinematics, touches, offset, lengths, compliance)
    ridge = np.concatenate([np.full(dof, ridge_m_per_rad**2), np.full(len(names), ridge_m_per_m**2),
                            np.zeros(int(pad_compliance))])
    if robust_scale_m:  # the scatter of the touches the loss kept, not of the ones it let go
        sigma = float(1.4826 * np.median(np.abs(after - np.median(after))))
    else:
        sigma = float(np.sqrt(np.sum(after**2) / max(n - unknowns, 1)))
    information = jac.T @ jac
    covariance = np.linalg.inv(information + np.diag(ridge))
    std = sigma * np.sqrt(np.diag(covariance))
    return FitResult(offset_rad=offset, residual_before_m=sphere_residuals_m(kinematics, touches, np.zeros(dof)),
                     residual_after_m=after, singular_values=singular,
                     link_length_error_m={k: float(v) for k, v in lengths.items()}, parameter_std=std,
                     pad_compliance_m_per_n=compliance if pad_compliance else None,
                     resolution=np.clip(np.diag(covariance @ information), 0.0, 1.0))


def _touch_jacobian(touch_residuals: Callable[[np.ndarray], np.ndarray], x: np.ndarray,
                    step: float = 1e-6) -> np.ndarray:
    """(n, unknowns) central-difference Jacobian of the touch residuals at ``x``."""
    columns = []
    for j in range(len(x)):
        up, down = x.copy(), x.copy()
        up[j] += step
        down[j] -= step
        columns.append((touch_residuals(up) - touch_residuals(down)) / (2.0 * step))
    return np.stack(columns, axis=1)


#: Ridge weights (metres of residual per radian) :func:`cross_validated_ridge` chooses from.
RIDGE_LADDER_M_PER_RAD = (0.02, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0)


@dataclass(frozen=True)
class RidgeChoice:
    """Outcome of :func:`cross_validated_ridge`.

    Attributes
    ----------
    ridge_m_per_rad : float
        The chosen weight.
    scores_m : dict float -> (float, float)
        Per candidate, the RMS left-out sphere residual over the folds and its standard error, metres.
    """

    ridge_m_per_rad: float
    scores_m: dict


def cross_validated_ridge(kinematics, touches: SphereTouches, ridges=RIDGE_LADDER_M_PER_RAD,
                          folds: int = 4, link_lengths: bool = False) -> RidgeChoice:
    """The ridge weight that predicts left-out touches best, from the touches alone (as a lab has them).

    ``folds``-fold cross-validation in touch order: each candidate is fitted without one fold and
    scored by that fold's sphere residuals. Noisy touches (a pad that did not lie flat, an IMU
    heading error) let weakly seen offsets soak up noise with a small ridge; the one-standard-error
    rule then takes the largest ridge within one standard error of the best score, so an offset the
    touches cannot determine stays near zero.
    """
    n = len(touches.q_rad)
    if n < 2 * folds:
        raise ValueError(f"{n} touches are too few for {folds}-fold cross-validation")
    fold_of = np.arange(n) % folds
    scores = {}
    for ridge in ridges:
        fold_ms = []
        for k in range(folds):
            fit = fit_joint_offsets(kinematics, touches.subset(fold_of != k), ridge_m_per_rad=ridge,
                                    link_lengths=link_lengths)
            residual = sphere_residuals_m(kinematics, touches.subset(fold_of == k), fit.offset_rad,
                                          fit.link_length_error_m or None, fit.pad_compliance_m_per_n or 0.0)
            fold_ms.append(float(np.mean(residual**2)))
        fold_ms = np.array(fold_ms)
        rms = float(np.sqrt(fold_ms.mean()))
        standard_error_ms = float(fold_ms.std(ddof=1) / np.sqrt(folds))
        scores[float(ridge)] = (rms, standard_error_ms / (2.0 * max(rms, 1e-12)))  # delta method: MSE -> RMS
    best = min(scores, key=lambda r: scores[r][0])
    limit = scores[best][0] + scores[best][1]
    chosen = max(r for r, (score, _) in scores.items() if score <= limit)
    return RidgeChoice(chosen, scores)


def _arm_links(kinematics):
    from robots.link_lengths import arm_link_lengths

    return arm_link_lengths(kinematics.spec)


class CalibratedRobot(Robot):
    """A robot whose encoder offsets are known: readings are corrected and commands shifted to match.

    ``joint_positions() = inner.joint_positions() - offset`` and every commanded position is sent as
    ``q + offset``, so the nominal kinematics of the corrected angles is the true pose.
    A command the planner placed at a nominal joint limit would land past the real one by the
    offset: commands are clipped to the inner robot's limits (``lower_rad`` / ``upper_rad``, where
    it has them), as a controller's soft limits would, and the readings then say where it stopped.
    Other attributes are the inner robot's.
    """

    def __init__(self, inner: Robot, offset_rad) -> None:
        self.inner = inner
        self.offset_rad = np.asarray(offset_rad, float)
        if self.offset_rad.shape != (inner.dof,):
            raise ValueError(f"offset_rad must have {inner.dof} values, got {self.offset_rad.shape}")

    def __getattr__(self, name):
        return getattr(self.inner, name)

    @property
    def dof(self) -> int:
        return self.inner.dof

    def joint_positions(self) -> np.ndarray:
        return self.inner.joint_positions() - self.offset_rad

    def move_joints(self, q, speed_rad_s: float = 1.0) -> None:
        self.inner.move_joints(self._command(q), speed_rad_s)

    def guarded_move(self, path, stop: Callable[[], bool], speed_rad_s: float = 0.2) -> GuardedMoveResult:
        result = self.inner.guarded_move(self._command(path), stop, speed_rad_s)
        return GuardedMoveResult(stopped=result.stopped, q=result.q - self.offset_rad,
                                 waypoint_index=result.waypoint_index)

    def hold(self, duration_s: float, stop: Callable[[], bool] | None = None) -> GuardedMoveResult:
        result = self.inner.hold(duration_s, stop)
        return GuardedMoveResult(stopped=result.stopped, q=result.q - self.offset_rad,
                                 waypoint_index=result.waypoint_index)

    def time_s(self) -> float:
        return self.inner.time_s()

    def _command(self, q) -> np.ndarray:
        """Corrected angles ``q`` ((dof,) or (n, dof), radians) -> the inner robot's, within its limits."""
        raw = np.asarray(q, float) + self.offset_rad
        lower, upper = getattr(self.inner, "lower_rad", None), getattr(self.inner, "upper_rad", None)
        if lower is None or upper is None:
            return raw
        return np.clip(raw, lower, upper)
