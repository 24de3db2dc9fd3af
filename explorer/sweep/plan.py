"""What a sweep runs: objects x strategies x normals settings x seeds, one directory per run.

A sweep directory holds ``sweep.json`` (the settings every run shares) and ``runs/<name>/``, one
:func:`explorer.run.explore` output per run. A run counts as done when its ``metrics.json`` says
``"completed": true``; everything else is (re)run, so a restarted sweep finishes only what is missing.
"""
from __future__ import annotations

import hashlib
import json
import os
from dataclasses import asdict, dataclass
from pathlib import Path

from explorer.planner import PlannerConfig
from explorer.run import RunSettings

#: Shared settings a restarted sweep must repeat exactly (its finished runs used them).
SHARED_KEYS = ("robot", "touches", "eval_every", "mesh_resolution", "profile", "calibration", "probe_depth_m")
#: What a sweep.json written before a key existed meant by it.
_SHARED_DEFAULTS = {"profile": "datasheet-noise", "calibration": None, "probe_depth_m": 0.03}
#: Shared settings that may name a file (a profile TOML, an arm calibration): the same content at
#: another path (a sweep directory copied or moved with its calibration inside) is the same setting.
_FILE_KEYS = ("profile", "calibration")


@dataclass(frozen=True)
class SweepConfig:
    """The grid of a sweep and the settings its runs share.

    Attributes
    ----------
    objects : tuple of str
        Registry names or mesh files (metres, object frame).
    strategies : tuple of str
        Names from :data:`explorer.strategies.STRATEGIES`.
    seeds : tuple of int
    normals : tuple of bool
        ``(True,)`` for GPIS with normals only, ``(True, False)`` for both.
    touches : int
        Touch budget of every run.
    robot : str
    eval_every : int
        Touches between the error-curve evaluations of a run (0: none).
    mesh_resolution : int
        Marching-cubes grid of each run's final reconstruction.
    profile : str
        Simulation profile name or TOML file (:mod:`explorer.sim_profile`).
    calibration : str or None
        An arm calibration file (``joint_calibration.json`` of ``scripts.calibrate_joints``) applied
        to every run (:mod:`explorer.arm_calibration`); its robot, profile and seed must be the sweep's.
    probe_depth_m : float
        How far past its target a touch may probe, metres (:class:`explorer.planner.PlannerConfig`).
    reach_samples : int
        Surface samples of each run's reach breakdown (0 skips it; ``RunSettings.reach_samples``).
        Not shared: the summary does not use it.
    """

    objects: tuple[str, ...]
    strategies: tuple[str, ...]
    seeds: tuple[int, ...]
    normals: tuple[bool, ...] = (True,)
    touches: int = 50
    robot: str = "armar3"
    eval_every: int = 5
    mesh_resolution: int = 96
    profile: str = "datasheet-noise"
    calibration: str | None = None
    probe_depth_m: float = PlannerConfig.probe_depth_m
    reach_samples: int = RunSettings.reach_samples

    def __post_init__(self) -> None:
        import objects
        import objects.generated as generated
        import robots
        from explorer.strategies import STRATEGIES
        from explorer.sim_profile import PROFILES, get_profile

        get_profile(self.profile)  # raises naming the bad profile or parameter
        if self.profile not in PROFILES:  # a file: workers may start elsewhere
            object.__setattr__(self, "profile", str(Path(self.profile).resolve()))

        if self.calibration is not None:
            from explorer.arm_calibration import read_arm_calibration

            calibration = read_arm_calibration(self.calibration)  # raises naming the file or field
            object.__setattr__(self, "calibration", str(Path(self.calibration).resolve()))
            if calibration.robot != self.robot or calibration.seed not in self.seeds or len(self.seeds) != 1:
                raise ValueError(f"calibration {self.calibration} is of robot {calibration.robot!r}, seed "
                                 f"{calibration.seed}: a calibrated sweep runs that robot and that one seed")

        for name in ("objects", "strategies", "seeds", "normals"):
            values = getattr(self, name)
            if isinstance(values, str) or not values:
                raise ValueError(f"{name} must be a non-empty sequence, got {values!r}")
            object.__setattr__(self, name, tuple(values))
            if len(set(values)) != len(values):
                raise ValueError(f"{name} holds duplicates: {values!r}")
        for name in self.objects:
            if generated.is_generated_name(name):
                generated.parse_name(name)  # raises naming the syntax or listing the families
            elif name not in objects.names() and not Path(name).is_file():
                raise ValueError(f"unknown object {name!r}: neither a registry name "
                                 f"({', '.join(objects.names())}), a generated:FAMILY/SEED name "
                                 "nor an existing mesh file")
        # Workers (Ray's especially) may start in another directory.
        object.__setattr__(self, "objects", tuple(
            n if n in objects.names() or generated.is_generated_name(n) else str(Path(n).resolve())
            for n in self.objects))
        for name in self.strategies:
            if name not in STRATEGIES:
                raise ValueError(f"unknown strategy {name!r}; choose from {', '.join(STRATEGIES)}")
        if self.robot not in robots.names():
            raise ValueError(f"unknown robot {self.robot!r}; choose from {', '.join(robots.names())}")
        if not all(isinstance(s, int) and s >= 0 for s in self.seeds):
            raise ValueError(f"seeds must be non-negative integers, got {self.seeds!r}")
        if not all(isinstance(n, bool) for n in self.normals):
            raise ValueError(f"normals must be booleans, got {self.normals!r}")
        if not isinstance(self.probe_depth_m, (int, float)) or not 0.0 <= self.probe_depth_m < 1.0:
            raise ValueError(f"probe_depth_m must be a number of metres in [0, 1), got {self.probe_depth_m!r}")
        for name, least in (("touches", 1), ("eval_every", 0), ("mesh_resolution", 8), ("reach_samples", 0)):
            value = getattr(self, name)
            if not isinstance(value, int) or value < least:
                raise ValueError(f"{name} must be an integer >= {least}, got {value!r}")
        labels = [object_label(name) for name in self.objects]
        if len(set(labels)) != len(labels):
            raise ValueError(f"objects {self.objects!r} give clashing run names {labels!r}; "
                             "rename the mesh files")

    def shared(self) -> dict:
        """The settings recorded in ``sweep.json``."""
        return {key: getattr(self, key) for key in SHARED_KEYS}


@dataclass(frozen=True)
class SweepRun:
    """One cell of the grid."""

    object: str
    strategy: str
    use_normals: bool
    seed: int

    @property
    def name(self) -> str:
        """Directory name: ``<object>-<strategy>-<normals|nonormals>-seed<k>``."""
        normals = "normals" if self.use_normals else "nonormals"
        return f"{object_label(self.object)}-{self.strategy}-{normals}-seed{self.seed}"

    def settings(self, config: SweepConfig) -> RunSettings:
        return RunSettings(object=self.object, robot=config.robot, strategy=self.strategy,
                           touches=config.touches, seed=self.seed, use_normals=self.use_normals,
                           eval_every=config.eval_every, mesh_resolution=config.mesh_resolution,
                           profile=config.profile, calibration=config.calibration,
                           reach_samples=config.reach_samples,
                           planner=PlannerConfig(probe_depth_m=float(config.probe_depth_m)))


def object_label(name: str) -> str:
    """A registry name as is; ``generated:mug/3`` as ``generated-mug-3``; a mesh file by its stem."""
    import objects

    return objects.file_label(name)


def plan_runs(config: SweepConfig) -> list[SweepRun]:
    """Every run of the grid, in table order (object, strategy, normals, seed)."""
    return [SweepRun(o, s, n, k) for o in config.objects for s in config.strategies
            for n in config.normals for k in config.seeds]


def run_dir(out_dir: Path, run: SweepRun) -> Path:
    return Path(out_dir) / "runs" / run.name


def read_metrics(directory: Path) -> dict | None:
    """A run's ``metrics.json``, or None where it is missing or unreadable (an interrupted write)."""
    try:
        return json.loads((Path(directory) / "metrics.json").read_text())
    except (FileNotFoundError, json.JSONDecodeError):
        return None


def is_complete(directory: Path) -> bool:
    """Whether the run in ``directory`` finished (its ``metrics.json`` says ``"completed": true``)."""
    metrics = read_metrics(directory)
    return metrics is not None and metrics.get("completed") is True


def prepare_sweep_dir(out_dir: Path, config: SweepConfig) -> None:
    """Create ``out_dir`` and record the shared settings; refuse a directory swept with others.

    Raises
    ------
    ValueError
        ``out_dir/sweep.json`` records different shared settings (its finished runs would be
        mixed with runs of another budget or robot).
    """
    out_dir = Path(out_dir)
    record = out_dir / "sweep.json"
    shared = config.shared()
    digests = {key: digest for key in _FILE_KEYS if (digest := _file_digest(shared[key]))}
    if record.exists():
        stored = json.loads(record.read_text())
        previous, previous_digests = stored.get("shared", {}), stored.get("file_digests", {})

        def same(key, value) -> bool:
            old = previous.get(key, _SHARED_DEFAULTS.get(key))
            if old == value:
                return True
            return key in digests and digests[key] in (previous_digests.get(key), _file_digest(old))

        differing = {k: (previous.get(k), v) for k, v in shared.items() if not same(k, v)}
        if differing:
            text = ", ".join(f"{k}={old!r} there, {new!r} now" for k, (old, new) in differing.items())
            raise ValueError(f"{out_dir} holds a sweep with other settings ({text}); "
                             "use another output directory")
    (out_dir / "runs").mkdir(parents=True, exist_ok=True)
    record.write_text(json.dumps({"shared": shared, "file_digests": digests,
                                  "last_config": _jsonable(asdict(config))}, indent=2))


def _file_digest(value) -> str | None:
    """SHA-256 of the file an absolute path names, None for anything else (a profile's name, None)."""
    if not isinstance(value, str) or not os.path.isabs(value) or not Path(value).is_file():
        return None
    return hashlib.sha256(Path(value).read_bytes()).hexdigest()


def _jsonable(value):
    if isinstance(value, dict):
        return {k: _jsonable(v) for k, v in value.items()}
    if isinstance(value, tuple):
        return [_jsonable(v) for v in value]
    return value
