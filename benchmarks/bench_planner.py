"""Planner speed: the time of one planning step (`ApfPlanner.step`, what planner_node calls at 20 Hz) for
both methods, over whole closed-loop runs of the paper's and the suite's busiest scenarios.

Each run is the headless closed loop (the nodes' core classes); every planning step is timed with
perf_counter. Target of issue 16: the robust method plans within 2 ms at p99 (the node adds the
conversion of its messages, measured separately by bench_graph's navigation graph). planner_node compiles
its cores unless TWBR_JIT=off (twbr_planner.planner_main); `TWBR_JIT=off bench_planner.py --methods robust
--json results/planner_interpreted.json` measures the step so.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np
from results_file import write_results

from twbr_batch.closed_loop import PlannerReference, run_closed_loop
from twbr_common.jit import jit_mode
from twbr_planner.planner import ApfPlanner
from twbr_planner.planner_params import METHODS
from twbr_sim.scenario import load_scenario
from twbr_sim.scenario_files import find_scenario

# the escape's A* runs most in the traps and clutter, the dynamic window's and the yielding's rollouts among
# walkers (the densest: people_flow's 8 people between 42 wall discs, clutter_movers' 20 discs,
# crowd_crossing's 12 people, reactive_crowd's)
SCENARIOS = ("dynamic_obstacles", "suite/clutter", "suite/corridor", "suite/crossing_sweep", "suite/trap_large",
             "suite/trap_wedge", "suite/clutter_movers", "suite/crowd_crossing", "suite/reactive_crowd",
             "suite/people_flow")
TARGET_P99_S = 0.002


def step_times(scenario_name: str, method: str, duration: float) -> np.ndarray:
    """[s] of every planning step of one closed-loop run."""
    times: list[float] = []
    original = ApfPlanner.step

    def timed(self, *args, **kwargs):
        started = time.perf_counter()
        out = original(self, *args, **kwargs)
        times.append(time.perf_counter() - started)
        return out

    ApfPlanner.step = timed
    try:
        scenario = load_scenario(find_scenario(scenario_name))
        run_closed_loop(min(duration, scenario.duration), PlannerReference({"method": method}), scenario=scenario,
                        seed=1)
    finally:
        ApfPlanner.step = original
    return np.array(times[5:])  # the first steps load the kernels


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=90.0, help="sim seconds per run")
    ap.add_argument("--json", help="write the figures to this file")
    ap.add_argument("--methods", default=",".join(METHODS), help="comma-separated (default every method)")
    args = ap.parse_args()
    result: dict = {"jit": jit_mode()}  # off: the cores interpreted
    worst = 0.0
    for name in SCENARIOS:
        for method in args.methods.split(","):
            t = step_times(name, method, args.duration)
            p50, p99, top = (float(np.percentile(t, 50)), float(np.percentile(t, 99)), float(t.max()))
            result[f"{name}:{method}"] = {"steps": len(t), "median_s": p50, "p99_s": p99, "max_s": top}
            if method == "robust":
                worst = max(worst, p99)
            print(f"{name:22s} {method:6s}: {len(t):5d} steps, median {1e3 * p50:.3f} ms, p99 {1e3 * p99:.3f} ms,"
                  f" max {1e3 * top:.3f} ms")
    print(f"target: robust planning step p99 < {1e3 * TARGET_P99_S:g} ms: {'met' if worst < TARGET_P99_S else 'NOT met'}"
          f" (worst p99 {1e3 * worst:.3f} ms)")
    if args.json:
        write_results(args.json, result)
    return 0


if __name__ == "__main__":
    sys.exit(main())
