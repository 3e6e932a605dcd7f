"""Time to the first result from an empty kernel cache (issue 37): what a fresh clone's user waits for.

Each step runs in a new process on a cache directory of its own (NUMBA_CACHE_DIR), empty at the start:
  cold     `montecarlo dynamic_obstacles -n 1000` with nothing compiled (what every first run paid before
           set-up compiled the kernels);
  warm     `python -m twbr_batch.warm` (what `make setup` runs beside pip and colcon);
  first    the same montecarlo after it (a fresh clone's first `make montecarlo` after `make setup`);
  again    once more (every later call).
Target (issue 37): `first` <= 30 s on 2 cores.

    tools/run.sh python benchmarks/bench_first_run.py [--json benchmarks/results/first_run.json]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time

from results_file import write_results

TARGET_FIRST_S = 30.0
MONTECARLO = [sys.executable, "-m", "twbr_batch.montecarlo", "dynamic_obstacles", "-n", "1000", "--no-figure"]


def timed(command: list[str], env: dict[str, str], cwd: str) -> float:
    started = time.perf_counter()
    subprocess.run(command, env=env, cwd=cwd, check=True, stdout=subprocess.DEVNULL)
    return time.perf_counter() - started


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", help="write the figures to this file")
    args = ap.parse_args()
    figures: dict[str, float | int] = {"cores": os.cpu_count() or 0}
    with tempfile.TemporaryDirectory() as work:
        cold = dict(os.environ, NUMBA_CACHE_DIR=os.path.join(work, "cold"))
        figures["cold_montecarlo_1000_s"] = timed([*MONTECARLO, "--out", os.path.join(work, "a")], cold, work)
        warmed = dict(os.environ, NUMBA_CACHE_DIR=os.path.join(work, "warm"))
        figures["warm_kernels_s"] = timed([sys.executable, "-m", "twbr_batch.warm"], warmed, work)
        figures["first_montecarlo_1000_s"] = timed([*MONTECARLO, "--out", os.path.join(work, "b")], warmed, work)
        figures["again_montecarlo_1000_s"] = timed([*MONTECARLO, "--out", os.path.join(work, "c")], warmed, work)
    for key, value in figures.items():
        print(f"{key:<28} {value:8.1f}")
    met = figures["first_montecarlo_1000_s"] <= TARGET_FIRST_S
    print(f"target: first montecarlo of 1000 runs after set-up <= {TARGET_FIRST_S:.0f} s: {'met' if met else 'NOT met'}")
    if args.json:
        write_results(args.json, figures)
    return 0


if __name__ == "__main__":
    sys.exit(main())
