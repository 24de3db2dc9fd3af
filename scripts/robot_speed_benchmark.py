"""Print simulated seconds per wall second while the simulated arm presses an object (DIRECT mode).

    python -m scripts.robot_speed_benchmark [--robot armar3 armar6] [--object box bowl] [--seconds 10]
    python -m scripts.robot_speed_benchmark --loop [--object banana] [--touches 10] [--repeats 3]

Without --object the arm presses a primitive box; with it, registry objects (triangle meshes).

With --loop, one process runs the whole exploration loop on the object (``tactile-explore``'s run
with ``--touches``, evaluation off) and, after every touch, a ``--burst`` of the bare physics (the arm
pressing the same object, no sensor: ``robots.benchmark.PressCycles``), so that both rates are
measured under the same load, interleaved. The loop's rate is its simulated time over the wall time
of its simulation phase (arm, sensor models, contact detection, recording); the bare rate is the
bursts' simulated over wall time. It prints bare / loop per run and the median over ``--repeats``
(issue 11 asks for <= 1.5), with the machine and its load.
"""
from __future__ import annotations

import argparse
import os
import statistics
import tempfile
import time
from pathlib import Path


def loop_against_bare(object_name: str, robot: str, touches: int, seed: int, burst_s: float) -> tuple[float, float, float]:
    """One exploration run with a bare-physics burst after every touch, in the same process.

    Returns (bare physics real-time factor, loop real-time factor, whole run wall seconds). The
    loop's rate is its simulated time over the wall time of its simulation phase; the bursts run
    between touches (from the run observer's ``touch`` call, outside that phase), so both rates see
    the same load.
    """
    from explorer.observer import RunObserver
    from explorer.run import RunSettings, explore
    from robots.benchmark import PressCycles

    class BareBursts(RunObserver):
        def __init__(self, bench):
            self.bench, self.wall_s = bench, 0.0

        def touch(self, record, t_s: float) -> None:
            self.wall_s += self.bench.run(burst_s)

    with PressCycles(robot, object_name) as bench, tempfile.TemporaryDirectory() as tmp:
        bursts = BareBursts(bench)
        start = time.perf_counter()
        run = explore(RunSettings(object=object_name, robot=robot, touches=touches, seed=seed, eval_every=0),
                      Path(tmp) / "run", observer=bursts)
        wall = time.perf_counter() - start
        bare = bench.world.time_s / bursts.wall_s
    loop = float(run.metrics["simulated_time_s"]) / float(run.metrics["phase_times_s"]["simulation_s"])
    return bare, loop, wall


def compare_loop(args) -> None:
    object_name = args.object[0] if args.object and args.object[0] else "banana"
    robot = args.robot[0]
    ratios = []
    for repeat in range(args.repeats):
        bare, loop, wall = loop_against_bare(object_name, robot, args.touches, args.seed, args.burst)
        ratios.append(bare / loop)
        print(f"  run {repeat + 1}: bare physics {bare:.1f}x real time, loop {loop:.1f}x, bare / loop = "
              f"{ratios[-1]:.2f} (whole run {wall:.0f} s wall)", flush=True)
    print(f"{robot} on {object_name}, {args.touches} touches, {args.burst:g} s bare burst after each: "
          f"bare / loop = {statistics.median(ratios):.2f} (median of {args.repeats}; issue 11 target <= 1.5)")


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
    parser.add_argument("--burst", type=float, default=2.0, help="--loop: simulated seconds of bare pressing "
                        "after every touch")
    args = parser.parse_args(argv)
    if args.touches < 1 or args.repeats < 1 or not (args.seconds > 0.0 and args.burst > 0.0):
        parser.error("--touches and --repeats must be >= 1, --seconds and --burst > 0")
    print(f"machine: {machine_description()}; load average {os.getloadavg()[0]:.1f} at start")
    if args.loop:
        compare_loop(args)
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
