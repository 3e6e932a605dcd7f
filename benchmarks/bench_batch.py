"""Batch engine speed: robot-steps per second at N = 1, 100, 1000, 10000, memory per robot, and a Monte
Carlo study of 1000 dynamic-obstacle runs to their end, against the scalar cores' step rate.

A robot-step is one physics step (1 kHz) of one robot with everything of its closed loop in it: the
dynamics and motors (RK4), the controller every 5th step (200 Hz), the planner and the world's
assessment every 50th (20 Hz). The rate counts the steps the robots really took (a finished robot stops)
over the wall time of the whole call, set-up included. The targets of issue 7: >= 5,000,000 robot-steps/s
at N = 10000, and the 1000 runs in under 60 s; of issue 16: the same rate with the robust planner; of issue
19 (the ones printed): >= 20,000,000 robot-steps/s at N = 10000 with the robust planner, and the 1000 runs
in under 3 s, on 2 cores; of issue 36: >= 5,000,000 robot-steps/s at N = 10000 with the robust planner on
the LiDAR (a 360-beam scan cast, the tracker and the target filter at 10 Hz in every robot); of issue 35:
>= 15,000,000 robot-steps/s at N = 10000 with the robust planner, the default method. The robust planner
on suite/people_flow (8 people between 42 wall discs) is measured as well: there the planner, not the
physics, sets the rate.
"""

from __future__ import annotations

import argparse
import os
import resource
import sys
import time
from pathlib import Path

import numpy as np
from results_file import write_results

from twbr_batch import montecarlo as mc
from twbr_batch.batch import run_batch
from twbr_batch.closed_loop import PlannerReference, run_closed_loop
from twbr_planner.planner_params import METHODS
from twbr_sim.robot_params import robot_params
from twbr_sim.scenario import load_scenario
from twbr_sim.scenario_files import find_scenario

SIZES = (1, 100, 1000, 10000)
TARGET_STEPS_PER_S = 20_000_000  # issue 19, with the robust planner (issue 7: 5 M)
TARGET_STUDY_S = 3.0  # issue 19 (issue 7: 60 s)
TARGET_LIDAR_STEPS_PER_S = 5_000_000  # issue 36
TARGET_PEOPLE_STEPS_PER_S = 15_000_000  # issue 35, with the robust planner (the default method)
DENSE_SCENARIO = "suite/people_flow"


def batch_rate(scenario, n: int, seconds: float, planner: dict | None = None,
               perception: str = "truth") -> tuple[float, int, float]:
    """(robot-steps/s, robot-steps, wall s) of n robots for `seconds` of sim time each (no early end)."""
    params = np.tile(robot_params(), (n, 1))
    started = time.perf_counter()
    result = run_batch(scenario, list(range(1, n + 1)), params, planner=planner, duration=seconds,
                       perception=perception)
    wall = time.perf_counter() - started
    return result.robot_steps / wall, result.robot_steps, wall


def scalar_rate(scenario, seconds: float) -> float:
    """Physics steps/s of one robot through the scalar cores (the nodes' classes) in closed loop."""
    run_closed_loop(0.1, PlannerReference(), scenario=scenario, seed=1)  # compile or load the kernels first
    started = time.perf_counter()
    trace = run_closed_loop(seconds, PlannerReference(), scenario=scenario, seed=1, stop_on_fall=False)
    return (len(trace.t) - 1) * 5 / (time.perf_counter() - started)


def memory_per_robot(scenario, n: int) -> float:
    """Peak resident memory a batch of n robots adds, per robot [bytes] (ru_maxrss is in KiB on Linux)."""
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    run_batch(scenario, list(range(1, n + 1)), np.tile(robot_params(), (n, 1)), duration=1.0)
    after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return (after - before) * 1024.0 / n


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="dynamic_obstacles")
    ap.add_argument("--sim-seconds", type=float, default=5.0, help="sim time per robot of the rate runs")
    ap.add_argument("--study-runs", type=int, default=1000)
    ap.add_argument("--json", help="write the figures to this file")
    args = ap.parse_args()
    path = find_scenario(args.scenario)
    scenario = load_scenario(path)
    run_batch(scenario, [1], robot_params()[None, :], duration=0.1)  # compile or load the kernels first
    result: dict = {"cores": os.cpu_count(), "scenario": scenario.name, "sim_seconds_per_robot": args.sim_seconds}
    # Memory first, while the peak RSS is still that of the small runs.
    result["memory_per_robot_bytes"] = memory_per_robot(scenario, 100_000)
    print(f"memory per robot (peak RSS added by a batch of 100000): {result['memory_per_robot_bytes']:.0f} B")
    result["scalar_core_steps_per_s"] = scalar_rate(scenario, args.sim_seconds)
    print(f"scalar cores (the nodes' classes), one robot: {result['scalar_core_steps_per_s']:12,.0f} steps/s")
    for n in SIZES:
        seconds = args.sim_seconds if n >= 100 else 10 * args.sim_seconds
        rate, steps, wall = batch_rate(scenario, n, seconds)
        result[f"batch_robot_steps_per_s_n{n}"] = rate
        print(f"batch engine N = {n:>5}: {rate:12,.0f} robot-steps/s ({steps:,} steps in {wall:.2f} s)")
    for method in METHODS:  # the same at N = 10000 with each planner method named (the default above)
        rate, steps, wall = batch_rate(scenario, SIZES[-1], args.sim_seconds, {"method": method})
        result[f"batch_robot_steps_per_s_n{SIZES[-1]}_{method}"] = rate
        print(f"batch engine N = {SIZES[-1]}, planner {method}: {rate:12,.0f} robot-steps/s")
    rate, steps, wall = batch_rate(scenario, SIZES[-1], args.sim_seconds, {"method": "robust"}, "lidar")
    result[f"batch_robot_steps_per_s_n{SIZES[-1]}_robust_lidar"] = rate
    truth_rate = result[f"batch_robot_steps_per_s_n{SIZES[-1]}_robust"]
    print(f"batch engine N = {SIZES[-1]}, planner robust on the LiDAR: {rate:12,.0f} robot-steps/s"
          f" ({rate / truth_rate:.2f} x on the truth)")
    # the planner-bound end: the suite's densest layout (8 people between 42 wall discs), the rollouts at
    # almost every plan
    dense = load_scenario(find_scenario(DENSE_SCENARIO))
    rate, steps, wall = batch_rate(dense, 1000, 10.0, {"method": "robust"})
    result["batch_robot_steps_per_s_n1000_robust_people_flow"] = rate
    print(f"batch engine N = 1000, planner robust, {DENSE_SCENARIO} (truth): {rate:12,.0f} robot-steps/s")
    study = mc.Study(path, args.study_runs)
    out = Path(os.environ.get("TMPDIR", "/tmp")) / f"twbr-bench-study-{os.getpid()}"
    started = time.perf_counter()
    rows = mc.run_study(study, out, progress=False)
    result["study_runs"] = args.study_runs
    result["study_wall_s"] = time.perf_counter() - started
    result["study_success_rate"] = sum(r.succeeded for r in rows) / len(rows)
    print(f"montecarlo {args.study_runs} runs of {scenario.name} to their end: {result['study_wall_s']:.1f} s"
          f" (success {100 * result['study_success_rate']:.1f} %)")
    big = result[f"batch_robot_steps_per_s_n{SIZES[-1]}_robust"]
    print(f"targets: >= {TARGET_STEPS_PER_S:,} robot-steps/s at N = {SIZES[-1]} with the robust planner:"
          f" {'met' if big >= TARGET_STEPS_PER_S else 'NOT met'} (issue 35's >= {TARGET_PEOPLE_STEPS_PER_S:,}:"
          f" {'met' if big >= TARGET_PEOPLE_STEPS_PER_S else 'NOT met'});"
          f" {args.study_runs} runs < {TARGET_STUDY_S:g} s: {'met' if result['study_wall_s'] < TARGET_STUDY_S else 'NOT met'}"
          f" ({os.cpu_count()} cores); on the LiDAR >= {TARGET_LIDAR_STEPS_PER_S:,}:"
          f" {'met' if result[f'batch_robot_steps_per_s_n{SIZES[-1]}_robust_lidar'] >= TARGET_LIDAR_STEPS_PER_S else 'NOT met'}")
    if args.json:
        write_results(args.json, result)
    return 0


if __name__ == "__main__":
    sys.exit(main())
