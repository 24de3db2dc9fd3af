"""``scripts.calibration_benchmark``: its score is zero for the true offsets and grows with the error
left; bad input is refused with one line."""
from __future__ import annotations

import numpy as np
import pytest

import robots
from robots.kinematics import ArmKinematics
from scripts import calibration_benchmark


def test_the_score_is_the_pad_error_the_leftover_offsets_give():
    kinematics = ArmKinematics(robots.load("armar3"))
    truth = np.radians([0.5, -0.3, 0.2, 0.4, -0.2, 0.1, 0.3])
    score = calibration_benchmark.pad_error_scorer(kinematics, truth, seed=0)
    assert score(truth) == 0.0
    uncalibrated = score(np.zeros_like(truth))
    assert 2.0 < uncalibrated < 30.0  # half a degree per joint: millimetres to centimetres at the pad
    half = score(truth / 2.0)  # half the error left: about half the pad error (small angles)
    assert half == pytest.approx(uncalibrated / 2.0, rel=0.05)


@pytest.mark.parametrize("argv, message", [
    (["--robots", "armar9"], "unknown robot"),
    (["--scales", "0"], "every Cauchy scale must be positive"),
    (["--touches", "5"], "must be at least 12"),
    (["--seeds", "one"], "invalid literal"),
])
def test_bad_input_is_refused_with_one_line(tmp_path, capsys, argv, message):
    with pytest.raises(SystemExit) as exit_info:
        calibration_benchmark.main([*argv, "--out", str(tmp_path)])
    assert exit_info.value.code == 2
    assert message in capsys.readouterr().err
