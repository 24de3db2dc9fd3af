"""Print simulated seconds per wall second while the simulated arm presses an object (DIRECT mode).

    python -m scripts.robot_speed_benchmark [--robot armar3 armar6] [--seconds 10]
"""
from __future__ import annotations

import argparse


def main(argv: list[str] | None = None) -> None:
    from robots.benchmark import machine_description, measure

    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--robot", nargs="+", default=["armar3", "armar6"], help="registered robot names")
    parser.add_argument("--seconds", type=float, default=10.0, help="simulated seconds per measurement")
    parser.add_argument("--time-step", type=float, default=None, help="physics step, s (default: SimWorld's)")
    args = parser.parse_args(argv)
    print(f"machine: {machine_description()}")
    for robot in args.robot:
        figures = measure(robot, args.seconds, args.time_step)
        print(
            f"{figures.robot}: dt = {figures.time_step_s:.6f} s, pressing (mean {figures.mean_normal_force_n:.1f} N): "
            f"{figures.pressing_realtime_factor:.1f}x real time with pad_state() every step, "
            f"{figures.pressing_no_listener_realtime_factor:.1f}x without "
            f"({figures.simulated_s:.0f} s simulated each)"
        )


if __name__ == "__main__":
    main()
