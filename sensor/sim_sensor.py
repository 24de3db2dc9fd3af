"""The simulated fingertip sensor: BNO055 and BMP280 models fed with the simulator's pad state.

The world glue (``explorer.simulation.connect_sensor``) calls :meth:`SimulatedTactileSensor.on_step`
after every physics step, or :meth:`~SimulatedTactileSensor.on_force_step` (the pad's normal force
alone) on the steps where :meth:`~SimulatedTactileSensor.needs_pad_state` says the chips read nothing
else: the same readings without the pose queries. Each chip samples at its own rate and every new
chip sample yields a :class:`~sensor.reading.Reading` whose other channels hold their newest value,
timestamped with the simulation time of that step.
"""
from __future__ import annotations

import math
import warnings
from collections import deque
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from sensor.interface import TactileSensor
from common.pad_state import PadState
from sensor.reading import Reading
from sensor.sim.bmp280 import BMP280Config, PressureSample, SimulatedBMP280
from sensor.sim.bno055 import BNO055Config, ImuSample, SimulatedBNO055

_QUATERNION_NORM_TOLERANCE = 1e-3


class SensorNotOpenError(RuntimeError):
    """The sensor was used before :meth:`SimulatedTactileSensor.open` (or after close)."""


class NoReadingError(RuntimeError):
    """The sensor is open but has not seen a physics step yet."""


@dataclass(frozen=True)
class SimulatedSensorConfig:
    """Both chips' settings.

    Attributes
    ----------
    imu : BNO055Config
        Simulated BNO055 settings.
    barometer : BMP280Config
        Simulated BMP280 and pad settings.
    """

    imu: BNO055Config = field(default_factory=BNO055Config)
    barometer: BMP280Config = field(default_factory=BMP280Config)

    def noiseless(self) -> "SimulatedSensorConfig":
        """Both chips without noise, bias or drift (quantisation and pad lag kept)."""
        return SimulatedSensorConfig(imu=self.imu.noiseless(), barometer=self.barometer.noiseless())


class SimulatedTactileSensor(TactileSensor):
    """The fingertip sensor in simulation.

    Push mode (preferred): the world calls :meth:`on_step` with the pad's true state after every
    physics step. Pull mode: give ``pad_state_source``, a callable returning the current
    :class:`PadState`; :meth:`read` and :meth:`drain` then fetch it first. Pull mode only sees the
    states at the moments you read, so the chips sample at most that often.

    Steps arriving while the sensor is closed are ignored (an unpowered sensor measures nothing);
    :meth:`open` powers the chips up afresh.

    Parameters
    ----------
    pad_state_source : callable () -> PadState, optional
        Pull-mode source of the pad's state.
    config : SimulatedSensorConfig
        Chip settings; ``SimulatedSensorConfig().noiseless()`` for noise-free runs.
    seed : int or numpy.random.Generator, optional
        Seed or generator for every random draw of this sensor.
    buffer_size : int
        Most readings kept for :meth:`drain`; older ones are discarded with a warning.
    """

    def __init__(
        self,
        pad_state_source: Callable[[], PadState] | None = None,
        config: SimulatedSensorConfig | None = None,
        seed: int | np.random.Generator | None = None,
        buffer_size: int = 100_000,
    ) -> None:
        if pad_state_source is not None and not callable(pad_state_source):
            raise ValueError(f"pad_state_source must be callable or None, got {type(pad_state_source).__name__}")
        if buffer_size < 1:
            raise ValueError(f"buffer_size must be >= 1, got {buffer_size}")
        self.config = config if config is not None else SimulatedSensorConfig()
        self._source = pad_state_source
        self._rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
        self._buffer: deque[Reading] = deque(maxlen=buffer_size)
        self.discarded_readings = 0
        self._imu: SimulatedBNO055 | None = None
        self._barometer: SimulatedBMP280 | None = None
        self._imu_sample: ImuSample | None = None
        self._pressure_sample: PressureSample | None = None
        self._newest: Reading | None = None
        self._last_t: float | None = None

    @property
    def is_open(self) -> bool:
        """True between :meth:`open` and :meth:`close`."""
        return self._imu is not None

    def open(self) -> None:
        """Power the chips up: fresh models, empty buffer. Idempotent."""
        if self.is_open:
            return
        imu_rng, barometer_rng = (np.random.default_rng(s) for s in self._rng.integers(2**63, size=2))
        self._imu = SimulatedBNO055(self.config.imu, imu_rng)
        self._barometer = SimulatedBMP280(self.config.barometer, barometer_rng)
        self._imu_sample = self._pressure_sample = self._newest = None
        self._last_t = None
        self._buffer.clear()

    def close(self) -> None:
        """Power the chips down. Idempotent."""
        self._imu = self._barometer = None

    def on_step(self, pad_state: PadState) -> None:
        """Advance both chips to ``pad_state.t_s``; queue a Reading if either produced a sample.

        Raises
        ------
        ValueError
            If time does not increase or the pad state is malformed.
        """
        if not self.is_open:
            return
        _check_pad_state(pad_state)
        self._advance_time(pad_state.t_s)
        imu_sample = self._imu.step(pad_state)
        pressure_sample = self._barometer.step(pad_state)
        self._queue(pad_state.t_s, imu_sample, pressure_sample)

    def needs_pad_state(self, t_s: float) -> bool:
        """Whether the step at ``t_s`` needs the whole pad state (:meth:`on_step`): an IMU sample
        falls due then or the IMU keeps a latency history. Where False, :meth:`on_force_step`
        with the pad's normal force gives the same readings; the PyBullet glue uses it to skip
        the pose queries on the steps between IMU samples."""
        return self.is_open and self._imu.needs_pad_state(t_s)

    def on_force_step(self, t_s: float, normal_force_n: float) -> None:
        """:meth:`on_step` on a step where :meth:`needs_pad_state` is False: only the barometer
        reads the pad then, and it reads the normal force (N) alone.

        Raises
        ------
        ValueError
            If time does not increase, the force is not finite and >= 0, or the IMU needs the
            whole pad state at ``t_s``.
        """
        if not self.is_open:
            return
        if not (math.isfinite(t_s) and math.isfinite(normal_force_n) and normal_force_n >= 0.0):
            raise ValueError(f"need a finite time and a finite normal force >= 0 N, got {t_s}, {normal_force_n}")
        if self._imu.needs_pad_state(t_s):
            raise ValueError(f"the IMU samples at {t_s} s: call on_step(pad_state) there")
        self._advance_time(t_s)
        self._queue(t_s, None, self._barometer.step_force(t_s, normal_force_n))

    def _advance_time(self, t_s: float) -> None:
        if self._last_t is not None and not t_s > self._last_t:
            raise ValueError(f"pad state time {t_s} s does not increase past {self._last_t} s")
        self._last_t = t_s

    def _queue(self, t_s: float, imu_sample: ImuSample | None, pressure_sample: PressureSample | None) -> None:
        """A Reading at ``t_s`` if either chip produced a sample."""
        if imu_sample is None and pressure_sample is None:
            return
        self._imu_sample = imu_sample or self._imu_sample
        self._pressure_sample = pressure_sample or self._pressure_sample
        reading = Reading(
            t_s=t_s,
            pressure_pa=self._pressure_sample.pressure_pa,
            quat_wxyz=self._imu_sample.quat_wxyz,
            lin_acc_mps2=self._imu_sample.lin_acc_mps2,
            gravity_mps2=self._imu_sample.gravity_mps2,
            temperature_c=self._pressure_sample.temperature_c,
        )
        if len(self._buffer) == self._buffer.maxlen:
            if self.discarded_readings == 0:
                warnings.warn(
                    f"SimulatedTactileSensor buffer full ({self._buffer.maxlen} readings): call drain() more "
                    "often; the oldest readings are being discarded (count in .discarded_readings)",
                    RuntimeWarning, stacklevel=2,
                )
            self.discarded_readings += 1
        self._buffer.append(reading)
        self._newest = reading

    def read(self) -> Reading:
        """The newest reading.

        Raises
        ------
        SensorNotOpenError
            Before :meth:`open` or after :meth:`close`.
        NoReadingError
            When no physics step has arrived since :meth:`open`.
        """
        self._pull()
        if self._newest is None:
            raise NoReadingError("no physics step seen since open(): the world must call on_step(pad_state)")
        return self._newest

    def drain(self) -> list[Reading]:
        """Every reading since the previous drain, oldest first (possibly empty)."""
        self._pull()
        readings = list(self._buffer)
        self._buffer.clear()
        return readings

    def _pull(self) -> None:
        if not self.is_open:
            raise SensorNotOpenError("SimulatedTactileSensor is not open: call open() or use it as a context manager")
        if self._source is None:
            return
        pad_state = self._source()
        if self._last_t is None or pad_state.t_s > self._last_t:
            self.on_step(pad_state)


def _check_pad_state(pad_state: PadState) -> None:
    # plain floats: this runs on every IMU sample step
    if not math.isfinite(pad_state.t_s):
        raise ValueError(f"pad state time must be finite, got {pad_state.t_s}")
    quat = np.asarray(pad_state.quat_wxyz, dtype=float)
    if quat.shape != (4,) or not all(map(math.isfinite, quat.tolist())):
        raise ValueError(f"pad state quat_wxyz must be 4 finite numbers, got {pad_state.quat_wxyz!r}")
    norm = math.sqrt(sum(v * v for v in quat.tolist()))
    if abs(norm - 1.0) > _QUATERNION_NORM_TOLERANCE:
        raise ValueError(f"pad state quat_wxyz must be a unit quaternion, norm is {norm:.6f}")
    for name in ("lin_vel_mps", "ang_vel_radps"):
        value = np.asarray(getattr(pad_state, name), dtype=float)
        if value.shape != (3,) or not all(map(math.isfinite, value.tolist())):
            raise ValueError(f"pad state {name} must be 3 finite numbers, got {getattr(pad_state, name)!r}")
    if not (math.isfinite(pad_state.normal_force_n) and pad_state.normal_force_n >= 0.0):
        raise ValueError(f"pad state normal_force_n must be finite and >= 0 N, got {pad_state.normal_force_n}")
