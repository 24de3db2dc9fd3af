"""Print simulated seconds per wall second while the simulated arm presses an object (DIRECT mode).

    python -m scripts.robot_speed_benchmark [--robot armar3 armar6] [--object box bowl] [--seconds 10]

Without --object the arm presses a primitive box; with it, registry objects (triangle meshes).
"""
from __future__ import annotations

import argparse


def main(argv: list[str] | None = None) -> None:
    from robots.benchmark import machine_description, measure

    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--robot", nargs="+", default=["armar3", "armar6"], help="registered robot names")
    parser.add_argument("--seconds", type=float, default=10.0, help="simulated seconds per measurement")
    parser.add_argument("--object", nargs="*", default=[None], help="objects registry names (default: primitive box)")
    parser.add_argument("--time-step", type=float, default=None, help="physics step, s (default: SimWorld's)")
    args = parser.parse_args(argv)
    print(f"machine: {machine_description()}")
    for robot in args.robot:
        for object_name in args.object or [None]:
            f = measure(robot, args.seconds, args.time_step, object_name)
            print(
                f"{f.robot} pressing {f.object_name} (mean {f.mean_press_force_n:.1f} N), dt = {f.time_step_s:.6f} s: "
                f"{f.realtime_factor:.1f}x real time, {f.with_listener_realtime_factor:.1f}x with pad_state() "
                f"after every step ({f.simulated_s:.0f} s simulated each)"
            )


if __name__ == "__main__":
    main()
