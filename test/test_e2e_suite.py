"""The hard suite through the node graph: each scenario for one seed with the robust planner, against the
batch engine's run of the same seed (the same cores: the same path).

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

from twbr_batch.batch import Z_COLLISIONS, Z_REACHED_AT, Z_SIM_TIME, Z_TORQUE_STEP_MAX, Z_TRACKING, run_batch
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
    seed and perception (the robust method): outcome, jolts, the path, and on the LiDAR the tracker judged."""
    name = scenario.name
    batch = run_batch(scenario, [seed], robot_params()[None, :], planner={"method": "robust"},
                      duration=min(scenario.duration, TIME_LIMIT), record=True, perception=perception)
    z = batch.table[0]
    path = batch.trace(0)
    assert m["reached"] == (not math.isnan(z[Z_REACHED_AT])), m
    assert m["collisions"] == z[Z_COLLISIONS]
    assert m["lockstep_timeouts"] == 0
    if m["reached"]:
        assert m["time_to_reach_s"] == pytest.approx(z[Z_REACHED_AT], rel=0.1)
    # the motors' largest jolt, from the bag's controller_state as from the batch engine's run
    assert m["torque_step_max_nm"] == pytest.approx(z[Z_TORQUE_STEP_MAX], rel=0.25)
    gaps = []
    # The path, each second, within 5 cm of the batch engine's for the first 15 s: the graph runs the same
    # kernels on the same states, but the yaw it reads back from odom's quaternion (and obstacles moved to the
    # odom stamp) differ from the batch's in the last bit, and the robust method's switches (boundary
    # following, the way round) amplify that where a decision is on its threshold. Measured over every
    # suite scenario, seed 1, with an earlier tuning of the method: 10 of 15 within 2 cm to the end; three
    # within 12 cm; three apart by 5 cm after 18-27 s and by up to 2.2 m later, reaching the target at
    # most 6 % apart.
    odom = series_from_messages(read_messages(run_dir / "bag", ["/odom", "/clock"]))
    end = min(float(path["t"][-1]), float(odom.odom_t[-1])) - 1.0
    for second in np.arange(1.0, end):
        i = int(np.argmin(np.abs(path["t"] - second)))
        j = int(np.argmin(np.abs(odom.odom_t - second)))
        assert abs(odom.odom_t[j] - second) <= 0.02, second
        gaps.append(math.hypot(odom.x_c[j] - path["x_c"][i], odom.y_c[j] - path["y_c"][i]))
    assert max(gaps[:15]) < 0.05, (name, gaps[:15])
    if perception == "lidar":  # the tracker judged by the same kernel at the same scans of nearly the same run
        figures = TrackingFigures.of(z[Z_TRACKING:Z_TRACKING + N_JUDGE], SCAN_PERIOD).as_dict()
        graph = m["tracking"]
        # a list at every scan of each run (they may end a little apart: the paths part after 15 s)
        assert graph["instants"] == pytest.approx(m["sim_time_s"] / SCAN_PERIOD, abs=2), (graph, m["sim_time_s"])
        assert figures["instants"] == pytest.approx(z[Z_SIM_TIME] / SCAN_PERIOD, abs=2), (figures, z[Z_SIM_TIME])
        assert graph["judged"] == pytest.approx(figures["judged"], rel=0.05, abs=2), (graph, figures)
        for key in ("position_rmse_m", "velocity_rmse_mps"):
            assert (graph[key] is None) == (figures[key] is None), key
            if figures[key] is not None:
                assert graph[key] == pytest.approx(figures[key], rel=0.2, abs=0.005), (key, graph, figures)
