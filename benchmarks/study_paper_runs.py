"""The paper's three navigation scenarios at their default seed (7), as README.md and docs/scenarios.md
show them: when the target is reached, the least clearance, and the pitch range over the whole run; and
their success over seeds 1-1000 (reached, no collision, no fall), nominal with ideal sensors and with
masses, inertias and motor constant perturbed by ±20 % and realistic sensors.

The batch engine runs what the node graph runs (`make demo`: test_e2e_suite and test_e2e_navigation prove
the same path), so these are the graph's figures, in a second instead of minutes.

    tools/run.sh python benchmarks/study_paper_runs.py   # -> benchmarks/results/paper_runs.json
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
from pathlib import Path

import numpy as np
from results_file import RESULTS, write_results

from twbr_batch.batch import Z_MIN_CLEARANCE, Z_REACHED_AT, run_batch
from twbr_batch.montecarlo import Study, run_study
from twbr_sim.robot_params import robot_params
from twbr_sim.scenario import load_scenario
from twbr_sim.scenario_files import find_scenario

SCENARIOS = ("static", "dynamic_target", "dynamic_obstacles")


def paper_run(name: str) -> dict[str, float]:
    scenario = load_scenario(find_scenario(name))
    run = run_batch(scenario, [scenario.seed], robot_params()[None, :], record=True, duration=scenario.duration)
    z, trace = run.table[0], run.trace(0)
    reached = float(z[Z_REACHED_AT])
    return {"seed": scenario.seed, "reached_at_s": None if math.isnan(reached) else reached,
            "min_clearance_m": float(z[Z_MIN_CLEARANCE]), "pitch_abs_max_rad": float(np.abs(trace["pitch_true"]).max())}


SEEDS = 1000
STUDIES = {"nominal": (0.0, "ideal"), "perturbed_realistic": (0.2, "realistic")}


def success_pct(name: str, perturbation: float, sensors: str, runs: int) -> float:
    study = Study(find_scenario(name), runs, perturbation, sensors=sensors)
    with tempfile.TemporaryDirectory() as out:
        rows = run_study(study, Path(out), progress=False)
    return 100.0 * sum(r.reached and r.collisions == 0 and not r.fallen for r in rows) / len(rows)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", default=str(RESULTS / "paper_runs.json"))
    args = ap.parse_args()
    runs = {name: paper_run(name) for name in SCENARIOS}
    for name, r in runs.items():
        print(f"{name:18s} seed {r['seed']}: reached at {r['reached_at_s']} s, min clearance"
              f" {r['min_clearance_m']:.2f} m, |pitch| <= {r['pitch_abs_max_rad']:.4f} rad")
    for name, r in runs.items():
        r["success_pct"] = {label: success_pct(name, p, sensors, SEEDS) for label, (p, sensors) in STUDIES.items()}
        print(f"{name:18s} success over {SEEDS} seeds: " + ", ".join(f"{k} {v:.1f} %" for k, v in
                                                                     r["success_pct"].items()))
    write_results(args.json, {"scenarios": runs, "seeds": SEEDS})
    return 0


if __name__ == "__main__":
    sys.exit(main())
