"""sensor-monitor: watch the fingertip sensor live, record it, or calibrate it.

Streams pressure, drift-compensated pressure (above the contact detector's baseline), contact
state and orientation (IMU quaternion and the face-normal direction a contact would give) at a
readable rate; contact starts and ends are printed as they happen.

    sensor-monitor --emulate --duration 10                 # no hardware: emulated presses on a table
    sensor-monitor --config configs/lab.toml --record runs/monitor-1 --csv monitor.csv
    sensor-monitor --config configs/lab.toml --calibrate calibration.json

``--calibrate`` asks for a quiet period and a few presses on a level table, then writes the
pressure baseline and the IMU mounting offset to a JSON file for the configuration's
``[sensor] calibration`` key (see docs/HARDWARE.md).
"""
from __future__ import annotations

import argparse
import contextlib
import dataclasses
import math
import sys
import time
from pathlib import Path
from typing import Callable, TextIO

EXIT_OK, EXIT_FAILED = 0, 1


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="sensor-monitor", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument("--config", type=Path, help="backend configuration (.toml or .json); its [sensor] is used")
    source.add_argument("--emulate", action="store_true", help="emulated chips pressed on a level table by a script")
    parser.add_argument("--duration", type=float, default=math.inf, help="stop after this many seconds "
                                                                         "(default: until Ctrl-C)")
    parser.add_argument("--rate", type=float, default=10.0, help="display lines per second (default 10)")
    parser.add_argument("--poll-hz", type=float, default=100.0, help="sensor polling rate (default 100)")
    parser.add_argument("--record", type=Path, help="record readings and contact events to this session directory")
    parser.add_argument("--csv", type=Path, help="record every sample to this CSV file")
    parser.add_argument("--calibrate", type=Path, metavar="OUT.json",
                        help="run the calibration and write its file instead of monitoring")
    parser.add_argument("--quiet-s", type=float, default=2.0, help="calibration: quiet period, s (default 2)")
    parser.add_argument("--presses", type=int, default=5, help="calibration: presses on the table (default 5)")
    parser.add_argument("--press-timeout-s", type=float, default=60.0,
                        help="calibration: time allowed for the presses, s (default 60)")
    parser.add_argument("--emulate-tilt-deg", type=float, nargs=2, default=(1.5, -2.0), metavar=("X", "Y"),
                        help="--emulate: true IMU mounting tilt about the body's x and y axes, degrees "
                             "(default 1.5 -2.0)")
    return parser


def main(argv: list[str] | None = None, *, clock: Callable[[], float] = time.monotonic,
         sleep: Callable[[float], None] = time.sleep, out: TextIO | None = None) -> int:
    """Command-line entry point; returns the exit status. ``clock``/``sleep`` are injectable for tests."""
    from sensor.drivers.errors import DeviceError

    from scripts._cli import check_out_dir

    out = out if out is not None else sys.stdout
    parser = _parser()
    args = parser.parse_args(argv)
    if args.record is not None:
        check_out_dir(parser, args.record, option="--record")
    if args.csv is not None and args.csv.exists():
        parser.error(f"--csv {args.csv} already exists; choose a new file (nothing is overwritten)")
    if args.calibrate is not None and args.calibrate.is_dir():
        parser.error(f"--calibrate {args.calibrate} is a directory; give the .json file to write")
    try:
        return _run(args, clock, sleep, out)
    except KeyboardInterrupt:
        print("stopped", file=out)
        return EXIT_OK
    except (ValueError, OSError, RuntimeError, ImportError, DeviceError) as error:
        print(f"sensor-monitor: error: {error}", file=sys.stderr)
        return EXIT_FAILED


def _run(args: argparse.Namespace, clock, sleep, out: TextIO) -> int:
    from explorer.backends import load_calibration, open_sensor
    from explorer.config import load_config
    from explorer.monitor import CsvRecorder, SensorMonitor, SessionRecorder, run_monitor

    if not args.duration > 0.0:
        raise ValueError(f"--duration must be > 0 s, got {args.duration}")
    calibration = None
    with contextlib.ExitStack() as stack:
        if args.emulate:
            sensor = stack.enter_context(_emulated_sensor(args, clock, sleep))
            description = "emulated fingertip (sensor.emulated_fingertip)"
        else:
            config = load_config(args.config)
            if config.sensor.backend == "sim":
                raise ValueError(f"{args.config}: sensor.backend = 'sim' has no live sensor to monitor; "
                                 f"choose a hardware backend or use --emulate")
            if args.calibrate is not None and config.sensor.calibration is not None \
                    and not config.sensor.calibration.exists():
                # the file this command is about to create: calibrate without one
                config = dataclasses.replace(config, sensor=dataclasses.replace(config.sensor, calibration=None))
            calibration = load_calibration(config.sensor)
            sensor = stack.enter_context(open_sensor(config.sensor, clock=clock, sleep=sleep))
            description = f"{config.sensor.backend} ({args.config})"
        print(f"sensor: {description}", file=out)
        if args.calibrate is not None:
            return _calibrate(args, sensor, calibration, clock, sleep, out)
        recorders = []
        if args.record is not None:
            recorders.append(SessionRecorder(args.record, description))
        if args.csv is not None:
            recorders.append(CsvRecorder(args.csv))
        alignment = calibration.imu_alignment() if calibration is not None else None
        monitor = SensorMonitor(sensor, alignment=alignment, recorders=recorders)
        summary = run_monitor(monitor, args.duration, display_hz=args.rate, poll_hz=args.poll_hz, out=out,
                              clock=clock, sleep=sleep)
        print(f"{summary.n_readings} readings, {summary.n_contacts} contacts in {summary.duration_s:.1f} s",
              file=out)
    return EXIT_OK


def _emulated_sensor(args: argparse.Namespace, clock, sleep):
    from scipy.spatial.transform import Rotation

    from sensor.emulated_fingertip import PressScript, emulated_fingertip
    from common.rotations import wxyz_from_rotation

    tilt = Rotation.from_rotvec(list(map(math.radians, args.emulate_tilt_deg)) + [0.0])
    script = PressScript.regular(max(20, args.presses + 2), quiet_s=args.quiet_s + 1.0,
                                 body_in_imu_wxyz=tuple(wxyz_from_rotation(tilt)))
    return emulated_fingertip(script, clock=clock, sleep=sleep)


def _calibrate(args, sensor, previous, clock, sleep, out: TextIO) -> int:
    from sensor.calibration import SensorCalibration, record_calibration

    calibration, presses = record_calibration(sensor, quiet_s=args.quiet_s, n_presses=args.presses,
                                              timeout_s=args.press_timeout_s, poll_hz=args.poll_hz, out=out,
                                              clock=clock, sleep=sleep)
    if previous is not None and previous.bno055_profile_hex:  # keep the BNO055 offsets of the old file
        calibration = SensorCalibration(calibration.pressure_baseline, calibration.mounting,
                                        calibration.reference_in_world_wxyz, previous.bno055_profile_hex)
    path = calibration.save(args.calibrate)
    mounting = calibration.mounting
    print(f"IMU mounting: face axis tilted {math.degrees(mounting.tilt_rad):.2f} deg from the IMU z axis, "
          f"quaternion (w, x, y, z) = ({', '.join(f'{v:+.5f}' for v in mounting.body_in_imu_wxyz)}); "
          f"presses agree within {math.degrees(mounting.spread_rad):.2f} deg ({mounting.n_presses} used)", file=out)
    print(f"wrote {path}", file=out)
    return EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
