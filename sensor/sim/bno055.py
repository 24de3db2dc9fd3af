"""Simulated Bosch BNO055 IMU in a fusion mode (IMU / NDOF): orientation, linear acceleration, gravity.

Figures from the BNO055 data sheet (Bosch Sensortec, BST-BNO055-DS000, rev. 1.4):

- Table 0-2 (electrical characteristics): accelerometer output noise density 150 ug/sqrt(Hz),
  gyroscope output noise density 0.014 deg/s/sqrt(Hz).
- Table 3-4 (section 3.3): default sensor settings in fusion, accelerometer 4 g range with 62.5 Hz
  bandwidth, gyroscope 2000 deg/s with 32 Hz bandwidth.
- Table 3-14 (section 3.6.3): fusion data output rate 100 Hz in IMU and NDOF modes.
- Table 3-31 (section 3.6.5.5): quaternion output, 1 = 2^14 LSB.
- Tables 3-33 and 3-35 (sections 3.6.5.6-7): linear acceleration and gravity vector, 1 m/s^2 = 100 LSB.

The data sheet gives no accuracy figure for the fused orientation, so its error model is derived
from the sensor figures above and stated assumptions:

- white orientation noise, a small random rotation in the body frame per sample, with the tilt
  noise an accelerometer-aided filter would see unfiltered: 150 ug/sqrt(Hz) * sqrt(62.5 Hz) / 1 g
  = 1.19 mrad (0.068 deg) per axis;
- heading (yaw about the world vertical) drifts as the integral of gyroscope noise: a random walk of
  0.014 deg/sqrt(s), as in IMU mode where nothing observes heading;
- tilt (about the world horizontal axes) has a slowly varying bias bounded by gravity: an
  Ornstein-Uhlenbeck process whose RMS equals the residual accelerometer bias / g (assumed 0.02 m/s^2
  after calibration, i.e. 0.12 deg) with an assumed 60 s correlation time;
- the chip is not mounted exactly parallel to the pad face: a constant rotation between the sensor
  body frame (the pad face) and the chip's axes, drawn at power-on, 1 deg RMS per axis by default.
  It is an assembly tolerance, not a chip figure: solder-joint height differences under the 3.8 mm
  LGA package (~20 um, 0.3 deg), the sensing elements' alignment in the package (cross-axis
  sensitivity of about 1 %, 0.6 deg) and the hand-cast 3.7 mm polyurethane pad, whose face is
  parallel to the PCB only to ~0.25 mm across 18 mm (0.8 deg); root-sum-square about 1 deg.
  Calibration removes it on hardware (``sensor.normal_estimation.ImuAlignment.body_in_imu_wxyz``);
  an uncalibrated sensor reads every surface normal tilted by it;
- in NDOF mode the heading comes from the magnetometer, which the arm's motors and steel disturb:
  a constant heading error drawn at power-on (``heading_offset_std_rad``, 0 by default: the
  default models IMU mode, whose heading only drifts);
- the fused output lags the motion (``BNO055Config.latency_s``, 0 by default): each sample
  reports the pose that was true that long ago.

Output conventions follow the chip: the quaternion rotates sensor-frame vectors into the world frame;
gravity is what the accelerometer reads at rest, +9.81 m/s^2 along the world's up axis, expressed in
the sensor frame; linear acceleration = accelerometer reading - gravity estimate, sensor frame.
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.spatial.transform import Rotation

from common.pad_state import PadState
from common.rotations import (quat_from_rotvec_wxyz, quat_multiply_wxyz, quat_normalised_wxyz,
                              quat_rotate_inverse_wxyz, wxyz_from_rotation)
from sensor.sim.sampling import SampleClock

STANDARD_GRAVITY_MPS2 = 9.80665
#: Table 0-2: accelerometer output noise density, (m/s^2)/sqrt(Hz).
ACCEL_NOISE_DENSITY_MPS2_PER_SQRT_HZ = 150e-6 * STANDARD_GRAVITY_MPS2
#: Table 0-2: gyroscope output noise density, (rad/s)/sqrt(Hz).
GYRO_NOISE_DENSITY_RADPS_PER_SQRT_HZ = math.radians(0.014)
#: Table 3-4: accelerometer bandwidth in fusion modes, hertz.
ACCEL_BANDWIDTH_HZ = 62.5
#: Table 3-14: fusion output data rate, hertz.
FUSION_RATE_HZ = 100.0
#: Table 3-31: quaternion LSB.
QUATERNION_LSB = 2.0**-14
#: Tables 3-33, 3-35: linear acceleration and gravity LSB, m/s^2.
ACCELERATION_LSB_MPS2 = 0.01

_ASSUMED_ACCEL_BIAS_MPS2 = 0.02
_ASSUMED_MOUNTING_MISALIGNMENT_RAD = math.radians(1.0)


@dataclass(frozen=True)
class BNO055Noise:
    """Noise, bias and drift of the fused outputs (module docstring gives the derivations).

    Attributes
    ----------
    accel_noise_density_mps2_per_sqrt_hz : float
        White accelerometer noise density, (m/s^2)/sqrt(Hz); per-sample RMS is this times
        sqrt(bandwidth).
    accel_bias_std_mps2 : float
        RMS of a constant per-axis accelerometer bias drawn at power-on, m/s^2.
    orientation_white_std_rad : float
        RMS per body axis of the white orientation error rotation, radians.
    yaw_random_walk_rad_per_sqrt_s : float
        Heading random walk about the world vertical, rad/sqrt(s).
    tilt_bias_std_rad : float
        Stationary RMS per horizontal world axis of the slowly varying tilt bias, radians.
    tilt_bias_time_constant_s : float
        Correlation time of the tilt bias, seconds.
    mounting_misalignment_std_rad : float
        RMS per axis of the constant rotation from the sensor body (pad face) frame to the chip's
        axes, drawn at power-on, radians (module docstring: assembly tolerances, ~1 deg).
    heading_offset_std_rad : float
        RMS of a constant heading error about the world vertical, drawn at power-on, radians
        (NDOF mode near motors; 0: IMU mode).
    """

    accel_noise_density_mps2_per_sqrt_hz: float = ACCEL_NOISE_DENSITY_MPS2_PER_SQRT_HZ
    accel_bias_std_mps2: float = _ASSUMED_ACCEL_BIAS_MPS2
    orientation_white_std_rad: float = (ACCEL_NOISE_DENSITY_MPS2_PER_SQRT_HZ * math.sqrt(ACCEL_BANDWIDTH_HZ)
                                        / STANDARD_GRAVITY_MPS2)
    yaw_random_walk_rad_per_sqrt_s: float = GYRO_NOISE_DENSITY_RADPS_PER_SQRT_HZ
    tilt_bias_std_rad: float = _ASSUMED_ACCEL_BIAS_MPS2 / STANDARD_GRAVITY_MPS2
    tilt_bias_time_constant_s: float = 60.0
    mounting_misalignment_std_rad: float = _ASSUMED_MOUNTING_MISALIGNMENT_RAD
    heading_offset_std_rad: float = 0.0

    def __post_init__(self) -> None:
        for name, value in vars(self).items():
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"{name} must be finite and >= 0, got {value}")
        if self.tilt_bias_time_constant_s == 0.0:
            raise ValueError("tilt_bias_time_constant_s must be > 0 s")

    @classmethod
    def off(cls) -> "BNO055Noise":
        """No noise, bias, drift or mounting misalignment."""
        return cls(accel_noise_density_mps2_per_sqrt_hz=0.0, accel_bias_std_mps2=0.0, orientation_white_std_rad=0.0,
                   yaw_random_walk_rad_per_sqrt_s=0.0, tilt_bias_std_rad=0.0, mounting_misalignment_std_rad=0.0)


@dataclass(frozen=True)
class BNO055Config:
    """Settings of the simulated IMU.

    Attributes
    ----------
    output_rate_hz : float
        Fusion output data rate, hertz (Table 3-14: 100 Hz).
    accel_bandwidth_hz : float
        Accelerometer bandwidth, hertz (Table 3-4: 62.5 Hz); sets the per-sample noise.
    gravity_mps2 : float
        Magnitude of gravity, m/s^2.
    noise : BNO055Noise
        Noise, bias and drift; ``BNO055Noise.off()`` for noise-free runs.
    quantise : bool
        Round outputs to the chip's LSBs (quaternion 2^-14, accelerations 0.01 m/s^2).
    latency_s : float
        Age of the pose a fused sample reports, seconds (0: none).
    """

    output_rate_hz: float = FUSION_RATE_HZ
    accel_bandwidth_hz: float = ACCEL_BANDWIDTH_HZ
    gravity_mps2: float = STANDARD_GRAVITY_MPS2
    noise: BNO055Noise = field(default_factory=BNO055Noise)
    quantise: bool = True
    latency_s: float = 0.0

    def __post_init__(self) -> None:
        for name in ("output_rate_hz", "accel_bandwidth_hz", "gravity_mps2"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"{name} must be finite and > 0, got {value}")
        if not (math.isfinite(self.latency_s) and self.latency_s >= 0.0):
            raise ValueError(f"latency_s must be finite and >= 0 s, got {self.latency_s}")

    @property
    def accel_noise_std_mps2(self) -> float:
        """Per-sample, per-axis accelerometer noise RMS, m/s^2."""
        return self.noise.accel_noise_density_mps2_per_sqrt_hz * math.sqrt(self.accel_bandwidth_hz)

    def noiseless(self) -> "BNO055Config":
        """The same settings with noise, bias and drift switched off (quantisation kept)."""
        return replace(self, noise=BNO055Noise.off())


@dataclass(frozen=True)
class ImuSample:
    """One fused IMU output.

    Attributes
    ----------
    t_s : float
        Simulation time of the sample, seconds.
    quat_wxyz : (4,) float
        Estimated sensor orientation in the world frame, unit quaternion (w, x, y, z).
    lin_acc_mps2 : (3,) float
        Linear acceleration without gravity, sensor frame, m/s^2.
    gravity_mps2 : (3,) float
        Gravity as the accelerometer reads it (pointing up), sensor frame, m/s^2.
    """

    t_s: float
    quat_wxyz: np.ndarray
    lin_acc_mps2: np.ndarray
    gravity_mps2: np.ndarray


class SimulatedBNO055:
    """Fused IMU outputs at the fusion rate, from the true pad pose and velocity.

    Call :meth:`step` after every physics step (or at least on the steps where
    :meth:`needs_pad_state` is True: the others change nothing); it returns an :class:`ImuSample`
    on the steps where a fusion output falls due, else None. Linear acceleration is the mean acceleration since the
    previous sample (finite difference of the true velocity), so the first sample reports zero.

    Parameters
    ----------
    config : BNO055Config
        Chip settings.
    rng : numpy.random.Generator
        Source of all randomness of this chip.

    Attributes
    ----------
    mounting : scipy.spatial.transform.Rotation
        The chip's axes in the sensor body frame, drawn at power-on (identity without
        misalignment): the chip measures the orientation of ``R_body * mounting``.
    """

    def __init__(self, config: BNO055Config, rng: np.random.Generator) -> None:
        self.config = config
        self._rng = rng
        self._clock = SampleClock(1.0 / config.output_rate_hz)
        noise = config.noise
        self._accel_bias_mps2 = noise.accel_bias_std_mps2 * rng.standard_normal(3)
        self._tilt_bias_rad = tuple((noise.tilt_bias_std_rad * rng.standard_normal(2)).tolist())
        self.mounting = Rotation.from_rotvec(noise.mounting_misalignment_std_rad * rng.standard_normal(3))
        self._mounting_wxyz = tuple(float(v) for v in wxyz_from_rotation(self.mounting))
        # Drawn last and only when on, so that profiles without it keep their earlier random streams.
        self._yaw_bias_rad = float(noise.heading_offset_std_rad * rng.standard_normal()) if noise.heading_offset_std_rad else 0.0
        self._accel_noise_std_mps2 = config.accel_noise_std_mps2
        self._history: deque[PadState] = deque()
        self._last_t: float | None = None
        self._last_velocity_mps: np.ndarray | None = None

    def needs_pad_state(self, t_s: float) -> bool:
        """Whether :meth:`step` must see the pad's state at ``t_s``: a sample falls due then, or the
        latency history keeps every step. Where False, leaving the step out changes nothing."""
        return self.config.latency_s > 0.0 or self._clock.would_be_due(t_s)

    def step(self, pad_state: PadState) -> ImuSample | None:
        """Advance to ``pad_state.t_s``; return a fused output if one is due."""
        now = pad_state.t_s
        if self.config.latency_s > 0.0:
            self._history.append(pad_state)
            while len(self._history) > 1 and self._history[1].t_s <= now - self.config.latency_s:
                self._history.popleft()
        if not self._clock.due(now):
            return None
        return self._measure(self._history[0] if self.config.latency_s > 0.0 else pad_state, now)

    def _measure(self, pad_state: PadState, t: float) -> ImuSample:
        # Plain-float quaternion algebra (common.rotations): the compositions of scipy's Rotation
        # (tests/test_rotations_fast.py compares the two), a sample in microseconds.
        vx, vy, vz = np.asarray(pad_state.lin_vel_mps, dtype=float).tolist()
        if self._last_t is None:
            ax = ay = az = 0.0
        else:
            dt = t - self._last_t
            lx, ly, lz = self._last_velocity_mps
            ax, ay, az = (vx - lx) / dt, (vy - ly) / dt, (vz - lz) / dt
            self._advance_bias(dt)
        self._last_t = t
        self._last_velocity_mps = (vx, vy, vz)

        noise = self.config.noise
        pad_quat = np.asarray(pad_state.quat_wxyz, dtype=float).tolist()
        chip = quat_multiply_wxyz(quat_normalised_wxyz(pad_quat), self._mounting_wxyz)
        error_world = quat_from_rotvec_wxyz(self._tilt_bias_rad[0], self._tilt_bias_rad[1], self._yaw_bias_rad)
        ex, ey, ez = (noise.orientation_white_std_rad * self._rng.standard_normal(3)).tolist()
        measured = quat_multiply_wxyz(quat_multiply_wxyz(error_world, chip), quat_from_rotvec_wxyz(ex, ey, ez))
        g = self.config.gravity_mps2
        fx, fy, fz = quat_rotate_inverse_wxyz(chip, (ax, ay, az + g))
        bias = self._accel_bias_mps2
        nx, ny, nz = (bias + self._accel_noise_std_mps2 * self._rng.standard_normal(3)).tolist()
        gravity = quat_rotate_inverse_wxyz(measured, (0.0, 0.0, g))
        lin_acc = (fx + nx - gravity[0], fy + ny - gravity[1], fz + nz - gravity[2])

        qw, qx, qy, qz = pad_quat
        if measured[0] * qw + measured[1] * qx + measured[2] * qy + measured[3] * qz < 0.0:
            measured = tuple(-v for v in measured)  # keep the caller's hemisphere: no sign jumps
        if self.config.quantise:  # round() of a float is round-half-even, as numpy's rint
            quat = np.array([round(v / QUATERNION_LSB) * QUATERNION_LSB for v in measured])
            quat /= np.linalg.norm(quat)
            lsb = ACCELERATION_LSB_MPS2
            gravity = tuple(round(v / lsb) * lsb + 0.0 for v in gravity)  # + 0.0: no -0.0
            lin_acc = tuple(round(v / lsb) * lsb + 0.0 for v in lin_acc)
        else:
            quat = np.array(measured)
        return ImuSample(t_s=t, quat_wxyz=quat, lin_acc_mps2=np.array(lin_acc), gravity_mps2=np.array(gravity))

    def _advance_bias(self, dt: float) -> None:
        noise = self.config.noise
        self._yaw_bias_rad += noise.yaw_random_walk_rad_per_sqrt_s * math.sqrt(dt) * float(self._rng.standard_normal())
        keep = math.exp(-dt / noise.tilt_bias_time_constant_s)
        scale = noise.tilt_bias_std_rad * math.sqrt(1.0 - keep * keep)
        tx, ty = self._tilt_bias_rad
        dx, dy = self._rng.standard_normal(2).tolist()
        self._tilt_bias_rad = (keep * tx + scale * dx, keep * ty + scale * dy)
