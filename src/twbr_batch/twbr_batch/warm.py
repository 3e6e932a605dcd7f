"""Compile every kernel a first run would compile, ahead of it: `make setup` runs this beside its colcon
build, so the first `make montecarlo`, `make suite` or `make demo` loads kernels instead of compiling them
(~110 s for the batch engine's, ~30 s for the nodes' on 2 cores).

Two jobs, one process each (numba compiles on one core): `batch` (the batch engine and the suite's
avoidability check) and `nodes` (the tracker's, and the simulator's, world's, planner's and controller's
scalar cores through the headless closed loop, as their nodes call them, and the dynamics' own batch step
that bench_dynamics.py and test_dynamics call: ~60 s, beside the batch job's longer one). The kernels land in
twbr_common.jit's cache, filed by package: compiled here from the checkout's src/, they are the ones the
installed packages load. A job whose kernels are cached only loads them (~2 s).
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

JOBS = ("batch", "nodes")
SCENARIO = "dynamic_obstacles"  # has a target, a moving one and obstacles: every kernel of a run is used


def warm_batch() -> None:
    from twbr_batch.avoidability import collision_avoidable
    from twbr_batch.montecarlo import run_chunk
    from twbr_batch.suite import robot_limits
    from twbr_planner.planner_params import resolve
    from twbr_sim.scenario_files import find_scenario

    run_chunk(str(find_scenario(SCENARIO)), [1], 0.0, "ideal", "pid", 0.1)
    collision_avoidable((0.0, 0.0, 0.0, 0.3, 0.0), (3.0, 0.0, -0.5, 0.0), 0.3, 0.2, robot_limits(resolve(None)))


def warm_nodes() -> None:
    from twbr_batch.closed_loop import PlannerReference, run_closed_loop
    from twbr_common.params import defaults
    from twbr_control.cascade import CONTROLLERS
    from twbr_sim import dynamics
    from twbr_sim.robot_params import robot_params
    from twbr_sim.scenario import load_scenario
    from twbr_sim.scenario_files import find_scenario
    from twbr_tracker.tracker import TRACKER_SPECS, Tracker

    Tracker(defaults(TRACKER_SPECS)).warm_up()
    p = robot_params()
    dynamics.step_batch(np.tile(p, (2, 1)), np.zeros((2, dynamics.N_STATE)), np.zeros((2, 2)), 0.001, 1)
    scenario = load_scenario(find_scenario(SCENARIO))
    for controller in CONTROLLERS:
        run_closed_loop(0.2, PlannerReference(control={"controller": controller}), scenario=scenario, seed=1,
                        control={"controller": controller})


WARMERS = {"batch": warm_batch, "nodes": warm_nodes}


def run_job(job: str) -> float:
    started = time.monotonic()
    WARMERS[job]()
    return time.monotonic() - started


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--job", choices=JOBS, help="one job in this process (default: every job, one "
                        "process each, in parallel)")
    args = parser.parse_args(argv)
    if args.job:
        took = run_job(args.job)
        print(f"warm: {args.job} kernels ready in {took:.1f} s", flush=True)
        return 0
    started = time.monotonic()
    jobs = [subprocess.Popen([sys.executable, "-m", "twbr_batch.warm", "--job", job]) for job in JOBS]
    failed = [job for job, process in zip(JOBS, jobs, strict=True) if process.wait() != 0]
    if failed:
        print(f"warm: {', '.join(failed)} failed (the first run compiles them instead)", file=sys.stderr)
        return 1
    print(f"warm: every kernel ready in {time.monotonic() - started:.1f} s ({Path(sys.executable).name})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
