"""Robustness of the two control laws (issue 17): the paper names the PID's sensitivity to parameter changes
as its weakness. For pid and lqr, with ideal and with realistic sensors (config/sensors_realistic.yaml),
on the nominal robot and with masses, inertias and the motor constant each drawn within ±20 % and ±40 %
(montecarlo's perturbation, seeded), N seeds each through the batch engine:

- the paper's step scenario (0.1 m/s at 1 s): the share that stays up, the share that meets the paper's
  response (settles within 1.5 s in the 5 % band, steady error < 2 %), the settling time's median and p95,
  the largest roll-back (in % of the step);
- the paper's dynamic-obstacle scenario (its planner, as the scenario pins): the share that reaches the
  target without a collision or a fall, and the runs in which a wheel would have lifted or slipped.

The gains are designed on the nominal robot (config/controller.yaml): the perturbed robots are what the
controller does not know. Prints a Markdown table and writes benchmarks/results/robustness.json.

    tools/run.sh python benchmarks/study_robustness.py            # 1000 seeds per cell (about 10 min)
    tools/run.sh python benchmarks/study_robustness.py -n 100     # a quick look
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np
from results_file import write_results

from twbr_batch import montecarlo as mc
from twbr_batch.batch import Z_COLLISIONS, Z_FALLEN, Z_LIFT_EVENTS, Z_REACHED_AT, Z_SLIP_EVENTS, run_batch
from twbr_batch.response import step_response
from twbr_sim.robot_params import robot_params
from twbr_sim.scenario import load_scenario
from twbr_sim.scenario_files import find_scenario, sensor_preset

CONTROLLERS = ("pid", "lqr")
SENSORS = ("ideal", "realistic")
PERTURBATIONS = (0.0, 0.2, 0.4)


def robots(seeds: list[int], perturbation: float) -> np.ndarray:
    return np.stack([robot_params(mc.perturbed_robot(mc.perturbation_factors(s, perturbation))) for s in seeds])


def step_cell(seeds: list[int], controller: str, sensors: str, perturbation: float) -> dict:
    scenario = load_scenario(find_scenario("step"))
    result = run_batch(scenario, seeds, robots(seeds, perturbation), control={"controller": controller},
                       sim=sensor_preset(sensors), record=True)
    settle, rollback, met = [], [], 0
    for i in range(len(seeds)):
        if result.table[i, Z_FALLEN]:
            continue
        trace = result.trace(i)
        r = step_response(trace["t"], trace["velocity_true"], trace["velocity_ref"])
        settle.append(r.settle_time_s)
        rollback.append(100.0 * r.undershoot / abs(r.final - r.initial))
        met += r.settle_time_s <= 1.5 and r.steady_state_error_pct < 2.0
    n = len(seeds)
    finite = [s for s in settle if math.isfinite(s)]
    return {
        "up_pct": 100.0 * len(settle) / n, "step_met_pct": 100.0 * met / n,
        "settle_median_s": float(np.median(finite)) if finite else None,
        "settle_p95_s": float(np.percentile(settle, 95)) if settle else None,
        "rollback_max_pct": float(max(rollback)) if rollback else None,
    }


def navigation_cell(seeds: list[int], controller: str, sensors: str, perturbation: float) -> dict:
    scenario = load_scenario(find_scenario("dynamic_obstacles"))
    z = run_batch(scenario, seeds, robots(seeds, perturbation), control={"controller": controller},
                  sim=sensor_preset(sensors)).table
    success = ~np.isnan(z[:, Z_REACHED_AT]) & (z[:, Z_COLLISIONS] == 0) & (z[:, Z_FALLEN] == 0)
    return {"success_pct": 100.0 * success.mean(), "fallen": int(z[:, Z_FALLEN].sum()),
            "lifted_runs": int((z[:, Z_LIFT_EVENTS] > 0).sum()), "slipped_runs": int((z[:, Z_SLIP_EVENTS] > 0).sum())}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("-n", "--runs", type=int, default=1000, help="seeds per cell (default 1000)")
    args = ap.parse_args()
    seeds = list(range(1, args.runs + 1))
    rows = []
    started = time.monotonic()
    print("| controller | sensors | parameters | stays up (step) | meets the paper's step | settle median / p95 |"
          " largest roll-back | dynamic obstacles: success | wheel lifted / slipped (runs) |")
    print("|---|---|---|---|---|---|---|---|---|")
    for controller in CONTROLLERS:
        for sensors in SENSORS:
            for perturbation in PERTURBATIONS:
                step = step_cell(seeds, controller, sensors, perturbation)
                nav = navigation_cell(seeds, controller, sensors, perturbation)
                rows.append({"controller": controller, "sensors": sensors, "perturbation": perturbation, **step,
                             **nav})
                label = f"±{100 * perturbation:g} %" if perturbation else "nominal"
                settle = (f"{step['settle_median_s']:.2f} / {step['settle_p95_s']:.2f} s"
                          if step["settle_median_s"] is not None else "-")
                rollback = f"{step['rollback_max_pct']:.0f} %" if step["rollback_max_pct"] is not None else "-"
                print(f"| {controller} | {sensors} | {label} | {step['up_pct']:.1f} % | {step['step_met_pct']:.1f} % |"
                      f" {settle} | {rollback} | {nav['success_pct']:.1f} % | {nav['lifted_runs']} /"
                      f" {nav['slipped_runs']} |", flush=True)
    out = Path(__file__).parent / "results" / "robustness.json"
    write_results(out, {"runs_per_cell": args.runs, "wall_s": time.monotonic() - started, "rows": rows})
    print(f"{args.runs} seeds per cell, {time.monotonic() - started:.0f} s; written to {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
