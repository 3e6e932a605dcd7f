"""sim_node (the ideal model) against mujoco_driver (MuJoCo multibody, wheel-ground contact): the same
controller and planner, the same scenarios, side by side.

Part 1, through the node graph (the runner, `--driver sim|mujoco`, lockstep, ideal sensors): the step
scenario and the paper's three navigation scenarios, metrics from each bag, and the largest distance between
the two robots' paths at equal sim time (from odom). Part 2, the cores headless (twbr_batch.closed_loop, the
same kernels): manoeuvres where the wheels stop holding the ground, which only MuJoCo can act out.

    tools/run.sh python benchmarks/compare_engines.py [--json benchmarks/results/engines.json] [--domain N]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from results_file import write_results

from twbr_batch.closed_loop import run_closed_loop
from twbr_mujoco.physics import mujoco_simulator
from twbr_runner.bag_reader import read_messages

SCENARIOS = ("step", "static", "dynamic_target", "dynamic_obstacles")
DRIVERS = ("sim", "mujoco")
ROWS = {  # metrics.json key -> label
    "time_to_reach_s": "time to reach [s]",
    "min_clearance_m": "min clearance [m]",
    "v_rmse": "speed RMSE vs reference [m/s]",
    "w_rmse": "yaw-rate RMSE vs reference [rad/s]",
    "pitch_after_transient_max_abs": "max |pitch| after 2 s [rad]",
    "max_delivered_torque_nm": "max wheel torque [N·m]",
    "settle_time_s": "0.1 m/s step: settling [s]",
    "overshoot_pct": "0.1 m/s step: overshoot [%]",
    "undershoot": "0.1 m/s step: wrong-way dip [m/s]",
    "wheel_lift_events": "wheel lift events",
    "wheel_slip_events": "wheel slip events",
    "real_time_factor": "real-time factor of the graph",
}


def graph_run(scenario: str, driver: str, out: Path, domain: int) -> tuple[dict, np.ndarray]:
    env = {**os.environ, "ROS_DOMAIN_ID": str(domain), "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}
    run_root = out / f"{scenario}-{driver}"
    done = subprocess.run([sys.executable, "-m", "twbr_runner.runner", scenario, "--driver", driver, "--out",
                           str(run_root), "--domain", str(domain), "--quiet", "--no-figures"],
                          env=env, capture_output=True, text=True, timeout=900)
    if done.returncode != 0:
        raise RuntimeError(f"{scenario} on {driver}: {done.stdout}{done.stderr}")
    (run_dir,) = [d for d in run_root.iterdir() if d.is_dir()]
    m = json.loads((run_dir / "metrics.json").read_text())
    m["pitch_after_transient_max_abs"] = max(abs(m["pitch_after_transient_min_rad"]),
                                             abs(m["pitch_after_transient_max_rad"]))
    m.update(m.get("velocity_step") or {})
    odom = read_messages(run_dir / "bag", ["/odom"])["/odom"]
    path = np.array([(msg.header.stamp.sec * 10**9 + msg.header.stamp.nanosec, msg.pose.pose.position.x,
                      msg.pose.pose.position.y) for _, msg in odom])
    return m, path


def path_gap(a: np.ndarray, b: np.ndarray) -> float:
    """Largest distance between two paths at the stamps both have [m]."""
    _, ia, ib = np.intersect1d(a[:, 0], b[:, 0], return_indices=True)
    return float(np.hypot(a[ia, 1] - b[ib, 1], a[ia, 2] - b[ib, 2]).max())


def manoeuvres() -> list[dict]:
    """Hard cases for the wheels, on the cores: what each engine says of lift and slip, and what happens."""

    def hard_turn(t, _sim):  # the controller's limits: 1.5 m/s, then a 3 rad/s yaw-rate step
        return (1.5 if t > 0.5 else 0.0, 3.0 if t > 4.0 else 0.0)

    def launch(t, _sim):  # a 1 m/s step (ramped at the controller's 0.36 m/s^2) on ice, mu = 0.03
        return (1.0 if t > 0.5 else 0.0, 0.0)

    cases = [("hard turn (1.5 m/s, 3 rad/s yaw-rate step)", hard_turn, {}, 6.0),
             ("1 m/s step on ice (mu = 0.03)", launch, {"traction.friction": 0.03}, 5.0)]
    rows = []
    run_closed_loop(0.5, hard_turn)  # compile the kernels before anything is timed
    run_closed_loop(0.5, hard_turn, engine=mujoco_simulator)
    for name, reference, sim, duration in cases:
        row = {"case": name}
        for label, engine in (("sim", None), ("mujoco", mujoco_simulator)):
            kw = {} if engine is None else {"engine": engine}
            start = time.perf_counter()
            tr = run_closed_loop(duration, reference, sim=sim, **kw)
            wall = time.perf_counter() - start
            row[label] = {
                "fallen": tr.fallen, "lift_events": tr.traction.lift_events,
                "lifted_time_s": tr.traction.lifted_samples / 200.0, "slip_events": tr.traction.slip_events,
                "slipping_time_s": tr.traction.slipping_samples / 200.0,
                "max_abs_pitch_rad": float(np.abs(tr.pitch_true).max()),
                "final_speed_m_s": float(tr.velocity_true[-1]),
                "real_time_factor": float(tr.t[-1]) / wall,  # the cores alone, no DDS
            }
        rows.append(row)
    return rows


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--json", type=Path)
    ap.add_argument("--domain", type=int, default=int(os.environ.get("ROS_DOMAIN_ID", "0")))
    a = ap.parse_args()
    results: dict = {"graph": {}, "manoeuvres": manoeuvres()}
    with tempfile.TemporaryDirectory(prefix="twbr-engines-") as tmp:
        for scenario in SCENARIOS:
            runs = {d: graph_run(scenario, d, Path(tmp), a.domain) for d in DRIVERS}
            results["graph"][scenario] = {d: runs[d][0] for d in DRIVERS}
            results["graph"][scenario]["path_gap_m"] = path_gap(runs["sim"][1], runs["mujoco"][1])
    print("| scenario | metric | sim_node | mujoco_driver |\n|---|---|---|---|")
    for scenario, r in results["graph"].items():
        for key, label in ROWS.items():
            values = [r[d].get(key) for d in DRIVERS]
            if all(v is None for v in values):
                continue
            print(f"| {scenario} | {label} | " + " | ".join(f"{v:.4g}" if isinstance(v, float) else str(v)
                                                           for v in values) + " |")
        print(f"| {scenario} | largest distance between the paths [m] | {r['path_gap_m']:.3g} | |")
    print("\n| manoeuvre (cores) | engine | lift events (time) | slip events (time) | max abs(pitch) [rad] |"
          " final speed [m/s] | fallen | real-time factor (cores) |\n|---|---|---|---|---|---|---|---|")
    for row in results["manoeuvres"]:
        for d in DRIVERS:
            r = row[d]
            print(f"| {row['case']} | {d} | {r['lift_events']} ({r['lifted_time_s']:.3f} s) | {r['slip_events']}"
                  f" ({r['slipping_time_s']:.3f} s) | {r['max_abs_pitch_rad']:.3f} | {r['final_speed_m_s']:.3f} |"
                  f" {r['fallen']} | {r['real_time_factor']:.1f} |")
    if a.json:
        write_results(a.json, json.loads(json.dumps(results, default=str)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
