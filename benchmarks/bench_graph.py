"""The node graph's own speed: lockstep real-time factor, control latency, resident memory per node.

Starts the nodes as separate processes over DDS (loopback, a domain of its own), as a user would in
several terminals, without a recorder. Graphs (physics 1 kHz, controller 200 Hz):
- lockstep_controller: sim_node + controller_node; the real-time factor (target >= 3) and the control
  latency (target p99 < 2 ms);
- lockstep_navigation: + planner_node on dynamic_obstacles, the simulator also waiting for its 20 Hz
  answers;
- realtime_echo: sim_node at real-time factor 1 answered by torque_driver's echo (zero torque at once, no
  controller): the floor of the realtime latency on this machine;
- realtime_controller, realtime_navigation: the same graphs in realtime at real-time factor 1;
- realtime_controller_pinned, realtime_navigation_pinned: sim_node (and planner_node) on CPU 0,
  controller_node on CPU 1 (parameter cpu_affinity).
The control latency is what the simulator measures: from publishing a state to receiving the command
computed from it (median and 99th percentile over the run). Each round runs every graph once, so a
slow spell of the machine falls on all of them alike; the figures are medians over the rounds. Each
node's resident memory is sampled (psutil) every 0.2 s, keeping the largest.
"""

from __future__ import annotations

import argparse
import contextlib
import itertools
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

import psutil
from results_file import write_results

from twbr_common.params import default_of
from twbr_planner.planner_params import NODE_SPECS as PLANNER_NODE_SPECS
from twbr_runner.runner import params_files
from twbr_runner.spawn import loopback_env, start_node
from twbr_sim.run_report import parse_run_report

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "config"
TARGET_RTF = 3.0
TARGET_P99_MS = 2.0
# label: (mode, what answers the simulator, CPUs by process or None)
CONFIGS: dict[str, tuple[str, str, dict[str, int] | None]] = {
    "lockstep_controller": ("lockstep", "controller", None),
    "lockstep_navigation": ("lockstep", "navigation", None),
    "realtime_echo": ("realtime", "echo", None),
    "realtime_controller": ("realtime", "controller", None),
    "realtime_navigation": ("realtime", "navigation", None),
    "realtime_controller_pinned": ("realtime", "controller", {"sim": 0, "controller": 1}),
    # The planner beside the simulator, which idles while the controller computes.
    "realtime_navigation_pinned": ("realtime", "navigation", {"sim": 0, "controller": 1, "planner": 0}),
}


def run_graph(mode: str, partner: str, pinning: dict[str, int] | None, sim_seconds: float, domain: int,
              log_dir: Path, node_jit: str | None = None) -> dict:
    """One run; node_jit: TWBR_JIT of controller_node and planner_node (None: their default, interpreted)."""
    env = loopback_env(domain)
    node_env = {**env, "TWBR_JIT": node_jit} if node_jit else env

    def node_args(name: str, *files: str) -> list[str]:
        pin = ["-p", f"cpu_affinity:=[{pinning[name]}]"] if pinning and name in pinning else []
        return [*params_files(CONFIG, *files), *pin]

    procs = {}
    if partner == "echo":
        procs["echo"] = start_node("twbr_sim", "torque_driver", [*node_args("echo"), "-p", "profile:=echo"], env,
                                   log_dir, f"echo-{domain}")
    else:
        procs["controller"] = start_node("twbr_control", "controller_node", node_args("controller", "controller.yaml"),
                                         node_env, log_dir, f"controller-{domain}")
    if partner == "navigation":
        procs["planner"] = start_node("twbr_planner", "planner_node", node_args("planner", "planner.yaml"),
                                      node_env, log_dir, f"planner-{domain}")
    sim_args = [*node_args("sim", "robot.yaml", "sim.yaml"), "-p", f"mode:={mode}", "-p", f"duration:={sim_seconds}",
                "-p", f"wait_for_subscribers:={len(procs)}"]
    if partner == "navigation":
        sim_args += ["-p", "scenario:=dynamic_obstacles"]
        if mode == "lockstep":
            sim_args += ["-p", f"lockstep_planner_rate:={default_of(PLANNER_NODE_SPECS, 'rate')}"]
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


def summarise(rows: list[dict]) -> dict:
    """Medians over the rounds, and the range of the latency's p99 (it moves most between rounds)."""
    out = {key: statistics.median(r[key] for r in rows) for key in rows[0]}
    p99 = [r["latency_p99_ms"] for r in rows]
    out["latency_p99_ms_min"], out["latency_p99_ms_max"] = min(p99), max(p99)
    out["runs_with_p99_under_target"] = sum(x < TARGET_P99_MS for x in p99)
    return out


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sim-seconds", type=float, default=20.0)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--json", help="write the figures to this file")
    ap.add_argument("--only", nargs="+", choices=CONFIGS, help="measure only these graphs (no summary)")
    ap.add_argument("--compare-jit", action="store_true",
                    help="run each graph twice per round, controller and planner interpreted (their default) and"
                         " compiled (TWBR_JIT=on), and print both (no summary)")
    args = ap.parse_args()
    base = int(os.environ.get("ROS_DOMAIN_ID", "150"))
    log_dir = Path(tempfile.mkdtemp(prefix="twbr-bench-graph-"))
    configs = {label: CONFIGS[label] for label in args.only or CONFIGS}
    result: dict = {"cores": os.cpu_count(), "physics_rate_hz": 1000, "controller_rate_hz": 200,
                    "sim_seconds": args.sim_seconds, "runs": args.runs}
    # Not measured: a short run that loads (or, after an edit, compiles and caches) every node's kernels.
    variants = {"": None} if not args.compare_jit else {" interpreted": "off", " compiled": "on"}
    run_graph("lockstep", "navigation", None, 1.0, base, log_dir, "on")
    rows: dict[str, list[dict]] = {label + v: [] for label in configs for v in variants}
    domain = base
    for k in range(args.runs):
        for (label, (mode, partner, pinning)), (variant, jit) in itertools.product(configs.items(), variants.items()):
            domain = (domain + 1) % 230
            row = run_graph(mode, partner, pinning, args.sim_seconds, domain, log_dir, jit)
            label += variant
            rows[label].append(row)
            print(f"round {k + 1} {label}: real-time factor {row['real_time_factor']:.2f},"
                  f" {row['exchanges_per_s']:.0f} exchanges/s, latency median {row['latency_median_ms']:.3f} ms,"
                  f" p99 {row['latency_p99_ms']:.3f} ms, RSS "
                  + ", ".join(f"{key[8:]} {v:.0f} MiB" for key, v in row.items() if key.startswith("rss_mib_")),
                  flush=True)
    for label, label_rows in rows.items():
        result[label] = summarise(label_rows)
    if args.only or args.compare_jit:
        for label, r in result.items():
            if isinstance(r, dict):
                print(f"{label}: medians over {args.runs} rounds: real-time factor {r['real_time_factor']:.2f},"
                      f" latency median {r['latency_median_ms']:.3f} ms, p99 {r['latency_p99_ms']:.3f} ms")
        return 0
    rtf = result["lockstep_controller"]["real_time_factor"]
    print(f"medians over {args.runs} rounds ({os.cpu_count()} cores): lockstep real-time factor {rtf:.2f} (sim +"
          f" controller; {result['lockstep_navigation']['real_time_factor']:.2f} with the planner)")
    for label in CONFIGS:
        r = result[label]
        print(f"  control latency {label}: median {r['latency_median_ms']:.3f} ms, p99 {r['latency_p99_ms']:.3f} ms"
              f" (rounds {r['latency_p99_ms_min']:.3f}-{r['latency_p99_ms_max']:.3f}; under"
              f" {TARGET_P99_MS:g} ms in {r['runs_with_p99_under_target']} of {args.runs})")
    p99 = {label: result[label]["latency_p99_ms"] for label in ("lockstep_controller", "realtime_controller")}
    # The issue lists the latency target under the lockstep graph and asks for the latency in realtime mode:
    # both readings are judged.
    print(f"targets: real-time factor >= {TARGET_RTF:g}: {'met' if rtf >= TARGET_RTF else 'NOT met'};"
          f" latency p99 < {TARGET_P99_MS:g} ms: lockstep {'met' if p99['lockstep_controller'] < TARGET_P99_MS else 'NOT met'},"
          f" realtime {'met' if p99['realtime_controller'] < TARGET_P99_MS else 'NOT met'}")
    if args.json:
        write_results(args.json, result)
    return 0


if __name__ == "__main__":
    sys.exit(main())
