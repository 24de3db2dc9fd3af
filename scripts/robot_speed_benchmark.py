"""Print simulated seconds per wall second while the simulated arm presses an object (DIRECT mode).

    python -m scripts.robot_speed_benchmark [--robot armar3 armar6] [--object box bowl] [--seconds 10]
    python -m scripts.robot_speed_benchmark --loop [--object banana] [--touches 10] [--repeats 3]

Without --object the arm presses a primitive box; with it, registry objects (triangle meshes).

With --loop, one run measures, alternately and ``--repeats`` times each, the bare physics (the arm
pressing the object, no sensor: ``robots.benchmark.measure``) and the whole exploration loop on the
same object (``tactile-explore``'s run with ``--touches``, evaluation off; its rate is simulated
time over the wall time of the loop's simulation phase: arm, sensor, contact detection and
recording). It prints the medians and loop / bare, the loop's overhead over the bare physics
(issue 11 asks for <= 1.5), with the machine and its load.
"""
from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path


def loop_realtime_factor(object_name: str, robot: str, touches: int, seed: int) -> tuple[float, float, float]:
    """(simulated s per wall s of the simulation phase, simulated s, wall s of the whole run)."""
    from explorer.run import RunSettings, explore

    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        run = explore(RunSettings(object=object_name, robot=robot, touches=touches, seed=seed, eval_every=0),
                      Path(tmp) / "run")
        wall = time.perf_counter() - start
    simulated = float(run.metrics["simulated_time_s"])
    return simulated / float(run.metrics["phase_times_s"]["simulation_s"]), simulated, wall


def loop_against_bare(args) -> None:
    from robots.benchmark import measure

    object_name = args.object[0] if args.object and args.object[0] else "banana"
    robot = args.robot[0]
    bare, loop = [], []
    for repeat in range(args.repeats):
        bare.append(measure(robot, args.seconds, args.time_step, object_name).realtime_factor)
        factor, simulated, wall = loop_realtime_factor(object_name, robot, args.touches, args.seed)
        loop.append(factor)
        print(f"  repeat {repeat + 1}: bare {bare[-1]:.1f}x, loop {factor:.1f}x real time "
              f"({simulated:.0f} s simulated, whole run {wall:.0f} s wall), ratio {bare[-1] / factor:.2f}",
              flush=True)
    ratios = [b / f for b, f in zip(bare, loop)]
    print(f"{robot} on {object_name}: bare physics {statistics.median(bare):.1f}x real time, loop "
          f"({args.touches} touches) {statistics.median(loop):.1f}x; bare / loop = "
          f"{statistics.median(ratios):.2f} (median of {args.repeats}; issue 11 target <= 1.5)")


def main(argv: list[str] | None = None) -> None:
    from robots.benchmark import machine_description, measure

    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--robot", nargs="+", default=["armar3", "armar6"], help="registered robot names")
    parser.add_argument("--seconds", type=float, default=10.0, help="simulated seconds per measurement")
    parser.add_argument("--object", nargs="*", default=[None], help="objects registry names (default: primitive box)")
    parser.add_argument("--time-step", type=float, default=None, help="physics step, s (default: SimWorld's)")
    parser.add_argument("--loop", action="store_true",
                        help="compare the whole exploration loop with the bare physics (first robot and object; "
                             "object default banana)")
    parser.add_argument("--touches", type=int, default=10, help="--loop: touches of the exploration run")
    parser.add_argument("--repeats", type=int, default=3, help="--loop: alternating measurements of each")
    parser.add_argument("--seed", type=int, default=0, help="--loop: seed of the exploration run")
    args = parser.parse_args(argv)
    if args.touches < 1 or args.repeats < 1 or not args.seconds > 0.0:
        parser.error("--touches and --repeats must be >= 1 and --seconds > 0")
    print(f"machine: {machine_description()}; load average {os.getloadavg()[0]:.1f} at start")
    if args.loop:
        loop_against_bare(args)
        print(f"load average {os.getloadavg()[0]:.1f} at the end")
        return
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
