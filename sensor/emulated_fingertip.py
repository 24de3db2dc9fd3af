"""An emulated fingertip pressed on a level table by a script: the hardware sensor stack without hardware.

The BMP280 and BNO055 chip emulators (:mod:`sensor.emulators`) sit on a fake I2C bus and are read
by the real drivers through :class:`sensor.drivers.HardwareTactileSensor`; before every poll the
script sets what the chips measure at that moment. This is what ``sensor-monitor --emulate`` shows
and what the calibration is tested against: the true mounting offset of the IMU is known here.

Geometry: pressed flat on the table, the sensor body's +z axis points straight down (into the
table, world -z), turned by the press's yaw about world z. Free, the pad hangs tilted in its
spring by ``free_tilt_rad``; after touching it aligns within ``align_s``, up to a small random
residual tilt (``align_error_rad``, the spring's imperfection). The IMU reports
``R_world_imu = R_world_body @ R(body_in_imu)^-1`` (see :class:`sensor.normal_estimation.ImuAlignment`)
with white orientation noise.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from scipy.spatial.transform import Rotation

from sensor.drivers.bmp280 import BMP280
from sensor.drivers.bno055 import BNO055I2C
from sensor.drivers.hardware_sensor import ChipSource, HardwareTactileSensor
from sensor.drivers.bno055_registers import OperationMode
from sensor.emulators.bmp280_chip import BMP280Chip
from sensor.emulators.bno055_chip import BNO055Chip
from sensor.emulators.fake_smbus import FakeSMBus
from common.rotations import rotation_from_wxyz, wxyz_from_rotation

GRAVITY_MPS2 = 9.80665
BMP280_ADDRESS = 0x76
BNO055_ADDRESS = 0x28
_FLAT = Rotation.from_rotvec([math.pi, 0.0, 0.0])  # body +z pointing down


@dataclass(frozen=True)
class Press:
    """One press of the pad on the table.

    Attributes
    ----------
    start_s : float
        Script time of the touch, seconds.
    duration_s : float
        Time from touch to release, seconds.
    rise_pa : float
        Pressure rise while pressed, pascals.
    yaw_rad : float
        Sensor body yaw about world z during the press, radians.
    residual_tilt_rad : (2,) float
        Tilt (about world x, y) left after the pad has aligned, radians.
    """

    start_s: float
    duration_s: float
    rise_pa: float
    yaw_rad: float
    residual_tilt_rad: tuple[float, float] = (0.0, 0.0)

    @property
    def end_s(self) -> float:
        return self.start_s + self.duration_s


@dataclass(frozen=True)
class PressScript:
    """What the chips measure over time: baseline with drift, presses, orientation.

    Attributes
    ----------
    presses : tuple of Press
        In time order, not overlapping.
    baseline_pa : float
        Free-pad pressure at script time 0, pascals.
    drift_pa_per_s : float
        Slow baseline drift (temperature, pad creep), Pa/s.
    noise_pa : float
        Barometer white noise per conversion, pascals.
    ramp_s : float
        Pressure rise and fall time of a press, seconds.
    align_s : float
        Time the pad takes to align flat after touching, seconds.
    free_tilt_rad : float
        Tilt of the free pad hanging in its spring, radians.
    imu_noise_rad : float
        Orientation white noise per IMU sample and axis, radians.
    body_in_imu_wxyz : (4,) float
        The IMU's true mounting offset (what calibration must recover).
    tail_s : float
        Free time after the last press, seconds.
    seed : int
        Seed of the IMU noise.
    """

    presses: tuple[Press, ...]
    baseline_pa: float = 100_900.0
    drift_pa_per_s: float = 0.3
    noise_pa: float = 2.0
    ramp_s: float = 0.04
    align_s: float = 0.08
    free_tilt_rad: float = math.radians(8.0)
    imu_noise_rad: float = math.radians(0.05)
    body_in_imu_wxyz: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)
    tail_s: float = 1.0
    seed: int = 0
    _mounting: Rotation = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        presses = tuple(self.presses)
        for earlier, later in zip(presses, presses[1:]):
            if later.start_s < earlier.end_s:
                raise ValueError(f"presses overlap or are out of order: {earlier} then {later}")
        for press in presses:
            if not (press.duration_s > 2 * self.ramp_s and press.start_s >= 0.0):
                raise ValueError(f"a press must start at >= 0 s and last longer than two ramps: {press}")
        for name in ("noise_pa", "ramp_s", "align_s", "free_tilt_rad", "imu_noise_rad", "tail_s"):
            if not getattr(self, name) >= 0.0:
                raise ValueError(f"PressScript.{name} must be >= 0, got {getattr(self, name)}")
        quat = np.asarray(self.body_in_imu_wxyz, dtype=float)
        if quat.shape != (4,) or not abs(np.linalg.norm(quat) - 1.0) < 1e-6:
            raise ValueError(f"body_in_imu_wxyz must be a unit quaternion (w, x, y, z), got {self.body_in_imu_wxyz}")
        object.__setattr__(self, "presses", presses)
        object.__setattr__(self, "_mounting", rotation_from_wxyz(quat))

    @classmethod
    def regular(cls, n_presses: int = 6, *, quiet_s: float = 2.0, period_s: float = 1.2, press_s: float = 0.6,
                rise_pa: float = 1500.0, align_error_rad: float = math.radians(0.3), seed: int = 0,
                **options) -> "PressScript":
        """A quiet period, then ``n_presses`` evenly spaced presses with spread yaws and random residual tilts."""
        if n_presses < 0 or not press_s < period_s:
            raise ValueError(f"need n_presses >= 0 and press_s < period_s, got {n_presses}, {press_s}, {period_s}")
        rng = np.random.default_rng(seed)
        presses = tuple(
            Press(start_s=quiet_s + i * period_s, duration_s=press_s, rise_pa=rise_pa,
                  yaw_rad=2.0 * math.pi * i / max(n_presses, 1) + rng.uniform(-0.3, 0.3),
                  residual_tilt_rad=tuple(rng.normal(0.0, align_error_rad, 2)))
            for i in range(n_presses))
        return cls(presses=presses, seed=seed, **options)

    @property
    def end_s(self) -> float:
        """Script time after the last press and the tail, seconds."""
        return (self.presses[-1].end_s if self.presses else 0.0) + self.tail_s

    def pressure_pa(self, t_s: float) -> float:
        """True pressure under the pad at script time ``t_s`` (noise is the chip's), pascals."""
        pressure = self.baseline_pa + self.drift_pa_per_s * t_s
        for press in self.presses:
            if press.start_s <= t_s <= press.end_s:
                rising = (t_s - press.start_s) / self.ramp_s if self.ramp_s else 1.0
                falling = (press.end_s - t_s) / self.ramp_s if self.ramp_s else 1.0
                pressure += press.rise_pa * min(1.0, rising, falling)
        return pressure

    def body_rotation(self, t_s: float) -> Rotation:
        """True sensor-body orientation in the world at script time ``t_s``."""
        press = self._press_near(t_s)
        if press is None:
            return _FLAT * Rotation.from_rotvec([self.free_tilt_rad, 0.0, 0.0])
        tilt_axis_angle = press.yaw_rad + 1.0  # the spring hangs in a fixed direction relative to the yaw
        if press.start_s <= t_s <= press.end_s:
            fraction = min(1.0, (t_s - press.start_s) / self.align_s) if self.align_s else 1.0
        else:
            fraction = 0.0
        hanging = (1.0 - fraction) * self.free_tilt_rad
        residual = fraction * np.array([*press.residual_tilt_rad, 0.0])
        tilt = Rotation.from_rotvec(residual) * Rotation.from_rotvec(
            hanging * np.array([math.cos(tilt_axis_angle), math.sin(tilt_axis_angle), 0.0]))
        return tilt * Rotation.from_rotvec([0.0, 0.0, press.yaw_rad]) * _FLAT

    def imu_rotation(self, t_s: float, rng: np.random.Generator | None = None) -> Rotation:
        """What the IMU reports (its chip frame in the fusion frame = world here), with noise if ``rng``."""
        reported = self.body_rotation(t_s) * self._mounting.inv()
        if rng is not None and self.imu_noise_rad > 0.0:
            reported = Rotation.from_rotvec(rng.normal(0.0, self.imu_noise_rad, 3)) * reported
        return reported

    def _press_near(self, t_s: float) -> Press | None:
        """The press under way at ``t_s``, else the next one (the arm already turned to its yaw)."""
        for press in self.presses:
            if t_s <= press.end_s:
                return press
        return self.presses[-1] if self.presses else None


class ScriptedChipSource(ChipSource):
    """A :class:`ChipSource` whose emulated chips are set from a :class:`PressScript` before each poll.

    Script time 0 is the moment :meth:`open` is called.
    """

    def __init__(self, script: PressScript, barometer_chip: BMP280Chip, imu_chip: BNO055Chip,
                 barometer: BMP280, imu: BNO055I2C, *, clock: Callable[[], float]):
        super().__init__(barometer, imu, imu_mode=OperationMode.NDOF, clock=clock)
        self.script = script
        self.barometer_chip = barometer_chip
        self.imu_chip = imu_chip
        self.device = f"emulated fingertip ({self.device})"
        self._rng = np.random.default_rng(script.seed)
        self._t0: float | None = None

    def open(self) -> None:
        super().open()
        self._t0 = self.clock()

    def script_time_s(self) -> float:
        if self._t0 is None:
            raise RuntimeError("the emulated fingertip is not open")
        return self.clock() - self._t0

    def poll(self):
        t = self.script_time_s()
        self.barometer_chip.pressure_pa = self.script.pressure_pa(t)
        reported = self.script.imu_rotation(t, self._rng)
        self.imu_chip.quat_wxyz = wxyz_from_rotation(reported)
        self.imu_chip.gravity_mps2 = reported.inv().apply([0.0, 0.0, GRAVITY_MPS2])
        self.imu_chip.lin_acc_mps2 = np.zeros(3)
        return super().poll()


def emulated_fingertip(script: PressScript | None = None, *, clock: Callable[[], float] = time.monotonic,
                       sleep: Callable[[float], None] = time.sleep) -> HardwareTactileSensor:
    """A :class:`HardwareTactileSensor` on emulated chips following ``script`` (default :meth:`PressScript.regular`).

    Pass a :class:`sensor.emulators.FakeClock`'s ``monotonic`` and ``sleep`` to run faster than real time.
    """
    script = script if script is not None else PressScript.regular()
    barometer_chip = BMP280Chip(pressure_pa=script.pressure_pa(0.0), noise_pa=script.noise_pa, seed=script.seed)
    imu_chip = BNO055Chip(clock=clock)
    bus = FakeSMBus({BMP280_ADDRESS: barometer_chip, BNO055_ADDRESS: imu_chip})
    barometer = BMP280(bus, BMP280_ADDRESS, sleep=sleep, clock=clock)
    imu = BNO055I2C(bus, BNO055_ADDRESS, sleep=sleep, clock=clock)
    source = ScriptedChipSource(script, barometer_chip, imu_chip, barometer, imu, clock=clock)
    return HardwareTactileSensor(source, clock=clock, sleep=sleep)
