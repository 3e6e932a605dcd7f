"""Lockstep cycles per second: sim_node against the trivial torque-echo node, as separate processes.

Each run simulates `--sim-seconds` at 1 kHz physics with a state/command exchange at 200 Hz and reads
the simulator's own count of exchanges and wall time (from the first step to the last). Prints the
median over runs of exchanges per second and the real-time factor.
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

from results_file import write_results

from twbr_runner.spawn import loopback_env, start_node
from twbr_sim.run_report import parse_run_report

ROOT = Path(__file__).resolve().parents[1]


def one_run(sim_seconds: float, scenario: str, domain: int, log_dir: Path) -> tuple[float, float]:
    env = loopback_env(domain)
    config = ROOT / "config"
    args = ["--params-file", str(config / "robot.yaml"), "--params-file", str(config / "sim.yaml"),
            "-p", f"duration:={sim_seconds}"]
    if scenario:
        args += ["-p", f"scenario:={scenario}"]
    sim = start_node("twbr_sim", "sim_node", args, env, log_dir, f"sim-{domain}")
    echo = start_node("twbr_sim", "torque_driver", ["-p", "profile:=echo"], env, log_dir, f"echo-{domain}")
    try:
        sim.wait(timeout=120 + 10 * sim_seconds)
    finally:
        sim.stop()
        echo.stop()
    report = parse_run_report(sim.stderr)
    if report is None:
        raise RuntimeError(f"no statistics from sim_node:\n{sim.output}")
    return report.exchanges_per_s, report.real_time_factor


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sim-seconds", type=float, default=20.0)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--scenario", default="dynamic_obstacles", help="world the simulator hosts ('' for none)")
    ap.add_argument("--json", help="write the figures to this file")
    args = ap.parse_args()
    base = int(os.environ.get("ROS_DOMAIN_ID", "150"))
    log_dir = Path(tempfile.mkdtemp(prefix="twbr-bench-"))
    rates, rtfs = [], []
    for k in range(args.runs):
        rate, rtf = one_run(args.sim_seconds, args.scenario, (base + 1 + k) % 230, log_dir)
        rates.append(rate)
        rtfs.append(rtf)
        print(f"run {k + 1}: {rate:8.1f} exchanges/s  real-time factor {rtf:5.2f}")
        time.sleep(0.2)
    result = {
        "cores": os.cpu_count(),
        "physics_rate_hz": 1000,
        "exchange_rate_hz": 200,
        "lockstep_exchanges_per_s_median": statistics.median(rates),
        "lockstep_real_time_factor_median": statistics.median(rtfs),
    }
    print(f"lockstep vs torque echo: median {result['lockstep_exchanges_per_s_median']:.1f} exchanges/s,"
          f" real-time factor {result['lockstep_real_time_factor_median']:.2f} ({os.cpu_count()} cores)")
    if args.json:
        write_results(args.json, result)
    return 0


if __name__ == "__main__":
    sys.exit(main())
