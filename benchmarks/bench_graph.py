"""The node graph's own speed: lockstep real-time factor, realtime control latency, resident memory per node.

Starts the nodes as separate processes over DDS (loopback, a domain of its own), as a user would in
several terminals, without a recorder:
- lockstep, sim_node + controller_node (physics 1 kHz, controller 200 Hz): the real-time factor and the
  exchanges per second the simulator reports; target >= 3;
- lockstep, the navigation graph (sim_node + controller_node + planner_node on dynamic_obstacles, the
  simulator also waiting for the planner's 20 Hz answers);
- realtime, the navigation graph at real-time factor 1: the control latency the simulator measures, from
  publishing a state to receiving the command computed from it (median and 99th percentile); target
  p99 < 2 ms;
and samples each node's resident memory (psutil) every 0.2 s, keeping the largest.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

import psutil

from twbr_common.processes import loopback_env, start_node
from twbr_runner.runner import params_files
from twbr_sim.run_report import parse_run_report

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "config"
TARGET_RTF = 3.0
TARGET_P99_MS = 2.0


def run_graph(mode: str, planner: bool, sim_seconds: float, domain: int, log_dir: Path) -> dict:
    env = loopback_env(domain)
    procs = {"controller": start_node("twbr_control", "controller_node", params_files(CONFIG, "controller.yaml"), env, log_dir,
                                      f"controller-{domain}")}
    if planner:
        procs["planner"] = start_node("twbr_planner", "planner_node", params_files(CONFIG, "planner.yaml"), env, log_dir,
                                      f"planner-{domain}")
    sim_args = [*params_files(CONFIG, "robot.yaml", "sim.yaml"), "-p", f"mode:={mode}", "-p", f"duration:={sim_seconds}",
                "-p", f"wait_for_subscribers:={len(procs)}"]
    if planner:
        sim_args += ["-p", "scenario:=dynamic_obstacles"]
        if mode == "lockstep":
            sim_args += ["-p", "lockstep_planner_rate:=20.0"]
    procs["sim"] = sim = start_node("twbr_sim", "sim_node", sim_args, env, log_dir, f"sim-{mode}-{domain}")
    rss = dict.fromkeys(procs, 0)
    try:
        deadline = time.monotonic() + 120 + 10 * sim_seconds
        while sim.running and time.monotonic() < deadline:
            for name, proc in procs.items():
                with contextlib.suppress(psutil.NoSuchProcess):
                    rss[name] = max(rss[name], psutil.Process(proc.proc.pid).memory_info().rss)
            time.sleep(0.2)
        sim.wait(timeout=10)
    finally:
        for proc in procs.values():
            proc.stop()
    report = parse_run_report(sim.stderr)
    if report is None or report.latency_median_ms is None:
        raise RuntimeError(f"no figures from sim_node ({mode}):\n{sim.output}")
    return {"real_time_factor": report.real_time_factor, "exchanges_per_s": report.exchanges_per_s,
            "latency_median_ms": report.latency_median_ms, "latency_p99_ms": report.latency_p99_ms,
            **{f"rss_mib_{name}": value / 2**20 for name, value in rss.items()}}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sim-seconds", type=float, default=20.0)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--json", help="write the figures to this file")
    args = ap.parse_args()
    base = int(os.environ.get("ROS_DOMAIN_ID", "150"))
    log_dir = Path(tempfile.mkdtemp(prefix="twbr-bench-graph-"))
    configs = {"lockstep_controller": ("lockstep", False), "lockstep_navigation": ("lockstep", True),
               "realtime_controller": ("realtime", False), "realtime_navigation": ("realtime", True)}
    result: dict = {"cores": os.cpu_count(), "physics_rate_hz": 1000, "controller_rate_hz": 200,
                    "sim_seconds": args.sim_seconds, "runs": args.runs}
    domain = base
    for label, (mode, planner) in configs.items():
        rows = []
        for k in range(args.runs):
            domain = (domain + 1) % 230
            row = run_graph(mode, planner, args.sim_seconds, domain, log_dir)
            rows.append(row)
            print(f"{label} run {k + 1}: real-time factor {row['real_time_factor']:.2f},"
                  f" {row['exchanges_per_s']:.0f} exchanges/s, latency median {row['latency_median_ms']:.3f} ms,"
                  f" p99 {row['latency_p99_ms']:.3f} ms, RSS "
                  + ", ".join(f"{k[8:]} {v:.0f} MiB" for k, v in row.items() if k.startswith("rss_mib_")))
        result[label] = {key: statistics.median(r[key] for r in rows) for key in rows[0]}
    rtf = result["lockstep_controller"]["real_time_factor"]
    p99 = result["realtime_navigation"]["latency_p99_ms"]
    p99_lockstep = result["lockstep_controller"]["latency_p99_ms"]
    print(f"medians over {args.runs} runs ({os.cpu_count()} cores): lockstep real-time factor {rtf:.2f} (sim +"
          f" controller; {result['lockstep_navigation']['real_time_factor']:.2f} with the planner); control latency"
          f" p99 lockstep {p99_lockstep:.3f} ms (sim + controller), realtime median"
          f" {result['realtime_navigation']['latency_median_ms']:.3f} ms, p99 {p99:.3f} ms (navigation graph)")
    # The issue lists the latency target under the lockstep graph and asks for the latency in realtime mode:
    # both readings are printed.
    print(f"targets: real-time factor >= {TARGET_RTF:g}: {'met' if rtf >= TARGET_RTF else 'NOT met'};"
          f" latency p99 < {TARGET_P99_MS:g} ms: lockstep {'met' if p99_lockstep < TARGET_P99_MS else 'NOT met'},"
          f" realtime {'met' if p99 < TARGET_P99_MS else 'NOT met'}")
    if args.json:
        Path(args.json).write_text(json.dumps(result, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
