"""Closed-loop lockstep speed and control latency: the full recorded graph of `run_scenario`.

Runs the scenario (default: the step) `--runs` times through the runner (recorder, controller_node,
command_player and sim_node as separate processes over DDS) and reads the simulator's own figures: the
real-time factor of the stepping, and the control latency of every exchange, from the moment it
publishes a state to the moment the command computed from that state arrives back (median and 99th
percentile). Prints the median over runs.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
from pathlib import Path

from results_file import write_results

from twbr_runner.runner import RunOptions, run
from twbr_sim.run_report import parse_run_report


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="step")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--json", help="write the figures to this file")
    args = ap.parse_args()
    out = Path(tempfile.mkdtemp(prefix="twbr-bench-loop-"))
    base = int(os.environ.get("ROS_DOMAIN_ID", "150"))
    rows = []
    for k in range(args.runs):
        code, run_dir = run(RunOptions(Path(args.scenario), out, domain=(base + 1 + k) % 230, figures=False,
                                       quiet=True))
        report = parse_run_report((run_dir / "logs" / "sim.err").read_text())
        if code != 0 or report is None or report.latency_median_ms is None:
            print(f"run {k + 1} failed (exit {code}); see {run_dir}/logs", file=sys.stderr)
            return 1
        row = {"exchanges_per_s": report.exchanges_per_s, "real_time_factor": report.real_time_factor,
               "latency_median_ms": report.latency_median_ms, "latency_p99_ms": report.latency_p99_ms}
        rows.append(row)
        print(f"run {k + 1}: {row['exchanges_per_s']:7.1f} exchanges/s, real-time factor {row['real_time_factor']:5.2f},"
              f" control latency median {row['latency_median_ms']:.3f} ms, p99 {row['latency_p99_ms']:.3f} ms")
    result = {key: statistics.median(r[key] for r in rows) for key in rows[0]}
    result.update(cores=os.cpu_count(), scenario=args.scenario, runs=args.runs)
    print(f"closed loop ({args.scenario}, recorded): median real-time factor {result['real_time_factor']:.2f},"
          f" {result['exchanges_per_s']:.1f} exchanges/s; control latency median {result['latency_median_ms']:.3f} ms,"
          f" p99 {result['latency_p99_ms']:.3f} ms ({os.cpu_count()} cores)")
    if args.json:
        write_results(args.json, result)
    return 0


if __name__ == "__main__":
    sys.exit(main())
