"""The graph on what the robot sees (issue 36): the runner with `--perception lidar` starts tracker_node
between the simulator's scan and the planner; the run reaches its target, the tracker's figures are in
metrics.json, and the run is the same on an idle and on a loaded machine."""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest
from conftest import RUNNER, busy_loops
from test_e2e_suite import assert_the_graph_took_the_batch_engines_path

from twbr_runner.bag_reader import read_messages
from twbr_runner.metrics import series_from_messages
from twbr_sim.scenario import load_scenario
from twbr_sim.scenario_files import find_scenario

pytestmark = pytest.mark.e2e

SCENARIO = "suite/head_on"  # one obstacle coming straight at the robot: it must be seen, tracked and passed


def run(out: Path, domain: int) -> tuple[dict, Path]:
    env = {**os.environ, "ROS_DOMAIN_ID": str(domain), "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}
    done = subprocess.run([*RUNNER, SCENARIO, "--out", str(out), "--perception", "lidar", "--quiet", "--no-figures"],
                          env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout + done.stderr
    (run_dir,) = out.iterdir()
    assert "tracker: " in (run_dir / "command.txt").read_text()
    return json.loads((run_dir / "metrics.json").read_text()), run_dir


@pytest.mark.alone
def test_on_the_lidar_the_robot_passes_what_it_tracks_the_same_way_idle_or_loaded(tmp_path, ros_domain):
    idle, idle_dir = run(tmp_path / "idle", ros_domain)
    assert idle["perception"] == "lidar"
    assert idle["reached"] and idle["collisions"] == 0 and idle["min_clearance_m"] > 0.2, idle
    assert idle["lockstep_timeouts"] == 0
    assert idle["messages"]["/scan"] >= 10 * idle["sim_time_s"] - 2  # 10 Hz of sim time
    assert idle["messages"]["/obstacles"] == idle["messages"]["/scan"]  # one list per scan, none dropped
    assert idle["messages"]["/obstacles_truth"] > 0  # the world's own, kept apart for the judge
    tracking = idle["tracking"]
    # The obstacle coming head-on, while the robot sees it: matched nearly always, within a few cm.
    assert tracking["judged"] > 100 and tracking["missed_pct"] < 5.0, tracking
    assert tracking["position_rmse_m"] < 0.06 and tracking["velocity_rmse_mps"] < 0.15, tracking
    assert tracking["id_switches"] == 0 and tracking["latency_p99_ms"] > 0.0, tracking
    # The target detector's looks (10 Hz) fused by the tracker: within a few cm of the world's target.
    assert idle["messages"]["/target_detections"] == idle["messages"]["/scan"]
    # (from its first sighting on: the obstacle coming head-on hides the target at the start)
    assert tracking["target_estimates"] >= 0.5 * idle["messages"]["/target_detections"]
    assert tracking["target_position_rmse_m"] < 0.1 and tracking["target_error_p95_m"] < 0.2, tracking
    # and the batch engine on the LiDAR takes its path and judges its tracker alike (the suite's check)
    scenario = load_scenario(find_scenario(SCENARIO))
    assert_the_graph_took_the_batch_engines_path(idle_dir, idle, scenario, scenario.seed, "lidar")

    with busy_loops():
        loaded, loaded_dir = run(tmp_path / "loaded", ros_domain)
    a, b = (series_from_messages(read_messages(d / "bag", ["/odom", "/clock"])) for d in (idle_dir, loaded_dir))
    common, ia, ib = np.intersect1d(a.odom_t, b.odom_t, return_indices=True)
    assert len(common) >= 0.99 * max(len(a.odom_t), len(b.odom_t))
    gap = np.hypot(a.x_c[ia] - b.x_c[ib], a.y_c[ia] - b.y_c[ib])
    assert gap.max() <= 1e-9, (gap.max(), common[np.argmax(gap)])
    for key in ("time_to_reach_s", "min_clearance_m", "lockstep_timeouts"):
        assert idle[key] == loaded[key], key
    for key in ("position_rmse_m", "id_switches", "missed", "false_tracks", "target_position_rmse_m"):
        assert idle["tracking"][key] == loaded["tracking"][key], key
