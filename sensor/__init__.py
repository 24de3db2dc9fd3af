"""The fingertip sensor: readings, simulated and hardware sensors, contact detection, normals.

Public API:

* data: :class:`Reading`, :class:`PadState`, :class:`ContactEvent`, :class:`OrientedContact`;
* sensors: :class:`TactileSensor` (the interface), :class:`SimulatedTactileSensor` with
  :class:`SimulatedSensorConfig`, :class:`HardwareTactileSensor` (drivers in
  :mod:`sensor.drivers`, emulators in :mod:`sensor.emulators`);
* contact detection: :class:`ContactDetector`, :class:`PressureContactDetector` with
  :class:`PressureDetectorConfig`;
* normals and calibration: :func:`estimate_normal`, :class:`ImuAlignment`,
  :class:`SettlingConfig`, :class:`SensorCalibration`.

Every name is imported on first use (module ``__getattr__``), so ``import sensor`` stays light.
"""
from __future__ import annotations

from common.lazy_exports import lazy_exports

_LAZY = {
    "Reading": "sensor.reading",
    "PadState": "common.pad_state",
    "ContactEvent": "sensor.contact_detection",
    "OrientedContact": "sensor.oriented_contact",
    "TactileSensor": "sensor.interface",
    "SimulatedTactileSensor": "sensor.sim_sensor",
    "SimulatedSensorConfig": "sensor.sim_sensor",
    "HardwareTactileSensor": "sensor.drivers",
    "ContactDetector": "sensor.contact_detection",
    "PressureContactDetector": "sensor.contact_detection",
    "PressureDetectorConfig": "sensor.contact_detection",
    "estimate_normal": "sensor.normal_estimation",
    "ImuAlignment": "sensor.normal_estimation",
    "SettlingConfig": "sensor.normal_estimation",
    "SensorCalibration": "sensor.calibration",
}

__all__ = sorted(_LAZY)

__getattr__, __dir__ = lazy_exports(__name__, _LAZY)
