"""The hard suite through the node graph: each scenario for one seed with the robust planner, against the
batch engine's run of the same seed (the same cores and the messages' roundings: the same path to the last
bit).

The runner starts recorder, controller_node, planner_node (method robust) and sim_node as processes in
lockstep; the seed's varied layout is built by the simulator's world exactly as the batch engine builds
it. On the truth, and on the LiDAR (tracker_node between the scan and the planner; the batch engine runs
the same scan, tracker and target filter kernels). One representative scenario runs in `make test` on
each; `make test-long` runs every suite scenario on both.
"""

from __future__ import annotations

import json
import math
import os
import subprocess

import numpy as np
import pytest
from conftest import RUNNER

from twbr_batch.batch import Z_COLLISIONS, Z_REACHED_AT, Z_TORQUE_STEP_MAX, Z_TRACKING, run_batch
from twbr_batch.suite import SCAN_PERIOD, TIME_LIMIT
from twbr_runner.bag_reader import read_messages
from twbr_runner.metrics import series_from_messages
from twbr_sim.robot_params import robot_params
from twbr_sim.scenario import load_scenario
from twbr_sim.scenario_files import find_scenario, suite_names
from twbr_tracker.evaluation import N_JUDGE, TrackingFigures

pytestmark = pytest.mark.e2e

SEED = 1
REPRESENTATIVE = "head_on"
# (head_on on the LiDAR, seed 1: test_e2e_perception's run, compared there)
CASES = [pytest.param(name, perception, marks=[] if (name, perception) == (REPRESENTATIVE, "truth") else [pytest.mark.long])
         for perception in ("truth", "lidar") for name in suite_names()]


@pytest.mark.parametrize(("name", "perception"), CASES)
def test_a_suite_scenario_through_the_graph_takes_the_batch_engines_path(tmp_path, ros_domain, name, perception):
    scenario_path = find_scenario(f"suite/{name}")
    scenario = load_scenario(scenario_path)
    env = {**os.environ, "ROS_DOMAIN_ID": str(ros_domain), "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}
    done = subprocess.run(
        [*RUNNER, str(scenario_path), "--out", str(tmp_path), "--domain",
         str(ros_domain), "--seed", str(SEED), "--planner-method", "robust", "--perception", perception, "--quiet",
         "--no-figures"],
        env=env, capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stdout + done.stderr
    (run_dir,) = [d for d in tmp_path.iterdir() if d.is_dir()]
    m = json.loads((run_dir / "metrics.json").read_text())
    assert m["perception"] == perception

    assert_the_graph_took_the_batch_engines_path(run_dir, m, scenario, SEED, perception)


def assert_the_graph_took_the_batch_engines_path(run_dir, m: dict, scenario, seed: int, perception: str) -> None:
    """A graph run (its run directory and metrics.json) against the batch engine's run of the same layout,
    seed and perception (the robust method): the same path to the last bit at every odom sample, so the same
    outcome, jolts and, on the LiDAR, the same tracker figures. The nodes read every value from a message
    (a stamp, a quaternion, a target's heading and speed, a detection's point); the batch engine applies the
    same read-backs (twbr_common.wire). Without them a last bit turned into another path where the robust
    method's decision sat on its threshold (suite/trap_wedge on the LiDAR, seed 1: apart after 24 s, the
    graph reaching at 51.8 s, the batch never)."""
    batch = run_batch(scenario, [seed], robot_params()[None, :], planner={"method": "robust"},
                      duration=min(scenario.duration, TIME_LIMIT), record=True, perception=perception)
    z = batch.table[0]
    path = batch.trace(0)
    assert m["lockstep_timeouts"] == 0  # (a late command would be another run: the graph's, not the batch's)
    odom = series_from_messages(read_messages(run_dir / "bag", ["/odom", "/clock"]))
    samples = np.rint(odom.odom_t / (path["t"][1] - path["t"][0])).astype(int)  # the trace's sample of each
    shared = samples < len(path["t"])
    assert shared.sum() >= min(len(samples), len(path["t"])) - 1, (len(samples), len(path["t"]))
    gaps = np.hypot(odom.x_c[shared] - path["x_c"][samples[shared]], odom.y_c[shared] - path["y_c"][samples[shared]])
    if gaps.any():
        first = int(np.flatnonzero(gaps)[0])
        late_worlds = (run_dir / "logs" / "planner.err").read_text().count("within world_wait")
        raise AssertionError(f"{scenario.name} on {perception}: the graph left the batch's path at t ="
                             f" {odom.odom_t[shared][first]:.3f} s (by {gaps[first]:.2e} m; {gaps.max():.3f} m at"
                             f" most); planner warnings of a world late: {late_worlds}")
    assert m["reached"] == (not math.isnan(z[Z_REACHED_AT])), m
    assert m["collisions"] == z[Z_COLLISIONS]
    if m["reached"]:
        assert m["time_to_reach_s"] == pytest.approx(z[Z_REACHED_AT], abs=1e-9)
    # the motors' largest jolt, from the bag's controller_state as from the batch engine's run
    assert m["torque_step_max_nm"] == pytest.approx(z[Z_TORQUE_STEP_MAX], rel=1e-12)
    if perception == "lidar":  # the tracker judged by the same kernel at the same scans of the same run
        figures = TrackingFigures.of(z[Z_TRACKING:Z_TRACKING + N_JUDGE], SCAN_PERIOD).as_dict()
        graph = m["tracking"]
        assert figures["instants"] == pytest.approx(m["sim_time_s"] / SCAN_PERIOD, abs=1.5), figures  # every scan
        for key, value in figures.items():
            assert graph[key] == (None if value is None else pytest.approx(value, rel=1e-9)), (key, graph, figures)
