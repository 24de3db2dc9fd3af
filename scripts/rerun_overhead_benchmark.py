"""How much Rerun logging (``--rerun``) slows an exploration run: the same run with and without.

    python -m scripts.rerun_overhead_benchmark --object banana --touches 20 --repeats 2

Runs alternate (without, with, without, with, ...) with the same seed, so both see the same
machine load on average; prints each wall time, the ratio of the medians and the machine. On a
shared machine the wall times of whole runs vary by more than the logging costs, so each logged
run also times every observer call: that time over the run's wall time is the logging share
measured inside one run (load slows both alike).
Outputs under ``--out`` (default a temporary directory).
"""
from __future__ import annotations

import argparse
import os
import platform
import statistics
import tempfile
import time
from pathlib import Path


class TimedObserver:
    """Forwards every call to ``observer`` and adds up the seconds spent in it."""

    def __init__(self, observer):
        self._observer = observer
        self.seconds = 0.0

    def __getattr__(self, name):
        method = getattr(self._observer, name)

        def timed(*args, **kwargs):
            start = time.perf_counter()
            try:
                return method(*args, **kwargs)
            finally:
                self.seconds += time.perf_counter() - start

        return timed


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--object", default="banana")
    parser.add_argument("--touches", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--surface-every", type=int, default=10, help="GPIS surface every k touches")
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args(argv)

    import torch

    from explorer.rerun_view import RerunObserver, open_stream
    from explorer.run import RunSettings, explore

    torch.set_num_threads(1)
    out = args.out or Path(tempfile.mkdtemp(prefix="rerun_overhead_"))
    settings = RunSettings(object=args.object, touches=args.touches, seed=args.seed)
    walls: dict[bool, list[float]] = {False: [], True: []}
    shares: list[float] = []
    for repeat in range(args.repeats):
        for logged in (False, True):
            name = f"{'rerun' if logged else 'plain'}{repeat}"
            start = time.perf_counter()
            observer = (TimedObserver(RerunObserver(open_stream(out / f"{name}.rrd"),
                                                    surface_every=args.surface_every)) if logged else None)
            result = explore(settings, out / name, observer=observer)
            walls[logged].append(time.perf_counter() - start)
            note = ""
            if logged:
                shares.append(observer.seconds / walls[logged][-1])
                note = f", {observer.seconds:.2f} s in the observer ({100 * shares[-1]:.1f} %)"
            print(f"{name}: {walls[logged][-1]:.1f} s wall, {result.metrics['contacts']} contacts{note}", flush=True)
    plain, logged = statistics.median(walls[False]), statistics.median(walls[True])
    size_mb = statistics.median((out / f"rerun{i}.rrd").stat().st_size for i in range(args.repeats)) / 1e6
    print(f"\n{args.object}, {args.touches} touches, seed {args.seed}, surface every {args.surface_every} touches")
    print(f"median wall without Rerun {plain:.1f} s, with {logged:.1f} s: ratio {logged / plain:.3f}; "
          f"recording {size_mb:.1f} MB")
    print(f"time inside the observer: {100 * statistics.median(shares):.1f} % of the logged runs' wall time "
          f"(median; each run: {', '.join(f'{100 * x:.1f}' for x in shares)})")
    print(f"Machine: {platform.machine()}, {os.cpu_count()} cores, python {platform.python_version()}")


if __name__ == "__main__":
    main()
