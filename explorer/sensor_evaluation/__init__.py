"""Evidence for the simulated arm + fingertip sensor: contact detection, normal accuracy, speed.

Public API:

* :func:`run_evaluation` (:class:`EvaluationConfig` -> :class:`EvaluationReport`), and
  :func:`to_json_dict`, :func:`format_table`, :func:`write_figures` to report it;
* building blocks: :func:`build_rig`, :func:`run_press` / :func:`run_free_motion` (one trial in
  its own headless world), :func:`score_detectors`, :func:`summarize` / :func:`normal_trial`,
  :func:`sensor_variants`.

The CLI is ``tactile-sensor-eval`` (scripts/sensor_eval.py). Importing this package does not start
a simulator; PyBullet and torch load when a rig or a trial is built.
"""
from explorer.sensor_evaluation.detection import DEFAULT_DETECTORS, DetectorScore, GroundTruthConfig, score_detectors
from explorer.sensor_evaluation.experiments import (REFERENCE_MEAN_NORMAL_ERROR_DEG, EvaluationConfig, EvaluationReport,
                                           run_evaluation)
from explorer.sensor_evaluation.normal_accuracy import NormalAccuracy, normal_trial, summarize
from explorer.sensor_evaluation.report import format_table, to_json_dict, write_figures
from explorer.sensor_evaluation.press_rig import PressRig, build_rig
from explorer.sensor_evaluation.scene import SUPPORTED_OBJECTS
from explorer.sensor_evaluation.trials import (FreeMotionProtocol, PressProtocol, PressSpec, TrialRecording, run_free_motion,
                                      run_press)
from explorer.sensor_evaluation.variants import sensor_variants

__all__ = [
    "DEFAULT_DETECTORS", "DetectorScore", "EvaluationConfig", "EvaluationReport", "FreeMotionProtocol",
    "GroundTruthConfig", "NormalAccuracy", "PressProtocol", "PressRig", "PressSpec",
    "REFERENCE_MEAN_NORMAL_ERROR_DEG", "SUPPORTED_OBJECTS", "TrialRecording", "build_rig", "format_table",
    "normal_trial", "run_evaluation", "run_free_motion", "run_press", "score_detectors", "sensor_variants",
    "summarize", "to_json_dict", "write_figures",
]
