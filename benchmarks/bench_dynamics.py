"""Steps per second of the dynamics core (dynamics + motors + driver, RK4 at 1 kHz).

Prints three figures: the compiled loop (what a batch or headless run pays), one rk4_step called from
Python per step (what sim_node pays per physics step), and Simulator.advance (the node's whole step
path: command admission, fall check, world). The issue's target is 50,000 single-robot steps/s.
"""

from __future__ import annotations

import argparse
import os
import sys
import time

import numpy as np
from results_file import write_results

from twbr_common.params import defaults
from twbr_sim import dynamics as dyn
from twbr_sim.robot_params import robot_params
from twbr_sim.scenario import load_scenario
from twbr_sim.scenario_files import find_scenario
from twbr_sim.simulator import SIM_SPECS, Simulator

H = 1e-3


def best_rate(fn, steps: int, repeats: int = 5) -> float:
    best = 0.0
    for _ in range(repeats):
        t = time.perf_counter()
        fn(steps)
        best = max(best, steps / (time.perf_counter() - t))
    return best


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("json", nargs="?", help="write the figures to this file (make bench: results/dynamics.json)")
    args = ap.parse_args()
    p = robot_params()
    s = dyn.initial_state(pitch=np.pi - 0.3)  # hanging: a long run stays in range
    work = dyn.new_work()
    dyn.simulate(p, s, 0.1, -0.1, H, 10, work)  # compile (or load the cache) outside the timing

    def compiled(n: int) -> None:
        dyn.simulate(p, s, 0.1, -0.1, H, n, work)

    def python_called(n: int) -> None:
        for _ in range(n):
            dyn.rk4_step(p, s, 0.1, -0.1, H, work)

    sc = load_scenario(find_scenario("dynamic_obstacles"))
    sim = Simulator(p, defaults(SIM_SPECS), sc, seed=sc.seed)
    # Opposite torques: it turns in place and stays exactly upright.

    def node_path(n: int) -> None:
        sim.offer_command(sim.time, 0.1, -0.1)  # a fresh command per batch: we time the step, not the timeout
        sim.advance(n)
        assert not sim.fallen

    results = {
        "cores": os.cpu_count(),
        "dynamics_steps_per_s_compiled_loop": best_rate(compiled, 1_000_000),
        "dynamics_steps_per_s_python_called": best_rate(python_called, 100_000),
        "simulator_advance_steps_per_s": best_rate(node_path, 50_000),
    }
    for key, value in results.items():
        print(f"{key:<40} {value:>14,.0f}")
    target = 50_000
    ok = results["dynamics_steps_per_s_python_called"] >= target
    print(f"target >= {target:,} single-robot steps/s (python-called RK4 step): {'met' if ok else 'NOT met'}")
    if args.json:
        write_results(args.json, results)
    return 0


if __name__ == "__main__":
    sys.exit(main())
