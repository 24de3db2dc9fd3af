"""Simulation profiles: how imperfect the simulated robot and fingertip sensor are, by name.

A :class:`SimProfile` is every error parameter of a simulation in one frozen dataclass, units in
the field names. Three are built in:

* ``ideal``: no noise, bias, drift, friction in the spring or calibration error (the physics' own
  error and the chips' quantisation only);
* ``datasheet-noise``: the chips' data-sheet noise models (``sensor/sim/bno055.py``,
  ``sensor/sim/bmp280.py``), a frictionless spring and an exactly calibrated arm with 14-bit
  encoders; the default, and what every figure before issue 12 was measured with;
* ``hardware-like``: the errors of a real fingertip on a real humanoid arm, each from its physical
  cause; the pad's stiffness and the heading disturbance (within its measured range) are
  calibrated so that the sensor evaluation reproduces the reference sensor's accuracy (BENCHMARKS.md).

:data:`PARAMETER_SOURCES` gives the source of each ``hardware-like`` value (data sheet, the reference
work, a published measurement) or says that it is an assumption. A TOML file overrides single
parameters of a base profile (:func:`load_profile_file`)::

    base = "hardware-like"          # optional, default "datasheet-noise"
    name = "my-lab"                 # optional, default the file's stem
    joint_offset_std_deg = 0.2

Every random draw (joint offsets, chip biases) comes from the seed of the run, so a seed reproduces
a run exactly on one machine.
"""
from __future__ import annotations

import difflib
import math
import sys
from dataclasses import dataclass, fields, replace
from pathlib import Path

import numpy as np

from sensor.sim.bmp280 import BMP280Config, BMP280Noise
from sensor.sim.bno055 import (ACCEL_NOISE_DENSITY_MPS2_PER_SQRT_HZ, ACCEL_BANDWIDTH_HZ, STANDARD_GRAVITY_MPS2,
                               BNO055Config, BNO055Noise)
from sensor.sim.pad_drift import PadDrift
from sensor.sim_sensor import SimulatedSensorConfig

ENCODER_RESOLUTION_RAD = 2.0 * math.pi / 2**14
"""14-bit absolute joint encoders: 0.38 mrad, about 0.27 mm at the fingertip."""

DEFAULT_PROFILE = "datasheet-noise"

_DATASHEET_WHITE_DEG = math.degrees(ACCEL_NOISE_DENSITY_MPS2_PER_SQRT_HZ * math.sqrt(ACCEL_BANDWIDTH_HZ)
                                    / STANDARD_GRAVITY_MPS2)
_DATASHEET_TILT_BIAS_DEG = math.degrees(0.02 / STANDARD_GRAVITY_MPS2)


@dataclass(frozen=True)
class SimProfile:
    """Every error parameter of a simulation (see the module docstring; sources in
    :data:`PARAMETER_SOURCES`). Angles in degrees as named, torques in N m, times in seconds.

    Attributes
    ----------
    name : str
    spring_stiffness_nm_per_rad : float
        Bending stiffness of the coil spring per axis, N m/rad (0: the robot spec's). Its restoring
        torque at a tilt is what the pad's compliance has to hold.
    spring_friction_nm : float
        Coulomb friction (with stiction) torque of each spring joint, N m: the pad stops aligning
        once the contact torque left over by the spring falls inside this band.
    pad_lateral_friction : float
        Coulomb friction coefficient of the pad on the object (0: the robot spec's own value).
    pad_contact_stiffness_n_per_m : float
        Contact stiffness of the pad's face (0: as the caller builds the robot). A soft pad
        compresses unevenly under the spring's restoring torque, so the module stays tilted
        against the surface by that torque over the pad's rotational stiffness: more at larger tilt.
    imu_white_noise_deg : float
        White orientation noise per body axis and sample, degrees RMS.
    imu_tilt_bias_std_deg, imu_tilt_bias_time_constant_s : float
        Slowly varying tilt error of the fusion (RMS, degrees) and its correlation time.
    imu_heading_walk_deg_per_sqrt_s : float
        Heading random walk (gyroscope drift in IMU mode), deg/sqrt(s).
    imu_heading_offset_std_deg : float
        Constant heading error drawn at power-on (NDOF mode: the arm's motors disturb the
        magnetometer), degrees RMS.
    imu_latency_s : float
        Age of the pose each fused output reports, seconds.
    imu_mounting_std_deg : float
        Mounting misalignment of the chip against the pad face, per axis, degrees RMS.
    imu_accel_noise_scale : float
        Multiplier on the data-sheet accelerometer noise and bias (0: off).
    baro_noise_scale : float
        Multiplier on the BMP280's data-sheet RMS noise (0: off).
    baro_pressure_walk_pa_per_sqrt_s, baro_temperature_walk_k_per_sqrt_s : float
        Ambient pressure and chip temperature random walks.
    pad_creep_fraction, pad_creep_time_constant_s : float
        Creep of a held pressure rise (fraction, time constant).
    pad_thermal_pa_per_k, pad_contact_temperature_difference_k, pad_thermal_time_constant_s : float
        The sealed bubble's pressure per kelvin, the touched object's temperature minus the pad's,
        and the pad's thermal time constant.
    encoder_resolution_rad : float
        Joint encoder quantisation step, radians (0: none).
    encoder_noise_std_deg : float
        White noise of the joint encoders, degrees RMS.
    joint_offset_std_deg : float
        Kinematic calibration error: per-joint offset between encoder zero and the nominal model's
        zero, drawn per run, degrees RMS.
    encoder_backlash_deg : float
        Gear play between motor-side encoder and link, degrees (full width).
    link_length_std_mm : float
        Kinematic calibration error: each link length of the arm (:func:`robots.link_lengths.arm_link_lengths`)
        differs from the nominal model's by a draw of this RMS per run, millimetres. The simulator
        moves the true arm; the loop computes with the nominal one.
    """

    name: str
    spring_stiffness_nm_per_rad: float = 0.0
    spring_friction_nm: float = 0.0
    pad_lateral_friction: float = 0.0
    pad_contact_stiffness_n_per_m: float = 0.0
    imu_white_noise_deg: float = _DATASHEET_WHITE_DEG
    imu_tilt_bias_std_deg: float = _DATASHEET_TILT_BIAS_DEG
    imu_tilt_bias_time_constant_s: float = 60.0
    imu_heading_walk_deg_per_sqrt_s: float = 0.014
    imu_heading_offset_std_deg: float = 0.0
    imu_latency_s: float = 0.0
    imu_mounting_std_deg: float = 1.0
    imu_accel_noise_scale: float = 1.0
    baro_noise_scale: float = 1.0
    baro_pressure_walk_pa_per_sqrt_s: float = 0.4
    baro_temperature_walk_k_per_sqrt_s: float = 0.005
    pad_creep_fraction: float = 0.0
    pad_creep_time_constant_s: float = 1.0
    pad_thermal_pa_per_k: float = 0.0
    pad_contact_temperature_difference_k: float = 0.0
    pad_thermal_time_constant_s: float = 140.0
    encoder_resolution_rad: float = ENCODER_RESOLUTION_RAD
    encoder_noise_std_deg: float = 0.0
    joint_offset_std_deg: float = 0.0
    encoder_backlash_deg: float = 0.0
    link_length_std_mm: float = 0.0

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise ValueError(f"profile name must be a non-empty string, got {self.name!r}")
        for f in fields(self):
            if f.name == "name":
                continue
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, (int, float)):
                raise ValueError(f"profile {self.name!r}: {f.name} must be a number, got {value!r}")
            if not math.isfinite(value):
                raise ValueError(f"profile {self.name!r}: {f.name} must be finite, got {value!r}")
            signed = f.name == "pad_contact_temperature_difference_k"
            positive = f.name.endswith("time_constant_s")
            if positive and not value > 0.0:
                raise ValueError(f"profile {self.name!r}: {f.name} must be > 0, got {value!r}")
            if not signed and value < 0.0:
                raise ValueError(f"profile {self.name!r}: {f.name} must be >= 0, got {value!r}")
            object.__setattr__(self, f.name, float(value))

    # ---- what the simulation is built from ----------------------------------------------------

    def sensor_config(self) -> SimulatedSensorConfig:
        """Both chips' settings for this profile."""
        accel = self.imu_accel_noise_scale
        imu_noise = BNO055Noise(
            accel_noise_density_mps2_per_sqrt_hz=accel * ACCEL_NOISE_DENSITY_MPS2_PER_SQRT_HZ,
            accel_bias_std_mps2=accel * 0.02,
            orientation_white_std_rad=math.radians(self.imu_white_noise_deg),
            yaw_random_walk_rad_per_sqrt_s=math.radians(self.imu_heading_walk_deg_per_sqrt_s),
            tilt_bias_std_rad=math.radians(self.imu_tilt_bias_std_deg),
            tilt_bias_time_constant_s=self.imu_tilt_bias_time_constant_s,
            mounting_misalignment_std_rad=math.radians(self.imu_mounting_std_deg),
            heading_offset_std_rad=math.radians(self.imu_heading_offset_std_deg),
        )
        baro_noise = BMP280Noise(
            white_noise_scale=self.baro_noise_scale,
            pressure_random_walk_pa_per_sqrt_s=self.baro_pressure_walk_pa_per_sqrt_s,
            temperature_random_walk_k_per_sqrt_s=self.baro_temperature_walk_k_per_sqrt_s,
        )
        drift = PadDrift(
            creep_fraction=self.pad_creep_fraction,
            creep_time_constant_s=self.pad_creep_time_constant_s,
            thermal_pa_per_k=self.pad_thermal_pa_per_k,
            contact_temperature_difference_k=self.pad_contact_temperature_difference_k,
            thermal_time_constant_s=self.pad_thermal_time_constant_s,
        )
        return SimulatedSensorConfig(imu=BNO055Config(noise=imu_noise, latency_s=self.imu_latency_s),
                                     barometer=BMP280Config(noise=baro_noise, pad_drift=drift))

    def joint_offsets_rad(self, dof: int, seed: int) -> np.ndarray:
        """The run's kinematic calibration error, (dof,) radians, drawn from ``seed``."""
        if self.joint_offset_std_deg == 0.0:
            return np.zeros(dof)
        rng = np.random.default_rng([int(seed), 12])  # its own stream: other draws do not shift it
        return math.radians(self.joint_offset_std_deg) * rng.standard_normal(dof)

    def encoder_model(self, dof: int, seed: int):
        """The arm's :class:`robots.sim_arm.EncoderModel` for a run seeded with ``seed``."""
        from robots.sim_arm import EncoderModel

        offsets = self.joint_offsets_rad(dof, seed)
        return EncoderModel(noise_std_rad=math.radians(self.encoder_noise_std_deg),
                            resolution_rad=self.encoder_resolution_rad, seed=seed,
                            offset_rad=tuple(offsets) if np.any(offsets) else (),
                            backlash_rad=math.radians(self.encoder_backlash_deg))

    def link_length_errors_m(self, spec, seed: int) -> dict[str, float]:
        """The run's link-length errors (joint name -> metres) of ``spec``'s arm, drawn from ``seed``."""
        if self.link_length_std_mm == 0.0:
            return {}
        from robots.link_lengths import arm_link_lengths

        links = arm_link_lengths(spec)
        rng = np.random.default_rng([int(seed), 13])  # its own stream, like the joint offsets
        draws = 1e-3 * self.link_length_std_mm * rng.standard_normal(len(links))
        return {link.joint: float(d) for link, d in zip(links, draws)}

    def robot_spec(self, spec):
        """``spec`` (a :class:`robots.spec.RobotSpec`) with this profile's pad friction and stiffness, if set."""
        if self.pad_lateral_friction:
            spec = replace(spec, pad_lateral_friction=self.pad_lateral_friction)
        if self.pad_contact_stiffness_n_per_m:
            spec = replace(spec, pad_contact_stiffness_n_per_m=self.pad_contact_stiffness_n_per_m)
        if self.spring_stiffness_nm_per_rad:
            spec = replace(spec, spring_stiffness_nm_per_rad=self.spring_stiffness_nm_per_rad)
        return spec

    def changed_parameters(self) -> dict[str, float]:
        """Parameters that differ from ``datasheet-noise``, for metadata and tables."""
        base = PROFILES[DEFAULT_PROFILE]
        return {f.name: getattr(self, f.name) for f in fields(self)
                if f.name != "name" and getattr(self, f.name) != getattr(base, f.name)}


def _ideal() -> SimProfile:
    return SimProfile(
        name="ideal", imu_white_noise_deg=0.0, imu_tilt_bias_std_deg=0.0, imu_heading_walk_deg_per_sqrt_s=0.0,
        imu_mounting_std_deg=0.0, imu_accel_noise_scale=0.0, baro_noise_scale=0.0,
        baro_pressure_walk_pa_per_sqrt_s=0.0, baro_temperature_walk_k_per_sqrt_s=0.0, encoder_resolution_rad=0.0,
    )


HARDWARE_LIKE = SimProfile(
    name="hardware-like",
    spring_friction_nm=1.0e-3,
    pad_contact_stiffness_n_per_m=500.0,
    imu_tilt_bias_std_deg=0.5,
    imu_heading_offset_std_deg=4.0,
    imu_latency_s=0.02,
    pad_creep_fraction=0.1,
    pad_creep_time_constant_s=1.0,
    pad_thermal_pa_per_k=110.0,
    pad_contact_temperature_difference_k=-5.0,
    joint_offset_std_deg=0.5,
    encoder_backlash_deg=0.1,
    link_length_std_mm=0.5,
)

PROFILES: dict[str, SimProfile] = {
    "ideal": _ideal(),
    "datasheet-noise": SimProfile(name="datasheet-noise"),
    "hardware-like": HARDWARE_LIKE,
}

PARAMETER_SOURCES: dict[str, str] = {
    "spring_stiffness_nm_per_rad": "0: the robot spec's 0.02 N m/rad kept (robots/fingertip.py); 0.03 was tried "
                                   "and jams the pad at 40 deg (the simulator's stability bound is ~0.035)",
    "spring_friction_nm": "assumption: a coil spring's inter-coil and mount friction, 1e-3 N m, 5 % of the "
                          "spring torque at 50 deg: hysteresis of about +-0.5 deg on the soft pad",
    "pad_lateral_friction": "0: the robot spec's 0.4 kept; measured in tuning: 0.8 jams the pad at 50 deg "
                            "tilt in every press (32 deg error), 0.5 at 40-50 deg in some",
    "pad_contact_stiffness_n_per_m": "calibrated: per contact point (PyBullet puts one at each of the face's 4 "
                                     "corners), a soft cast pad: 0.76 mm per newton on a flat plate as "
                                     "measured (robots/pad_compliance.py; the loop's compliance), more on "
                                     "curved surfaces and edges (fewer contact points); "
                                     "its rotational stiffness against the spring's torque sets how far the "
                                     "module stays tilted, growing with the tilt",
    "imu_white_noise_deg": "BNO055 data sheet Table 0-2 and 3-4: 150 ug/sqrt(Hz) x sqrt(62.5 Hz) / g",
    "imu_tilt_bias_std_deg": "assumption: residual accelerometer offset of a consumer IMU after the "
                             "fusion's calibration, ~0.1 g-percent; users report ~0.5-1 deg static tilt error",
    "imu_tilt_bias_time_constant_s": "assumption (as datasheet-noise)",
    "imu_heading_walk_deg_per_sqrt_s": "BNO055 data sheet Table 0-2: gyroscope noise density 0.014 deg/s/sqrt(Hz)",
    "imu_heading_offset_std_deg": "published measurement: BNO055 heading repeatability about +-3 deg (1 sigma) "
                                  "on a turntable away from motors (Adafruit forum, t=112315); 4 deg assumed "
                                  "beside the arm's motors in NDOF mode; calibrated within that range",
    "imu_latency_s": "assumption: two 100 Hz fusion periods (Table 3-14) between motion and output",
    "imu_mounting_std_deg": "assumption from assembly tolerances (sensor/sim/bno055.py); calibrated away by "
                            "sensor-monitor --calibrate",
    "imu_accel_noise_scale": "BNO055 data sheet (as datasheet-noise)",
    "baro_noise_scale": "BMP280 data sheet Table 8 (as datasheet-noise)",
    "baro_pressure_walk_pa_per_sqrt_s": "assumption: indoor ambient pressure drift (as datasheet-noise)",
    "baro_temperature_walk_k_per_sqrt_s": "assumption (as datasheet-noise); 1.5 Pa/K from the data sheet",
    "pad_creep_fraction": "assumption: polyurethane elastomers creep by several percent within seconds",
    "pad_creep_time_constant_s": "assumption",
    "pad_thermal_pa_per_k": "physics: sealed air bubble dP/dT = P/T = 340 Pa/K, a third of it assumed to "
                            "reach the chip through the compliant pad",
    "pad_contact_temperature_difference_k": "assumption: the fingertip warmed 5 K above the object by the hand's "
                                            "electronics and motors",
    "pad_thermal_time_constant_s": "physics: (3.7 mm)^2 / 1e-7 m^2/s thermal diffusivity of polyurethane",
    "encoder_resolution_rad": "14-bit absolute joint encoders (as datasheet-noise)",
    "encoder_noise_std_deg": "0: absolute encoders are noiseless at this scale",
    "joint_offset_std_deg": "assumption: 0.5 deg per joint, about 1 cm at the fingertip of a 0.6 m arm; "
                            "uncalibrated humanoid arms deviate from their nominal kinematics by 1-6 cm "
                            "(Agile Justin 61 mm worst case, Tenhumberg et al. 2023, arXiv:2311.08338)",
    "encoder_backlash_deg": "assumption: harmonic-drive lost motion of a few arcmin (0.1 deg)",
    "link_length_std_mm": "assumption: 0.5 mm RMS per link (upper arm, forearm, hand; ARMAR-6 also the "
                          "shoulder offset), machining and assembly tolerance of bolted aluminium links; "
                          "smaller at the fingertip than the joint offsets' ~1 cm, as in arm calibrations "
                          "where the angle offsets dominate",
}


def profile_names() -> tuple[str, ...]:
    return tuple(PROFILES)


def get_profile(name_or_path: str | Path | SimProfile | None) -> SimProfile:
    """A built-in profile by name, or a TOML profile file (path ending in .toml).

    Raises
    ------
    ValueError
        Unknown name (the message names the known ones), or a bad file.
    """
    if name_or_path is None:
        return PROFILES[DEFAULT_PROFILE]
    if isinstance(name_or_path, SimProfile):
        return name_or_path
    text = str(name_or_path)
    if text in PROFILES:
        return PROFILES[text]
    if text.lower().endswith(".toml"):
        return load_profile_file(text)
    close = difflib.get_close_matches(text, list(PROFILES), n=1)
    hint = f" (did you mean {close[0]!r}?)" if close else ""
    raise ValueError(f"unknown simulation profile {text!r}{hint}: use one of {', '.join(PROFILES)} or a .toml "
                     "profile file")


def profile_from_dict(data: dict, default_name: str = "custom") -> SimProfile:
    """A profile from a table: optional ``base`` and ``name``, then parameter overrides."""
    if not isinstance(data, dict):
        raise ValueError(f"a profile must be a table of parameters, got {type(data).__name__}")
    data = dict(data)
    base_name = data.pop("base", DEFAULT_PROFILE)
    if base_name not in PROFILES:
        raise ValueError(f"base: unknown profile {base_name!r}; use one of {', '.join(PROFILES)}")
    name = data.pop("name", default_name)
    known = [f.name for f in fields(SimProfile) if f.name != "name"]
    for key in data:
        if key not in known:
            close = difflib.get_close_matches(str(key), known, n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise ValueError(f"{key}: unknown profile parameter{hint}")
    return replace(PROFILES[base_name], name=name, **data)


def load_profile_file(path: str | Path) -> SimProfile:
    """Read a TOML profile file (module docstring); errors name the file and the bad key."""
    path = Path(path)
    if sys.version_info >= (3, 11):
        import tomllib
    else:  # pragma: no cover
        import tomli as tomllib
    try:
        data = tomllib.loads(path.read_text())
    except FileNotFoundError:
        raise ValueError(f"profile file not found: {path}") from None
    except tomllib.TOMLDecodeError as error:
        raise ValueError(f"{path}: not valid TOML: {error}") from None
    try:
        return profile_from_dict(data, default_name=path.stem)
    except (TypeError, ValueError) as error:
        raise ValueError(f"{path}: {error}") from None


def format_parameter_table(profiles: tuple[SimProfile, ...] | None = None) -> str:
    """Markdown table: every parameter under each profile, with the hardware-like source."""
    profiles = profiles or tuple(PROFILES.values())
    lines = ["| parameter | " + " | ".join(p.name for p in profiles) + " | source of the hardware-like value |",
             "|---|" + "---|" * len(profiles) + "---|"]
    for f in fields(SimProfile):
        if f.name == "name":
            continue
        values = " | ".join(f"{getattr(p, f.name):.4g}" for p in profiles)
        lines.append(f"| {f.name} | {values} | {PARAMETER_SOURCES.get(f.name, '')} |")
    return "\n".join(lines)
