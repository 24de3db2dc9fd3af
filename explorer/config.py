"""Rig configuration: which robot and sensor to use and how to reach them, what object is explored
and roughly where, and the exploration settings, from a TOML or JSON file.

::

    [robot]
    backend = "serial"          # "sim" | "serial" | "emulated"
    spec = "armar3"             # registered robot name or robot spec .json path
    port = "/dev/ttyUSB0"       # or "armemu://armar3" (emulated controller)

    [sensor]
    backend = "i2c"             # "sim" | "i2c" | "uart" | "mcu" | "emulated"
    bus = 1
    bmp280_address = 0x76
    bno055_address = 0x28
    calibration = "calibration.json"   # relative to this file

    [object]
    name = "mug"                        # a label on hardware; a registry name or mesh in simulation
    centre_m = [0.0, 0.55, 1.0]         # rough centre, robot base frame (the object frame's origin)
    half_extent_m = [0.06, 0.06, 0.08]  # rough half size along the base axes (over-estimate)
    reference_mesh = "mug.stl"          # optional true surface, object frame, for error metrics
    units = "m"                         # length unit of the mesh files: "m" (default), "cm", "mm", "in"

    [exploration]
    touches = 50
    strategy = "variance"
    probe_depth_m = 0.15                # how far past its target a touch may go before it is a miss
    reach_samples = 64                  # reach_breakdown's surface samples (0 skips it: 0.5 s each unreachable)

    [simulation]                        # backend = "sim" only
    profile = "hardware-like"           # ideal | datasheet-noise (default) | hardware-like | a .toml file

:func:`load_config` reads and checks a file (every error names the key); this module is the schema
only. :mod:`explorer.backends` opens what a configuration describes
(:func:`explorer.backends.open_backends`, :func:`explorer.backends.open_rig`). ``robot.backend = "emulated"`` with
``sensor.backend = "emulated"`` is a dry run without hardware: the serial arm protocol and the
chip drivers on emulators, pressed against a virtual sphere (``[emulation]``).
"""
from __future__ import annotations

import difflib
import json
import math
import sys
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

ROBOT_BACKENDS = ("sim", "serial", "emulated")
#: The strategies' names (``explorer.strategies.STRATEGIES`` is keyed by them; a test ties the two).
STRATEGY_NAMES = ("variance", "efficient", "random", "uniform")
SENSOR_BACKENDS = ("sim", "i2c", "uart", "mcu", "emulated")
BMP280_ADDRESSES = (0x76, 0x77)
BNO055_ADDRESSES = (0x28, 0x29)
BNO055_UART_BAUD = 115200
MCU_DEFAULT_BAUD = 230400
#: Length units a mesh file may be in (the keys of ``objects.UNITS``; not imported to keep this light).
MESH_UNITS = ("m", "cm", "mm", "in")
FUSION_MODES = ("IMU", "COMPASS", "M4G", "NDOF_FMC_OFF", "NDOF")

"""Builds the simulated robot and sensor for a config; a context manager yielding ``(robot, sensor)``."""


def _fail(key: str, message: str) -> ValueError:
    return ValueError(f"{key}: {message}")


def _choice(key: str, value: Any, choices: tuple[str, ...]) -> str:
    if value not in choices:
        raise _fail(key, f"{value!r} is not one of {', '.join(repr(c) for c in choices)}")
    return value


def _integer(key: str, value: Any, low: int, high: int | None = None) -> int:
    if isinstance(value, str) and value.lower().startswith("0x"):  # JSON has no hex literals
        try:
            value = int(value, 16)
        except ValueError:
            raise _fail(key, f"{value!r} is not a hexadecimal integer") from None
    if isinstance(value, bool) or not isinstance(value, int):
        raise _fail(key, f"expected an integer, got {value!r}")
    if value < low or (high is not None and value > high):
        bound = f">= {low}" if high is None else f"in {low}..{high}"
        raise _fail(key, f"{value} must be {bound}")
    return value


def _positive(key: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
        raise _fail(key, f"expected a positive number, got {value!r}")
    return float(value)


def _number(key: str, value: Any, low: float, high: float) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not low <= value < high:
        raise _fail(key, f"expected a number in [{low:g}, {high:g}), got {value!r}")
    return float(value)


def _port(key: str, value: Any) -> str | None:
    if value is None:
        return None
    if not isinstance(value, str) or not value.strip():
        raise _fail(key, f"expected a device path or URL such as '/dev/ttyUSB0', got {value!r}")
    return value


def _vector3(key: str, value: Any, positive: bool = False) -> tuple[float, float, float] | None:
    """Three finite numbers (a single number means the same on each axis when ``positive``)."""
    if value is None:
        return None
    if positive and isinstance(value, (int, float)) and not isinstance(value, bool):
        value = [value] * 3
    if (not isinstance(value, (list, tuple)) or len(value) != 3
            or any(isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) for v in value)):
        raise _fail(key, f"expected three numbers [x, y, z] in metres, got {value!r}")
    if positive and min(value) <= 0:
        raise _fail(key, f"every component must be positive, got {list(value)}")
    return tuple(float(v) for v in value)


def _boxes(key: str, value: Any) -> tuple[tuple[float, ...], ...]:
    """Boxes as six finite numbers each, ``[x, y, z, half_x, half_y, half_z]`` with positive halves."""
    if not isinstance(value, (list, tuple)):
        raise _fail(key, f"expected a list of boxes [x, y, z, half_x, half_y, half_z] in metres, got {value!r}")
    boxes = []
    for i, box in enumerate(value):
        if (not isinstance(box, (list, tuple)) or len(box) != 6
                or any(isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) for v in box)):
            raise _fail(f"{key}[{i}]", f"expected six numbers [x, y, z, half_x, half_y, half_z] in metres, got {box!r}")
        if min(box[3:]) <= 0:
            raise _fail(f"{key}[{i}]", f"the half sizes (the last three numbers) must be positive, got {list(box[3:])}")
        boxes.append(tuple(float(v) for v in box))
    return tuple(boxes)


def _address(key: str, value: Any, allowed: tuple[int, ...], wiring: str) -> int:
    value = _integer(key, value, 0, 0x7F)
    if value not in allowed:
        raise _fail(key, f"0x{value:02X} is not a possible address of this chip ({wiring})")
    return value


@dataclass(frozen=True)
class RobotConfig:
    """``[robot]``: the arm backend.

    Attributes
    ----------
    backend : {"sim", "serial"}
    spec : str
        Registered robot name or robot spec ``.json`` path.
    port : str or None
        Serial device or pyserial URL of the controller (required for ``"serial"``).
    baudrate : int
    control_rate_hz : float
        Joint-target streaming rate, Hz.
    reply_timeout_s : float
        Per-attempt reply timeout, seconds.
    attempts : int
        Tries per request.
    obstacles_m : tuple of (6,) float
        What else is fixed in the arm's workspace (the table the stand is on), as axis-aligned
        boxes ``[x, y, z, half_x, half_y, half_z]``: centre and half size, robot base frame,
        metres. Free moves keep clear of them (:attr:`explorer.rig.Rig.obstacles`). The simulation
        adds its own table.
    """

    backend: str = "sim"
    spec: str = "armar3"
    port: str | None = None
    baudrate: int = 1_000_000
    control_rate_hz: float = 100.0
    reply_timeout_s: float = 0.05
    attempts: int = 4
    obstacles_m: tuple = ()

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        _choice("robot.backend", self.backend, ROBOT_BACKENDS)
        if not isinstance(self.spec, str) or not self.spec:
            raise _fail("robot.spec", f"expected a robot name or spec file, got {self.spec!r}")
        set_(self, "port", _port("robot.port", self.port))
        if self.backend == "serial" and self.port is None:
            raise _fail("robot.port", "required when robot.backend = 'serial' (e.g. '/dev/ttyUSB0' or "
                                      "'armemu://armar3')")
        set_(self, "baudrate", _integer("robot.baudrate", self.baudrate, 1))
        set_(self, "control_rate_hz", _positive("robot.control_rate_hz", self.control_rate_hz))
        set_(self, "reply_timeout_s", _positive("robot.reply_timeout_s", self.reply_timeout_s))
        set_(self, "attempts", _integer("robot.attempts", self.attempts, 1, 100))
        set_(self, "obstacles_m", _boxes("robot.obstacles_m", self.obstacles_m))


@dataclass(frozen=True)
class SensorConfig:
    """``[sensor]``: the fingertip sensor backend.

    Attributes
    ----------
    backend : {"sim", "i2c", "uart", "mcu", "emulated"}
        ``i2c``: both chips on the I2C bus; ``uart``: BMP280 on I2C, BNO055 on its UART;
        ``mcu``: both behind a microcontroller streaming ``$T`` lines; ``emulated``: emulated
        chips pressed on a level table by a script (no hardware).
    bus : int
        I2C bus number (``/dev/i2c-<bus>``).
    bmp280_address, bno055_address : int
        I2C addresses (0x76/0x77 and 0x28/0x29).
    port : str or None
        Serial device or pyserial URL: the BNO055 UART (``uart``) or the microcontroller (``mcu``).
    baudrate : int or None
        Default 115200 for the BNO055 UART, 230400 for a microcontroller.
    imu_mode : str
        BNO055 fusion mode name.
    calibration : Path or None
        Calibration file written by ``sensor-monitor --calibrate``.
    read_timeout_s : float
        How long the first reading may take, seconds.
    """

    backend: str = "sim"
    bus: int = 1
    bmp280_address: int = 0x76
    bno055_address: int = 0x28
    port: str | None = None
    baudrate: int | None = None
    imu_mode: str = "NDOF"
    calibration: Path | None = None
    read_timeout_s: float = 1.0

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        _choice("sensor.backend", self.backend, SENSOR_BACKENDS)
        set_(self, "bus", _integer("sensor.bus", self.bus, 0))
        set_(self, "bmp280_address", _address("sensor.bmp280_address", self.bmp280_address, BMP280_ADDRESSES,
                                              "0x76 with SDO to GND, 0x77 with SDO to VDDIO"))
        set_(self, "bno055_address", _address("sensor.bno055_address", self.bno055_address, BNO055_ADDRESSES,
                                              "0x28 with COM3 low, 0x29 with COM3 high"))
        set_(self, "port", _port("sensor.port", self.port))
        if self.backend in ("uart", "mcu") and self.port is None:
            raise _fail("sensor.port", f"required when sensor.backend = {self.backend!r}")
        if self.baudrate is None:
            set_(self, "baudrate", MCU_DEFAULT_BAUD if self.backend == "mcu" else BNO055_UART_BAUD)
        set_(self, "baudrate", _integer("sensor.baudrate", self.baudrate, 1))
        _choice("sensor.imu_mode", self.imu_mode, FUSION_MODES)
        if self.calibration is not None:
            if not isinstance(self.calibration, (str, Path)) or not str(self.calibration):
                raise _fail("sensor.calibration", f"expected a file path, got {self.calibration!r}")
            set_(self, "calibration", Path(self.calibration))
        set_(self, "read_timeout_s", _positive("sensor.read_timeout_s", self.read_timeout_s))


@dataclass(frozen=True)
class ObjectConfig:
    """``[object]``: what is explored and roughly where.

    Attributes
    ----------
    name : str
        A label on hardware; in simulation the registry name or mesh file that is loaded.
    centre_m : (3,) float or None
        Rough centre, robot base frame, metres: the object frame's origin (its axes are the
        base axes). Default: the robot's workspace centre.
    half_extent_m : (3,) float or None
        Rough half size along each axis, metres (over-estimate; a number means all three).
        Required on hardware; in simulation it comes from the object's mesh, in emulation from
        the sphere.
    reference_mesh : Path or None
        The true surface, object frame (OBJ, STL or PLY, checked by :func:`objects.load`), for
        error metrics.
    units : str
        Length unit of ``reference_mesh`` and of a mesh file given as ``name``: "m" (default),
        "cm", "mm" or "in" (the ``--units`` flag of the commands).
    """

    name: str = "banana"
    centre_m: tuple[float, float, float] | None = None
    half_extent_m: tuple[float, float, float] | None = None
    reference_mesh: Path | None = None
    units: str = "m"

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        if not isinstance(self.name, str) or not self.name.strip():
            raise _fail("object.name", f"expected a non-empty name, got {self.name!r}")
        set_(self, "centre_m", _vector3("object.centre_m", self.centre_m))
        set_(self, "half_extent_m", _vector3("object.half_extent_m", self.half_extent_m, positive=True))
        if self.reference_mesh is not None:
            if not isinstance(self.reference_mesh, (str, Path)) or not str(self.reference_mesh):
                raise _fail("object.reference_mesh", f"expected a mesh file path, got {self.reference_mesh!r}")
            set_(self, "reference_mesh", Path(self.reference_mesh))
        if self.units not in MESH_UNITS:
            raise _fail("object.units", f"expected one of {', '.join(MESH_UNITS)}, got {self.units!r}")


@dataclass(frozen=True)
class ExplorationConfig:
    """``[exploration]``: the run's settings (see :class:`explorer.run.RunSettings`).

    Attributes
    ----------
    touches : int
    strategy : str
        One of :data:`STRATEGY_NAMES`.
    seed : int
    use_normals : bool
    eval_every : int
        Evaluate against the reference every this many touches (0: never).
    mesh_resolution : int
        Marching-cubes grid of the final mesh.
    reach_samples : int
        Surface samples of the reference sorted by why they were (not) touched
        (``metrics.json``'s ``reach_breakdown``); each asks the planner for up to a few IK solves,
        about 0.5 s where the arm cannot reach. 0 skips it (``python -m scripts.reach_report``
        computes it afterwards).
    probe_depth_m : float
        How far past its target a touch may probe before it counts as a miss, metres
        (:class:`explorer.planner.PlannerConfig`).
    """

    touches: int = 50
    strategy: str = "variance"
    seed: int = 0
    use_normals: bool = True
    eval_every: int = 5
    mesh_resolution: int = 96
    reach_samples: int = 64
    probe_depth_m: float = 0.15  # PlannerConfig's default (a test ties the two; not imported: kept light)

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "touches", _integer("exploration.touches", self.touches, 1))
        set_(self, "probe_depth_m", _number("exploration.probe_depth_m", self.probe_depth_m, 0.0, 1.0))
        _choice("exploration.strategy", self.strategy, STRATEGY_NAMES)
        set_(self, "seed", _integer("exploration.seed", self.seed, 0))
        if not isinstance(self.use_normals, bool):
            raise _fail("exploration.use_normals", f"expected true or false, got {self.use_normals!r}")
        set_(self, "eval_every", _integer("exploration.eval_every", self.eval_every, 0))
        set_(self, "mesh_resolution", _integer("exploration.mesh_resolution", self.mesh_resolution, 8, 512))
        set_(self, "reach_samples", _integer("exploration.reach_samples", self.reach_samples, 0))


@dataclass(frozen=True)
class EmulationConfig:
    """``[emulation]``: the virtual object of an emulated rig (``robot.backend = "emulated"``).

    Attributes
    ----------
    sphere_radius_m : float
    sphere_offset_m : (3,) float
        The sphere's true centre relative to ``object.centre_m`` (a rough location is rough).
    noise_pa : float
        Barometer noise, pascals (standard deviation).
    seed : int
    """

    sphere_radius_m: float = 0.05
    sphere_offset_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    noise_pa: float = 2.0
    seed: int = 0

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "sphere_radius_m", _positive("emulation.sphere_radius_m", self.sphere_radius_m))
        set_(self, "sphere_offset_m", _vector3("emulation.sphere_offset_m", self.sphere_offset_m))
        if isinstance(self.noise_pa, bool) or not isinstance(self.noise_pa, (int, float)) or not self.noise_pa >= 0:
            raise _fail("emulation.noise_pa", f"expected a number >= 0, got {self.noise_pa!r}")
        set_(self, "seed", _integer("emulation.seed", self.seed, 0))


@dataclass(frozen=True)
class SimulationConfig:
    """``[simulation]``: how imperfect the simulated robot and sensor are (``backend = "sim"``).

    Attributes
    ----------
    profile : str
        A profile name from :data:`explorer.sim_profile.PROFILES` or a TOML profile file (relative
        paths resolve against the configuration file).
    """

    profile: str = "datasheet-noise"

    def __post_init__(self) -> None:
        if not isinstance(self.profile, str) or not self.profile:
            raise _fail("simulation.profile", f"expected a profile name or .toml file, got {self.profile!r}")
        from explorer.sim_profile import PROFILES

        if self.profile not in PROFILES and not self.profile.lower().endswith(".toml"):
            raise _fail("simulation.profile", f"unknown profile {self.profile!r}: use one of "
                                              f"{', '.join(PROFILES)} or a .toml profile file")


@dataclass(frozen=True)
class BackendConfig:
    """The whole configuration.

    Attributes
    ----------
    robot : RobotConfig
    sensor : SensorConfig
    object : ObjectConfig
    exploration : ExplorationConfig
    emulation : EmulationConfig
    simulation : SimulationConfig
    source : Path or None
        The file it was read from.
    """

    robot: RobotConfig = field(default_factory=RobotConfig)
    sensor: SensorConfig = field(default_factory=SensorConfig)
    object: ObjectConfig = field(default_factory=ObjectConfig)
    exploration: ExplorationConfig = field(default_factory=ExplorationConfig)
    emulation: EmulationConfig = field(default_factory=EmulationConfig)
    simulation: SimulationConfig = field(default_factory=SimulationConfig)
    source: Path | None = None

    def __post_init__(self) -> None:
        if self.robot.backend == "emulated" and self.sensor.backend != "emulated":
            raise _fail("sensor.backend", f"robot.backend = 'emulated' needs sensor.backend = 'emulated' (the "
                                          f"emulated arm presses the emulated chips), got {self.sensor.backend!r}")


_SECTIONS = {"robot": RobotConfig, "sensor": SensorConfig, "object": ObjectConfig,
             "exploration": ExplorationConfig, "emulation": EmulationConfig, "simulation": SimulationConfig}


def config_from_dict(data: Any, base_dir: str | Path | None = None, source: Path | None = None) -> BackendConfig:
    """Check ``data`` (the parsed file) and build the config.

    Relative ``sensor.calibration`` paths are resolved against ``base_dir``. Missing sections
    and keys take their defaults; unknown ones are errors.
    """
    if not isinstance(data, dict):
        raise ValueError(f"a configuration must be a table/object with [robot] and [sensor], got {type(data).__name__}")
    _reject_unknown("", data, _SECTIONS)
    sections = {}
    for name, cls in _SECTIONS.items():
        section = data.get(name, {})
        if not isinstance(section, dict):
            raise _fail(name, f"must be a table of keys, got {section!r}")
        _reject_unknown(f"{name}.", section, {f.name for f in fields(cls)})
        sections[name] = cls(**section)
    sensor, target = sections["sensor"], sections["object"]
    if base_dir is not None:
        if sensor.calibration is not None and not sensor.calibration.is_absolute():
            sensor = _replace(sensor, calibration=Path(base_dir) / sensor.calibration)
        if target.reference_mesh is not None and not target.reference_mesh.is_absolute():
            target = _replace(target, reference_mesh=Path(base_dir) / target.reference_mesh)
    simulation = sections["simulation"]
    if base_dir is not None and simulation.profile.lower().endswith(".toml") \
            and not Path(simulation.profile).is_absolute():
        simulation = SimulationConfig(profile=str(Path(base_dir) / simulation.profile))
    if simulation.profile.lower().endswith(".toml"):
        from explorer.sim_profile import get_profile

        try:
            get_profile(simulation.profile)
        except ValueError as error:
            raise _fail("simulation.profile", str(error)) from None
    return BackendConfig(robot=sections["robot"], sensor=sensor, object=target,
                         exploration=sections["exploration"], emulation=sections["emulation"],
                         simulation=simulation, source=source)


def _replace(config, **changes):
    values = {f.name: getattr(config, f.name) for f in fields(config)}
    values.update(changes)
    return type(config)(**values)


def _reject_unknown(prefix: str, data: dict, known) -> None:
    for key in data:
        if key not in known:
            close = difflib.get_close_matches(str(key), list(known), n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else f"; known: {', '.join(sorted(known))}"
            raise ValueError(f"{prefix}{key}: unknown key{hint}")


def load_config(path: str | Path) -> BackendConfig:
    """Read a ``.toml`` or ``.json`` configuration file."""
    path = Path(path)
    try:
        text = path.read_text()
    except FileNotFoundError:
        raise FileNotFoundError(f"configuration file not found: {path}") from None
    suffix = path.suffix.lower()
    if suffix == ".json":
        try:
            data = json.loads(text)
        except json.JSONDecodeError as error:
            raise ValueError(f"{path} is not valid JSON: {error}") from None
    elif suffix == ".toml":
        data = _parse_toml(text, path)
    else:
        raise ValueError(f"{path}: configuration files must end in .toml or .json, not {suffix!r}")
    try:
        return config_from_dict(data, base_dir=path.resolve().parent, source=path)
    except ValueError as error:
        raise ValueError(f"{path}: {error}") from None


def _parse_toml(text: str, path: Path) -> dict:
    if sys.version_info >= (3, 11):
        import tomllib
    else:  # pragma: no cover - python 3.10
        try:
            import tomli as tomllib
        except ImportError:
            raise ImportError("reading TOML on Python 3.10 needs tomli (pip install tomli), or use a .json "
                              "configuration") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise ValueError(f"{path} is not valid TOML: {error}") from None
