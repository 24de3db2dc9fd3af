"""Tactile exploration: the loop, strategies, planner, stand, rigs, sessions and their replay.

Public API:

* runs: :func:`explore` (simulated run from :class:`RunSettings`), :func:`run_on_rig` with a
  :class:`Rig` (or :func:`open_rig` from a configuration file), :class:`RunResult`;
* the loop and its parts: :class:`ExplorationLoop`, :class:`LoopConfig`, :class:`TouchOutcome`,
  :class:`ApproachPlanner`, :class:`PlannerConfig`, :class:`FreePathPlanner` with
  :class:`FreePathConfig` (free moves around the prior box), :class:`Positioner`, :class:`FixedStand`,
  :class:`SimulatedStand`, :class:`StandPose`, :class:`ObjectPrior`, :class:`Touch`;
* strategies: :class:`TouchStrategy` (subclass it), :class:`ExplorationState`,
  :func:`make_strategy`, :data:`STRATEGIES`, :class:`VarianceStrategy`, :class:`RandomStrategy`,
  :class:`UniformStrategy`;
* watching and sessions: :class:`RunObserver`, :class:`RerunObserver` with :func:`open_stream`
  (Rerun, the ``viz`` extra), :class:`RunRecorder`, :func:`read_session`,
  :class:`SessionReplay` with :class:`ReplaySettings` (-> :class:`ReplayResult`);
* :func:`reconstruction_errors` (what ``metrics.json`` reports), :func:`load_config`;
* contact quality (issue 11): :class:`ContactPipeline`, :class:`ContactQuality`, :class:`DoubtRule`,
  :func:`pad_load`, the presses that give no contact (:class:`NoContactMeasured`,
  :class:`PadSideContact`, :class:`PressReleased`), the contacts the reconstruction leaves out
  (:class:`RimStandoff`, in :class:`Reconstruction`), and against a known truth :func:`contact_truth`.

Every name is imported on first use (module ``__getattr__``), so ``import explorer`` imports
neither torch nor pybullet.
"""
from __future__ import annotations

from common.lazy_exports import lazy_exports

_LAZY = {
    "explore": "explorer.run",
    "run_on_rig": "explorer.run",
    "RunSettings": "explorer.run",
    "RunResult": "explorer.run",
    "Rig": "explorer.rig",
    "object_prior": "explorer.rig",
    "open_rig": "explorer.backends",
    "load_config": "explorer.config",
    "ExplorationLoop": "explorer.loop",
    "LoopConfig": "explorer.loop",
    "Reconstruction": "explorer.loop",
    "RimStandoff": "explorer.rim_standoff",
    "TouchOutcome": "explorer.touch",
    "ApproachPlanner": "explorer.planner",
    "PlannerConfig": "explorer.planner",
    "FreePathPlanner": "explorer.free_path",
    "FreePathConfig": "explorer.free_path",
    "Positioner": "explorer.positioner",
    "FixedStand": "explorer.positioner",
    "SimulatedStand": "explorer.positioner",
    "StandPose": "explorer.positioner",
    "ObjectPrior": "explorer.touch",
    "Touch": "explorer.touch",
    "TouchStrategy": "explorer.strategies",
    "ExplorationState": "explorer.strategies",
    "make_strategy": "explorer.strategies",
    "STRATEGIES": "explorer.strategies",
    "VarianceStrategy": "explorer.strategies",
    "RandomStrategy": "explorer.strategies",
    "UniformStrategy": "explorer.strategies",
    "RunRecorder": "explorer.recording",
    "RunObserver": "explorer.observer",
    "RerunObserver": "explorer.rerun_view",
    "open_stream": "explorer.rerun_view",
    "read_session": "explorer.session",
    "SessionReplay": "explorer.replay",
    "ReplaySettings": "explorer.replay",
    "ReplayResult": "explorer.replay",
    "reconstruction_errors": "explorer.evaluation",
    "ContactPipeline": "explorer.contact",
    "ContactQuality": "explorer.contact",
    "DoubtRule": "explorer.contact",
    "NoContactMeasured": "explorer.contact",
    "PadSideContact": "explorer.contact",
    "PressReleased": "explorer.contact",
    "pad_load": "explorer.contact",
    "contact_truth": "explorer.contact_truth",
}

__all__ = sorted(_LAZY)

__getattr__, __dir__ = lazy_exports(__name__, _LAZY)
