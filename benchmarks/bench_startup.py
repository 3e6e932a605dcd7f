"""The deployable nodes' footprint: from process start to ready, and resident memory, interpreted (their
default) and compiled (TWBR_JIT=on).

"Ready" is the node's first log line, written at the end of its constructor: parameters declared and
checked, publishers, subscriptions and services created. Resident memory is read 1 s later. Medians over
`--runs` starts (the compiled kernels come from numba's cache, warmed by one start that is not counted).

    tools/run.sh python benchmarks/bench_startup.py [--runs 5] [--json FILE]
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time
from pathlib import Path

import psutil
from results_file import write_results

from twbr_runner.runner import params_files
from twbr_runner.spawn import loopback_env, node_executable

ROOT = Path(__file__).resolve().parents[1]
NODES = {"controller_node": ("twbr_control", "controller.yaml"), "planner_node": ("twbr_planner", "planner.yaml")}
TARGET_S, TARGET_MIB = 0.5, 100.0


def start_once(name: str, jit: str, domain: int) -> tuple[float, float]:
    package, params = NODES[name]
    env = {**loopback_env(domain), "TWBR_JIT": jit}
    argv = [str(node_executable(package, name)), "--ros-args", *params_files(ROOT / "config", params)]
    begin = time.monotonic()
    proc = subprocess.Popen(argv, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        line = proc.stderr.readline()
        ready = time.monotonic() - begin
        if not line.startswith("[INFO]"):
            raise RuntimeError(f"{name} did not start: {line}{proc.stderr.read() if proc.poll() is not None else ''}")
        time.sleep(1.0)
        rss = psutil.Process(proc.pid).memory_info().rss / 2**20
    finally:
        proc.terminate()
        proc.wait(timeout=10)
    return ready, rss


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--domain", type=int, default=88)
    ap.add_argument("--json", type=Path)
    a = ap.parse_args(argv)
    figures: dict[str, dict[str, float]] = {}
    for name in NODES:
        start_once(name, "on", a.domain)  # numba's cache filled, the files in the page cache
        for jit in ("off", "on"):
            rows = [start_once(name, jit, a.domain) for _ in range(a.runs)]
            ready, rss = statistics.median(r[0] for r in rows), statistics.median(r[1] for r in rows)
            figures[f"{name} {'interpreted' if jit == 'off' else 'compiled'}"] = {
                "ready_s": ready, "ready_s_min": min(r[0] for r in rows), "ready_s_max": max(r[0] for r in rows),
                "rss_mib": rss}
    for label, f in figures.items():
        print(f"{label}: ready after {f['ready_s']:.2f} s (median of {a.runs}; {f['ready_s_min']:.2f}-"
              f"{f['ready_s_max']:.2f}), {f['rss_mib']:.0f} MiB resident")
    deployed = [f for label, f in figures.items() if label.endswith("interpreted")]
    print(f"targets (interpreted, the default): ready <= {TARGET_S:g} s:"
          f" {'met' if all(f['ready_s'] <= TARGET_S for f in deployed) else 'NOT met'};"
          f" <= {TARGET_MIB:g} MiB: {'met' if all(f['rss_mib'] <= TARGET_MIB for f in deployed) else 'NOT met'}")
    if a.json:
        a.json.parent.mkdir(parents=True, exist_ok=True)
        write_results(a.json, figures)
    return 0


if __name__ == "__main__":
    sys.exit(main())
