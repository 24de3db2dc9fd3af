"""Calibrate the arm's joint offsets and link lengths by touching a known ball, in simulation, and
show before/after.

The lab procedure of :mod:`robots.joint_calibration` run on the simulated robot of a profile: a
5 cm ball is placed at three known places in front of the arm; the fingertip touches it at
``--touches`` poses (guarded approach stopped by the pressure detector, held while the spring
settles, orientation from the IMU, force from the pad's pressure). The first two thirds of the
touches calibrate (a robust fit by default: a touch whose pad did not lie flat on the ball does not
bend the offsets; the pad's compression on the ball is fitted with them from each touch's force;
``--least-squares`` is the plain fit with a cross-validated ridge), the last third
are held out: their pad position computed from the encoders is compared with the simulator's true
pad position before and after the offsets are applied, and their distance from the ball with the
fitted model (``held_out_ball_residual_mm``) is what a lab, without that truth, checks the fit by:
the error along the touched normal, the one that moves a contact off a surface. The touches come
from all around the ball and from configurations spread over the joint ranges
(:func:`touch_poses`). Writes ``joint_calibration.json`` and ``joint_calibration.png`` into ``--out``.

    python -m scripts.calibrate_joints --profile hardware-like --touches 36 --seed 0 --out DIR
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

BALL_RADIUS_M = 0.05
PLACES_M = np.array([[0.0, 0.0, 0.0], [0.0, 0.12, 0.0], [0.0, -0.06, 0.12]])
"""Ball centres relative to the robot's workspace centre, metres (known: measured once by the lab)."""
STANDOFF_M = 0.012
OVERSHOOT_M = 0.025
"""How far past the ball's nominal surface an approach may go before it counts as no touch: the
uncalibrated arm's pad can be 1-2 cm off where its nominal kinematics put it (ARMAR-III,
hardware-like, seed 1: 24 of 36 approaches ran out at 8 mm without meeting the ball); the
detector stops the approach at the contact."""
CONE_DEG = 85.0
"""Largest angle between a touch's outward normal and the arm's home facing, degrees. The exploration
on the stand touches from the side as much as from the front (the reference table's ARMAR-6 contacts:
normals 36-83 deg from that facing, 10th-90th percentile); offsets fitted from touches within 55 deg
and IK started at home left errors of 2-4 mm along the normal at the exploration's configurations
(BENCHMARKS.md, issue 12)."""
APPROACH_SPEED_MPS = 0.005
HOLD_S = 0.6


def touch_poses(kinematics, count: int, rng: np.random.Generator, spread: bool = True):
    """Reachable ball touches, the three places in turn.

    Returns ``(centres (n, 3), normals (n, 3), q (n, dof))``: the ball's centre (world, metres), the
    touched point's outward normal and the nominal arm's joint angles (radians) that put the pad
    flat on the ball there. ``spread`` (the default): normals within :data:`CONE_DEG` of the arm's
    home facing and each pose's inverse kinematics started from its own uniform draw within the
    joint limits, so the touches visit the arm's configurations as widely as the exploration does;
    otherwise the design before: within 55 deg, every IK started from the home pose.
    """
    from robots.ik import solve_pad_ik

    spec = kinematics.spec
    facing = -kinematics.forward_kinematics(spec.home_q).z_axis
    centres, normals = [], []
    while len(normals) < 4 * count:
        n = rng.standard_normal(3)
        n /= np.linalg.norm(n)
        if n @ facing > math.cos(math.radians(CONE_DEG if spread else 55.0)):
            normals.append(n)
            centres.append(np.asarray(spec.workspace_center_m, float) + PLACES_M[len(normals) % 3])
    centres, normals = np.array(centres), np.array(normals)
    lower, upper = kinematics.lower_rad, kinematics.upper_rad
    seeds = lower + (upper - lower) * rng.random((len(normals), spec.dof)) if spread else spec.home_q
    ik = solve_pad_ik(kinematics, centres + BALL_RADIUS_M * normals, -normals, q_seed=seeds)
    keep = np.flatnonzero(ik.success)[:count]
    return centres[keep], normals[keep], ik.q_rad[keep]


def run_touches(profile, robot: str, count: int, seed: int, progress=None, spread: bool = True):
    """Touch the ball ``count`` times; returns per-touch reported q, IMU body quaternion, true pad
    position, ball centre, all (n, ...) arrays, the arm's true offsets, the kinematics, the true
    link-length errors and each touch's force from the pad's pressure ((n,) newtons)."""
    import objects
    import robots
    from robots.ik import solve_pad_ik
    from robots.kinematics import ArmKinematics
    from robots.sim_arm import SimArm
    from robots.sim_world import SimWorld
    from sensor.contact_detection import PressureContactDetector
    from sensor.normal_estimation import OrientationNotSettledError, estimate_normal
    from sensor.sim_sensor import SimulatedTactileSensor
    from explorer.simulation import connect_sensor

    spec = profile.robot_spec(robots.load(robot))
    kinematics = ArmKinematics(spec)
    rng = np.random.default_rng(seed)
    centres, normals, planned_q = touch_poses(kinematics, count, rng, spread=spread)
    ball = objects.load("sphere")
    rows = []
    with SimWorld(table=None) as world:
        encoder = profile.encoder_model(spec.dof, seed)
        arm = SimArm(world, spec, encoder=encoder, spring_friction_nm=profile.spring_friction_nm,
                     link_length_error_m=profile.link_length_errors_m(spec, seed))
        sensor = SimulatedTactileSensor(config=profile.sensor_config(), seed=seed)
        connect_sensor(world, arm, sensor)
        sensor.open()
        handle = world.add_object(ball.urdf_path, centres[0], name="ball")
        for k, (centre, normal, planned) in enumerate(zip(centres, normals, planned_q)):
            arm.guarded_move(spec.home_q[None], lambda: False, speed_rad_s=0.8)
            world.set_object_pose(handle, centre, (1.0, 0.0, 0.0, 0.0))
            depths = np.arange(0.0, STANDOFF_M + OVERSHOOT_M, 0.001)
            points = centre + (BALL_RADIUS_M + STANDOFF_M - depths)[:, None] * normal
            ik = solve_pad_ik(kinematics, points, np.tile(-normal, (len(depths), 1)), q_seed=planned)
            if not ik.success.all():
                continue
            arm.guarded_move(ik.q_rad[:1], lambda: False, speed_rad_s=0.8)
            world.step(60)
            sensor.drain()
            detector = PressureContactDetector()
            readings = []

            def touching():
                for reading in sensor.drain():
                    readings.append(reading)
                    detector.update(reading)
                return detector.in_contact

            speed = APPROACH_SPEED_MPS * np.abs(np.diff(ik.q_rad, axis=0)).max() / 0.001
            result = arm.guarded_move(ik.q_rad[1:], touching, speed_rad_s=speed)
            baseline = detector.baseline_pa
            arm.hold(HOLD_S)
            hold = [r for r in sensor.drain()]
            pad_true = arm.link_state(spec.pad_link).position_m
            q_read = arm.joint_positions()
            arm.guarded_move(ik.q_rad[:result.waypoint_index + 1][::-1], lambda: False, speed_rad_s=speed)
            if not result.stopped:
                continue
            try:
                estimate = estimate_normal(hold, baseline)
            except OrientationNotSettledError:
                continue
            rows.append((q_read, estimate.body_quat_wxyz, pad_true, centre, estimate.force_n))
            if progress:
                progress(f"touch {k + 1}/{len(centres)}: {len(rows)} usable")
        true_offsets = np.asarray(encoder.offset_rad) if encoder.offset_rad else np.zeros(spec.dof)
    if not rows:
        raise RuntimeError("no usable touch of the ball (none stopped by the detector with a settled orientation)")
    q, quats, pads, balls, forces = (np.array(v) for v in zip(*rows))
    return q, quats, pads, balls, true_offsets, kinematics, dict(arm.link_length_error_m), forces


def kinematic_touches(profile, robot: str, count: int, seed: int, spread: bool = True):
    """The touches of :func:`run_touches` from kinematics alone (seconds, not a simulation): the
    arm with the profile's link-length errors (a rewritten URDF) puts its pad flat on the ball at
    the same planned poses; the encoders read the true angles plus the offsets, half the backlash
    in a random direction and the resolution; the IMU's orientation carries a heading offset
    (``imu_heading_offset_std_deg``, one per run, about the vertical) and a tilt error
    (``imu_tilt_bias_std_deg``, per touch); the mounting is taken as calibrated. Same returns, but
    no forces (None): the pad lies on the ball uncompressed."""
    import tempfile

    import robots
    from common.rotations import matrix_to_quat
    from robots.ik import solve_pad_ik
    from robots.kinematics import ArmKinematics
    from robots.link_lengths import with_link_length_errors
    from scipy.spatial.transform import Rotation

    spec = profile.robot_spec(robots.load(robot))
    kinematics = ArmKinematics(spec)
    lengths = profile.link_length_errors_m(spec, seed)
    with tempfile.TemporaryDirectory() as directory:
        true_kinematics = ArmKinematics(with_link_length_errors(spec, lengths, Path(directory)))
    rng = np.random.default_rng(seed)
    centres, normals, planned_q = touch_poses(kinematics, count, rng, spread=spread)
    ik = solve_pad_ik(true_kinematics, centres + BALL_RADIUS_M * normals, -normals, q_seed=planned_q)
    q_true = ik.q_rad[ik.success]
    pad = true_kinematics.forward_kinematics(q_true)
    body = true_kinematics.forward_kinematics(q_true, spec.sensor_body_link)
    offsets = profile.joint_offsets_rad(spec.dof, seed)
    backlash = 0.5 * np.radians(profile.encoder_backlash_deg) * rng.choice([-1.0, 1.0], q_true.shape)
    q_read = q_true + offsets + backlash
    if profile.encoder_resolution_rad:
        q_read = np.round(q_read / profile.encoder_resolution_rad) * profile.encoder_resolution_rad
    heading = Rotation.from_rotvec([0.0, 0.0, np.radians(profile.imu_heading_offset_std_deg) * rng.standard_normal()])
    axes = rng.standard_normal((len(q_true), 3))
    axes[:, 2] = 0.0
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    tilt = Rotation.from_rotvec(axes * np.radians(profile.imu_tilt_bias_std_deg) * rng.standard_normal((len(q_true), 1)))
    measured = (heading * tilt * Rotation.from_matrix(body.rotation)).as_matrix()
    balls = pad.position_m + BALL_RADIUS_M * pad.z_axis  # the pad lies flat on the ball
    return q_read, matrix_to_quat(measured), pad.position_m, balls, offsets, kinematics, lengths, None


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="calibrate_joints", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--profile", default="hardware-like", help="simulation profile (default hardware-like)")
    parser.add_argument("--robot", default="armar3")
    parser.add_argument("--touches", type=int, default=36, help="touches in all (2/3 calibrate, 1/3 held out)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--link-lengths", action=argparse.BooleanOptionalAction, default=True,
                        help="fit the arm's link lengths too (default; from touches whose IK started at home "
                             "their standard errors exceeded the errors, BENCHMARKS.md)")
    parser.add_argument("--home-poses", action="store_true",
                        help="the touch poses before issue 12's spread: IK from the home pose, normals within "
                             "55 deg of its facing (for comparison)")
    parser.add_argument("--least-squares", action="store_true",
                        help="plain least squares with a cross-validated ridge (the fit before the robust default; "
                             "every touch weighs, also one whose pad did not lie flat on the ball)")
    parser.add_argument("--kinematic", action="store_true",
                        help="touches from kinematics and the profile's sensor errors, no physics (seconds)")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    from explorer.sim_profile import get_profile

    try:
        profile = get_profile(args.profile)
    except ValueError as error:
        parser.error(str(error))
    if args.touches < 12:
        parser.error(f"--touches must be at least 12 (8 to calibrate 7 joints, 4 held out), got {args.touches}")
    from robots.joint_calibration import (ROBUST_RIDGE_M_PER_RAD, ROBUST_SCALE_M, SphereTouches, cross_validated_ridge,
                                          fit_joint_offsets, sphere_residuals_m)
    from robots.link_lengths import link_length_shift_m

    started = time.perf_counter()
    if args.kinematic:
        q, quats, pads, balls, truth, kinematics, true_lengths, forces = kinematic_touches(
            profile, args.robot, args.touches, args.seed, spread=not args.home_poses)
    else:
        q, quats, pads, balls, truth, kinematics, true_lengths, forces = run_touches(
            profile, args.robot, args.touches, args.seed,
            progress=lambda line: print(line, file=sys.stderr, flush=True), spread=not args.home_poses)
    n_fit = (2 * len(q)) // 3
    if n_fit < kinematics.dof + 4:
        print(f"calibrate_joints: only {len(q)} touches were usable; raise --touches", file=sys.stderr)
        return 1
    calibration_touches = SphereTouches(q[:n_fit], quats[:n_fit], balls[:n_fit], BALL_RADIUS_M,
                                        None if forces is None else forces[:n_fit])
    if args.least_squares:
        ridge = cross_validated_ridge(kinematics, calibration_touches, link_lengths=args.link_lengths)
        ridge_m_per_rad, robust_scale_m, scores = ridge.ridge_m_per_rad, None, ridge.scores_m
    else:
        ridge_m_per_rad, robust_scale_m, scores = ROBUST_RIDGE_M_PER_RAD, ROBUST_SCALE_M, {}
    fit = fit_joint_offsets(kinematics, calibration_touches, ridge_m_per_rad=ridge_m_per_rad,
                            link_lengths=args.link_lengths, robust_scale_m=robust_scale_m)

    def errors_mm(offset, lengths):
        computed = kinematics.pad_position_from_orientation(q[n_fit:] - offset, quats[n_fit:])
        if lengths:
            computed = computed + link_length_shift_m(kinematics, q[n_fit:] - offset, lengths)
        return 1e3 * np.linalg.norm(computed - pads[n_fit:], axis=1)

    before = errors_mm(np.zeros_like(fit.offset_rad), {})
    after = errors_mm(fit.offset_rad, fit.link_length_error_m)
    held_out = SphereTouches(q[n_fit:], quats[n_fit:], balls[n_fit:], BALL_RADIUS_M,
                             None if forces is None else forces[n_fit:])
    held_out_residual_mm = 1e3 * sphere_residuals_m(kinematics, held_out, fit.offset_rad, fit.link_length_error_m,
                                                    fit.pad_compliance_m_per_n or 0.0)
    dof = kinematics.dof
    result = {
        "profile": profile.name, "robot": args.robot, "seed": args.seed, "touches_used": int(len(q)),
        "touches_from": "kinematics" if args.kinematic else "simulation",
        "calibration_touches": int(n_fit), "held_out_touches": int(len(q) - n_fit),
        "true_offset_deg": np.degrees(truth).round(4).tolist(),
        "fitted_offset_deg": np.degrees(fit.offset_rad).round(4).tolist(),
        "offset_std_deg": np.degrees(fit.parameter_std[:dof]).round(4).tolist(),
        "offset_resolution": fit.resolution[:dof].round(4).tolist(),
        "unresolved_joints": [kinematics.spec.joint_names[i] for i in fit.unresolved()],
        "true_link_length_error_mm": {k: round(1e3 * v, 4) for k, v in true_lengths.items()},
        "fitted_link_length_error_mm": {k: round(1e3 * v, 4) for k, v in fit.link_length_error_m.items()},
        "link_length_std_mm": dict(zip(fit.link_length_error_m, (1e3 * fit.parameter_std[dof:]).round(4).tolist())),
        "singular_values": fit.singular_values.round(5).tolist(),
        "pad_compliance_mm_per_n": (None if fit.pad_compliance_m_per_n is None
                                    else round(1e3 * fit.pad_compliance_m_per_n, 4)),
        "pad_compliance_std_mm_per_n": (None if fit.pad_compliance_m_per_n is None
                                        else round(1e3 * float(fit.parameter_std[-1]), 4)),
        "fit": "least squares, cross-validated ridge" if args.least_squares else "robust (Cauchy loss)",
        "robust_scale_mm": None if robust_scale_m is None else 1e3 * robust_scale_m,
        "touches_off_the_ball": (None if robust_scale_m is None
                                 else int(np.sum(np.abs(fit.residual_after_m) > 3 * robust_scale_m))),
        "ridge_m_per_rad": ridge_m_per_rad,
        "ridge_cross_validation_rms_mm": {str(k): round(1e3 * v[0], 4) for k, v in scores.items()},
        "ball_residual_rms_mm": {"before": float(1e3 * np.sqrt(np.mean(fit.residual_before_m**2))),
                                 "after": float(1e3 * np.sqrt(np.mean(fit.residual_after_m**2)))},
        "held_out_ball_residual_mm": {"rms": float(np.sqrt(np.mean(held_out_residual_mm**2))),
                                      "median": float(np.median(held_out_residual_mm)),
                                      "max": float(np.abs(held_out_residual_mm).max())},
        "held_out_pad_error_mm": {"before_mean": float(before.mean()), "before_max": float(before.max()),
                                  "after_mean": float(after.mean()), "after_max": float(after.max())},
        "wall_s": time.perf_counter() - started,
    }
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "joint_calibration.json").write_text(json.dumps(result, indent=2))
    _figure(before, after, result, args.out / "joint_calibration.png")
    print(json.dumps(result, indent=2))
    if result["unresolved_joints"]:
        shares = ", ".join(f"{name} {fit.resolution[i]:.2f}" for name, i in zip(result["unresolved_joints"], fit.unresolved()))
        print(f"calibrate_joints: the touches determine less than half of these offsets ({shares}); the fit "
              "keeps them near zero whatever they are, so their offset_std_deg understates their error. "
              "Calibrate them another way (they turn the pad about points near it, which a ball's radius "
              "does not see)", file=sys.stderr)
    return 0


def _figure(before, after, result, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 3.5))
    index = np.arange(len(before))
    ax.bar(index - 0.2, before, 0.4, label=f"before (mean {before.mean():.1f} mm)", color="tab:red")
    ax.bar(index + 0.2, after, 0.4, label=f"after (mean {after.mean():.1f} mm)", color="tab:green")
    ax.set_xlabel("held-out touch")
    ax.set_ylabel("pad position error (mm)")
    ax.set_title(f"Joint-offset calibration on a ball, {result['robot']}, profile {result['profile']}")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
