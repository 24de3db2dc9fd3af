"""``scripts.calibrate_joints`` end to end on kinematic touches (seconds): the file it writes, and bad input."""
from __future__ import annotations

import json

import numpy as np
import pytest

from scripts import calibrate_joints


@pytest.mark.parametrize("extra, fit", [([], "robust (Cauchy loss)"), (["--least-squares"], "least squares")])
def test_the_calibration_file_says_how_it_was_fitted_and_what_it_gained(tmp_path, extra, fit, capsys):
    out = tmp_path / "calibration"
    status = calibrate_joints.main(["--kinematic", "--robot", "armar3", "--touches", "36", "--seed", "0",
                                    "--out", str(out), *extra])
    assert status == 0
    result = json.loads((out / "joint_calibration.json").read_text())
    assert result["fit"].startswith(fit)
    assert result["touches_from"] == "kinematics" and result["robot"] == "armar3"
    held_out = result["held_out_pad_error_mm"]
    assert held_out["after_mean"] < 0.5 * held_out["before_mean"]
    on_the_ball = result["held_out_ball_residual_mm"]  # what a lab sees, without the truth
    assert on_the_ball["rms"] < held_out["after_mean"] and on_the_ball["max"] >= abs(on_the_ball["median"])
    assert (result["touches_off_the_ball"] is None) == bool(extra)
    assert (out / "joint_calibration.png").exists()
    resolution = np.array(result["offset_resolution"])
    assert len(resolution) == len(result["fitted_offset_deg"]) and np.all((resolution >= 0) & (resolution <= 1))
    import robots

    unresolved = [name for name, share in zip(robots.load("armar3").joint_names, resolution) if share < 0.5]
    assert result["unresolved_joints"] == unresolved
    assert bool(unresolved) == ("determine less than half of these offsets" in capsys.readouterr().err)


def test_too_few_touches_are_refused_with_the_fix(capsys):
    with pytest.raises(SystemExit) as exit_info:
        calibrate_joints.main(["--touches", "5", "--out", "unused"])
    assert exit_info.value.code == 2
    assert "--touches must be at least 12" in capsys.readouterr().err


def test_every_ball_touch_of_the_uncalibrated_arm_reaches_the_ball():
    """Simulated touches (physics): the hardware-like ARMAR-III of seed 1 puts its pad 1-2 cm from
    where its nominal kinematics say, so approaches that stopped 8 mm past the ball's nominal
    surface ran out without a contact on two touches in three and its calibration failed;
    ``OVERSHOOT_M`` lets every approach reach the ball, and the detector stops it there."""
    from explorer.sim_profile import get_profile

    count = 8
    q, _, pads, balls, *_ = calibrate_joints.run_touches(get_profile("hardware-like"), "armar3", count, seed=1)
    assert len(q) >= count - 2  # a press may not settle (2 of 36 on this arm); 3 of 8 were usable before
    gap = np.linalg.norm(pads - balls, axis=1) - calibrate_joints.BALL_RADIUS_M
    assert np.all(np.abs(gap) < 0.01)  # the pad (its true place) is on the ball, not short of it
