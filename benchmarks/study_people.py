"""Issue 35's people layouts, every planner method side by side: the figures README.md and docs/planner.md
cite (success, outcome counts, median time to reach, clearance), through the suite's own runner and judge.

    tools/run.sh python benchmarks/study_people.py [-n 30] [--json benchmarks/results/people.json]

30 seeds per layout and method take ~5 minutes on 2 cores (dwa's rollouts are most of it); issue 35's
targets ask for 1000 (`make suite`).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

from results_file import RESULTS, write_results

from twbr_batch.suite import chosen_scenarios, run_suite
from twbr_planner.planner_params import METHODS

LAYOUTS = ("crowd_crossing", "people_flow", "narrow_passage", "overtaken_by_crowd", "clutter_movers",
           "target_behind_wall", "reactive_crowd")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-n", "--runs", type=int, default=30, help="seeds per layout and method (1..n)")
    ap.add_argument("--methods", default=",".join(m for m in METHODS if m != "paper"))
    ap.add_argument("--json", default=str(RESULTS / "people.json"))
    args = ap.parse_args()
    methods = args.methods.split(",")
    with tempfile.TemporaryDirectory() as out:
        summary = run_suite(Path(out), args.runs, {m: {"method": m} for m in methods},
                            chosen_scenarios(",".join(LAYOUTS)), figures=False)
    print(f"| layout | {' | '.join(methods)} |")
    for layout, by_method in summary.items():
        print(f"| {layout} | " + " | ".join(f"{100 * by_method[m]['success_rate']:.1f} %" for m in methods) + " |")
    write_results(args.json, {"runs_per_cell": args.runs, "methods": methods, "layouts": summary})
    return 0


if __name__ == "__main__":
    sys.exit(main())
