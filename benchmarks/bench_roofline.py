"""Roofline of the batch engine: flops per robot-step (counted), achieved Gflop/s, fraction of the peak.

- Counted: one robot of the scenario runs through the batch kernel itself, interpreted on counting
  numbers (flop_count.py, in a TWBR_JIT=off process), for --count-seconds of sim time: every operation the
  dynamics, motors, controller, planner and world execute is tallied, per component.
- Achieved: the batch engine's robot-steps/s at N = 10000 (the closed loop with the planner's
  --planner-method, robust by default, for the counted run too) times the counted flops per robot-step.
- Peak: nominal (cores x clock x 16 flops per cycle: two 4-wide FMA pipes, AVX2), and measured by a kernel
  of independent vectorised FMA chains on every core, the most this machine's numba code reaches.
- What limits: the physics alone (dynamics.step_batch, N = 10000) against the closed loop, and the time
  of the counted sin/cos calls alone, per robot-step.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import time
from pathlib import Path

import numba
import numpy as np
from results_file import write_results

HERE = Path(__file__).parent
FLOPS_PER_CYCLE = 16  # two 256-bit FMA pipes: 2 x 4 doubles x 2 flops (x86-64 with AVX2 and FMA)

COUNT = """
import json, sys
import numpy as np
sys.path.insert(0, {here!r})
import flop_count as fc
from twbr_batch import batch
from twbr_sim.robot_params import robot_params
from twbr_sim.scenario import load_scenario
from twbr_sim.scenario_files import find_scenario

components = {{"dynamics": "advance_upright", "controller": "cascade_compute", "planner": "plan_step",
              "world": "assess_obstacles", "obstacles": "agents_at", "target": "target_at",
              "sample's derivative": "derivatives", "wheel loads": "wheel_loads"}}
by_component = {{name: {{}} for name in components}}

def attribute(name, function):
    def counted(*args):
        before = dict(fc.TALLY)
        out = function(*args)
        into = by_component[name]
        for kind, n in fc.TALLY.items():
            into[kind] = into.get(kind, 0) + n - before.get(kind, 0)
        return out
    return counted

for name, attr in components.items():
    setattr(batch, attr, attribute(name, getattr(batch, attr)))
real_run = batch._run_robots
total = {{}}

def run_counting(*args):
    counted = [fc.counted_array(a) for a in args]
    with fc.counting() as tally:
        real_run(*counted)
        total.update(tally)
    results = args[11]
    results[:] = np.vectorize(float)(counted[11])

batch._run_robots = run_counting
scenario = load_scenario(find_scenario({scenario!r}))
out = batch.run_batch(scenario, [scenario.seed], robot_params()[None, :], duration={seconds!r},
                      planner={{"method": {method!r}}})
print(json.dumps({{"robot_steps": out.robot_steps, "total": total, "components": by_component}}))
"""


def count_flops(scenario: str, seconds: float, method: str) -> dict:
    env = {**os.environ, "TWBR_JIT": "off"}
    done = subprocess.run([sys.executable, "-c", COUNT.format(here=str(HERE), scenario=scenario, seconds=seconds,
                                                              method=method)],
                          env=env, capture_output=True, text=True, timeout=1800)
    if done.returncode != 0:
        raise RuntimeError(f"counting failed:\n{done.stderr[-3000:]}")
    return json.loads(done.stdout.strip().splitlines()[-1])


@numba.njit(fastmath={"contract"}, nogil=True)
def fma_chains(n, a, b, x):
    """n rounds of x[i] = x[i] * a + b: len(x) independent chains, which LLVM vectorises into FMAs."""
    for _ in range(n):
        for i in range(x.shape[0]):
            x[i] = x[i] * a + b
    return x.sum()


def measured_peak(seconds: float = 0.5) -> float:
    """Gflop/s of independent vectorised FMA chains on every core (the best of a few chain counts)."""

    @numba.njit(parallel=True, nogil=True)
    def on_every_core(n, xs):
        total = 0.0
        for t in numba.prange(xs.shape[0]):
            total += fma_chains(n, 0.999999, 1e-9, xs[t])
        return total

    cores = os.cpu_count() or 1
    best = 0.0
    for k in (32, 40, 48, 56, 64):
        xs = np.tile(np.arange(k, dtype=float), (cores, 1))
        on_every_core(10, xs)
        n = max(1, int(seconds * 2e9 / k))
        started = time.perf_counter()
        on_every_core(n, xs)
        best = max(best, 2.0 * k * n * cores / (time.perf_counter() - started) / 1e9)
    return best


def clock_ghz() -> float:
    mhz = [float(line.split(":")[1]) for line in Path("/proc/cpuinfo").read_text().splitlines()
           if line.startswith("cpu MHz")]
    return max(mhz) / 1000.0 if mhz else float("nan")


@numba.njit(fastmath={"contract"}, nogil=True)
def sin_cos_pairs(n, x):
    acc = 0.0
    for i in range(n):
        y = x + i * 1e-7
        acc += math.sin(y) + math.cos(y)
    return acc


def transcendental_ns(calls_per_step: float, steps: int = 2_000_000) -> float:
    """ns per robot-step of `calls_per_step` libm sin/cos calls alone (compiled, one core)."""
    sin_cos_pairs(10, 0.1)
    started = time.perf_counter()
    sin_cos_pairs(int(steps * calls_per_step / 2), 0.1)
    return (time.perf_counter() - started) / steps * 1e9


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="dynamic_obstacles")
    ap.add_argument("--count-seconds", type=float, default=5.0, help="sim time of the counted run")
    ap.add_argument("--sim-seconds", type=float, default=5.0, help="sim time per robot of the rate run")
    ap.add_argument("--robots", type=int, default=10000)
    ap.add_argument("--planner-method", default="robust", help="the planner's method (issue 19's target: robust)")
    ap.add_argument("--json", help="write the figures to this file")
    args = ap.parse_args()

    from twbr_batch.batch import run_batch
    from twbr_sim import dynamics as dyn
    from twbr_sim.robot_params import robot_params
    from twbr_sim.scenario import load_scenario
    from twbr_sim.scenario_files import find_scenario

    counted = count_flops(args.scenario, args.count_seconds, args.planner_method)
    steps = counted["robot_steps"]
    total = counted["total"]
    arithmetic = sum(total.get(k, 0) for k in ("add", "sub", "mul", "div"))
    per_step = arithmetic / steps
    trig = (total.get("sin", 0) + total.get("cos", 0)) / steps
    result: dict = {"scenario": args.scenario, "planner_method": args.planner_method, "counted_robot_steps": steps,
                    "flops_per_robot_step": per_step,
                    "compares_per_robot_step": total.get("compare", 0) / steps,
                    "math_calls_per_robot_step": {k: v / steps for k, v in sorted(total.items())
                                                  if k not in ("add", "sub", "mul", "div", "compare")}}
    print(f"counted over {steps} robot-steps ({args.count_seconds:g} s of {args.scenario}):"
          f" {per_step:.1f} flops per robot-step (+ {result['compares_per_robot_step']:.1f} comparisons,"
          f" {trig:.1f} sin/cos calls)")
    rest = per_step
    for name, tally in counted["components"].items():
        n = sum(tally.get(k, 0) for k in ("add", "sub", "mul", "div")) / steps
        result[f"flops_per_robot_step_{name}"] = n
        rest -= n
        print(f"  {name:>19}: {n:7.1f} flops per robot-step")
    result["flops_per_robot_step_loop"] = rest
    print(f"  {'the loop':>19}: {rest:7.1f} flops per robot-step (the batch loop's own: limits, tallies, timing)")

    scenario = load_scenario(find_scenario(args.scenario))
    run_batch(scenario, [1], robot_params()[None, :], duration=0.1)  # compile or load the kernels first
    n = args.robots
    started = time.perf_counter()
    out = run_batch(scenario, list(range(1, n + 1)), np.tile(robot_params(), (n, 1)), duration=args.sim_seconds,
                    planner={"method": args.planner_method})
    rate = out.robot_steps / (time.perf_counter() - started)
    achieved = rate * per_step / 1e9
    cores = os.cpu_count() or 1
    ghz = clock_ghz()
    nominal = cores * ghz * FLOPS_PER_CYCLE
    peak = measured_peak()
    result.update({"robot_steps_per_s": rate, "achieved_gflops": achieved, "cores": cores, "clock_ghz": ghz,
                   "nominal_peak_gflops": nominal, "measured_peak_gflops": peak,
                   "fraction_of_measured_peak": achieved / peak, "fraction_of_nominal_peak": achieved / nominal,
                   "svml": bool(numba.config.USING_SVML)})
    print(f"batch engine N = {n}: {rate:,.0f} robot-steps/s -> {achieved:.2f} Gflop/s")
    print(f"peak: nominal {nominal:.1f} Gflop/s ({cores} cores x {ghz:.2f} GHz x {FLOPS_PER_CYCLE} flops/cycle),"
          f" measured {peak:.1f} Gflop/s (vectorised FMA chains)")
    print(f"roofline: {per_step:.0f} flops/robot-step, {achieved:.2f} Gflop/s achieved,"
          f" {100 * achieved / peak:.1f} % of the measured peak ({100 * achieved / nominal:.1f} % of nominal)")

    # What limits: the physics alone, and the libm calls alone, per robot-step and core.
    params = np.tile(robot_params(), (n, 1))
    states = np.tile(dyn.initial_state(pitch=0.01), (n, 1))
    commands = np.zeros((n, 2))
    dyn.step_batch(params, states, commands, 1e-3, 1)
    physics_steps = 200
    started = time.perf_counter()
    dyn.step_batch(params, states, commands, 1e-3, physics_steps)
    physics_rate = n * physics_steps / (time.perf_counter() - started)
    loop_ns = cores / rate * 1e9
    physics_ns = cores / physics_rate * 1e9
    trig_ns = transcendental_ns(trig)
    result.update({"physics_only_robot_steps_per_s": physics_rate, "closed_loop_ns_per_robot_step_core": loop_ns,
                   "physics_ns_per_robot_step_core": physics_ns, "sin_cos_ns_per_robot_step_core": trig_ns})
    print(f"per robot-step and core: closed loop {loop_ns:.0f} ns, of which physics (step_batch alone)"
          f" {physics_ns:.0f} ns ({100 * physics_ns / loop_ns:.0f} %); its {trig:.0f} libm sin/cos calls alone"
          f" {trig_ns:.0f} ns ({100 * trig_ns / loop_ns:.0f} %); SVML {'on' if result['svml'] else 'off'}"
          f" (numba {numba.__version__})")
    if args.json:
        write_results(args.json, result)
    return 0


if __name__ == "__main__":
    sys.exit(main())
