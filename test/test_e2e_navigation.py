"""The paper's three navigation scenarios through the real nodes and the runner, over several seeds each.

Each run: recorder, controller_node, planner_node and sim_node as processes (lockstep), outcomes from the
recorded bag (metrics.json): the target is reached (a moving one caught within the capture radius) within
the scenario's time limit, no collision, never fallen, and after the first transient |pitch| <= 0.015 rad.
"""

from __future__ import annotations

import json
import os
import subprocess

import pytest
from conftest import RUNNER

from twbr_common.ros_io import stamp_ns
from twbr_runner.bag_reader import read_messages
from twbr_sim.scenario import load_scenario
from twbr_sim.scenario_files import find_scenario

pytestmark = pytest.mark.e2e

SCENARIOS = ("static", "dynamic_target", "dynamic_obstacles")
OTHER_SEEDS = (1, 2, 3, 4, 5)
PITCH_LIMIT = 0.015  # rad after the first transient (the paper reports about +-0.01)


def run(tmp_path, domain: int, scenario: str, seed: int | None, figures: bool,
        extra: tuple[str, ...] = ()) -> tuple[dict, object]:
    env = {**os.environ, "ROS_DOMAIN_ID": str(domain), "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}
    args = [*RUNNER, scenario, "--out", str(tmp_path), "--domain", str(domain),
            "--quiet"]
    args += [] if seed is None else ["--seed", str(seed)]
    args += [] if figures else ["--no-figures"]
    args += list(extra)
    done = subprocess.run(args, env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout + done.stderr
    (run_dir,) = [d for d in tmp_path.iterdir() if d.is_dir()]
    return json.loads((run_dir / "metrics.json").read_text()), run_dir


def assert_paper_outcome(m: dict, scenario: str) -> None:
    limit = load_scenario(find_scenario(scenario)).duration
    assert m["reached"] and m["ended_by"] == "target reached", m
    assert m["time_to_reach_s"] <= limit
    assert m["collisions"] == 0 and m["min_clearance_m"] > 0.0
    assert not m["fallen"]
    assert abs(m["pitch_after_transient_min_rad"]) <= PITCH_LIMIT
    assert abs(m["pitch_after_transient_max_rad"]) <= PITCH_LIMIT
    assert m["lockstep_timeouts"] == 0


# One representative in `make test` (~35 s each through the graph); the other two: make test-long.
DEFAULT_RUNS = [pytest.param(sc, marks=[] if sc == "dynamic_obstacles" else [pytest.mark.long]) for sc in SCENARIOS]


@pytest.mark.parametrize("scenario", DEFAULT_RUNS)
def test_default_seed_reaches_the_target_and_draws_the_papers_figures(tmp_path, ros_domain, scenario):
    m, run_dir = run(tmp_path, ros_domain, scenario, None, figures=True)
    assert m["seed"] == 7
    assert_paper_outcome(m, scenario)
    for png in ("potential_field.png", "response.png", "velocity.png", "yaw_rate.png", "pitch.png"):
        assert (run_dir / png).stat().st_size > 20_000, png
    (movie,) = run_dir.glob("animation.*")  # gif, or mp4 where ffmpeg is installed
    assert movie.stat().st_size > 100_000
    # The paper's planner tracks, then avoids or follows; the modes' times add up to the run's.
    modes = m["pitch_by_mode"]
    assert "tracking" in modes and set(modes) <= {"tracking", "avoiding", "following", "arrived", "stuck"}, modes
    assert sum(v["time_s"] for v in modes.values()) == pytest.approx(m["sim_time_s"], abs=0.2)
    # The planner's state in the bag agrees with the world's verdict at the end.
    planner = read_messages(run_dir / "bag", ["/planner_state"])["/planner_state"]
    assert planner[-1][1].mode in ("arrived", "following", "avoiding", "tracking")
    assert planner[-1][1].distance_to_target < 0.6
    assert {msg.method for _t, msg in planner} == {"paper"}  # the scenario pins the paper's planner
    # Every state's joints reach the bag once, those of the planner's instants too (lockstep holds them
    # until the controller's command is in, then sends them).
    bag = read_messages(run_dir / "bag", ["/odom", "/joint_states"])
    joints = [stamp_ns(msg.header.stamp) for _t, msg in bag["/joint_states"]]
    assert sorted(joints) == sorted({stamp_ns(msg.header.stamp) for _t, msg in bag["/odom"]})


# The static scenario has no random element (the seed draws the target's turns and IMU noise, and it has
# neither): seeds 1-5 give the very run of seed 7, which test_static_outcome_does_not_depend_on_the_seed
# shows exactly on the cores; one other seed stands for them end to end, in the long study.
# `make test` runs dynamic_obstacles at its default seed above; every other seed is a long study
# (`make test-long`): the same outcome over 1000 seeds is measured on the cores by `make montecarlo`, whose
# runs the graph's match (test_e2e_suite).
SEEDED_RUNS = [pytest.param(sc, seed, marks=[pytest.mark.long])
               for sc in ("dynamic_target", "dynamic_obstacles") for seed in OTHER_SEEDS] + [
    pytest.param("static", 3, marks=[pytest.mark.long])]


@pytest.mark.parametrize(("scenario", "seed"), SEEDED_RUNS)
def test_other_seeds_reach_the_target_without_collision_or_fall(tmp_path, ros_domain, scenario, seed):
    m, _ = run(tmp_path, ros_domain, scenario, seed, figures=False)
    assert m["seed"] == seed
    assert_paper_outcome(m, scenario)


def test_static_outcome_does_not_depend_on_the_seed():
    from twbr_batch.closed_loop import PlannerReference, run_closed_loop

    scenario = load_scenario(find_scenario("static"))
    paths = []
    for seed in (7, *OTHER_SEEDS):
        trace = run_closed_loop(12.0, PlannerReference(), scenario=scenario, seed=seed)
        paths.append((trace.x_c[-1], trace.y_c[-1], trace["pitch"][-1]))
    assert len(set(paths)) == 1


def test_planner_node_stops_the_robot_when_the_world_goes_stale_or_the_target_is_unknown(launch, ros):
    import time

    from geometry_msgs.msg import Point, Twist
    from nav_msgs.msg import Odometry
    from rclpy.qos import QoSProfile, ReliabilityPolicy

    from twbr_msgs.msg import Obstacle, ObstacleArray, PlannerState

    reliable = QoSProfile(depth=20, reliability=ReliabilityPolicy.RELIABLE)
    node = ros.node
    pub_odom = node.create_publisher(Odometry, "odom", reliable)
    pub_target = node.create_publisher(Odometry, "target", reliable)
    pub_obstacles = node.create_publisher(ObstacleArray, "obstacles", reliable)
    states: list[PlannerState] = []
    cmds: list[Twist] = []
    node.create_subscription(PlannerState, "planner_state", states.append, reliable)
    node.create_subscription(Twist, "cmd_vel", cmds.append, reliable)
    planner = launch("twbr_planner", "planner_node", "-p", "use_sim_time:=false", params=("planner.yaml",))
    world_live = {"on": True, "known": True}

    def tick() -> None:
        stamp = node.get_clock().now().to_msg()
        odom = Odometry()
        odom.header.stamp, odom.header.frame_id = stamp, "odom"
        odom.pose.pose.orientation.w = 1.0
        pub_odom.publish(odom)
        if world_live["on"]:
            target = Odometry()
            target.header.stamp = stamp
            target.pose.pose.position.x, target.pose.pose.orientation.w = 8.0, 1.0
            if not world_live["known"]:  # a tracker that has not seen its target: position unknown
                target.pose.covariance[0] = -1.0
            pub_target.publish(target)
            obstacles = ObstacleArray()
            obstacles.header.stamp = stamp
            obstacles.obstacles = [Obstacle(id=1, position=Point(x=4.0, y=3.0), radius=0.5)]
            pub_obstacles.publish(obstacles)
            world_live["last"] = stamp.sec + stamp.nanosec * 1e-9

    def run_until(condition, patience: float) -> bool:
        """Publish odom (and the world while live) every 20 ms until condition(): wall time is only patience
        here (the node's clock is the wall clock, use_sim_time false); what is judged are the stamps."""
        end = time.monotonic() + patience
        while time.monotonic() < end:
            tick()
            ros.spin_for(0.02)
            if condition():
                return True
        return False

    assert run_until(lambda: cmds and states and states[-1].velocity_cmd > 0.0, 60.0), planner.output
    live = states[-1]
    assert live.mode == "tracking" and live.velocity_cmd > 0.0 and cmds[-1].linear.x > 0.0
    assert live.distance_to_target == pytest.approx(8.0)
    assert live.nearest_obstacle_id == 1 and live.nearest_obstacle_distance == pytest.approx(5.0 - 0.5 - 0.3)
    world_live["on"] = False
    assert run_until(lambda: states[-1].mode == "stale", 30.0), planner.output
    stale = next(p for p in states if p.mode == "stale")
    stale_at = stale.header.stamp.sec + stale.header.stamp.nanosec * 1e-9
    assert stale_at - world_live["last"] > 0.5  # world_timeout is 0.5 s, against the last world sample's stamp
    assert run_until(lambda: cmds[-1].linear.x == 0.0, 5.0)
    assert cmds[-1].linear.x == 0.0 and cmds[-1].angular.z == 0.0
    assert "older than world_timeout" in planner.output
    # A target of unknown position (a tracker that has not seen it): the robot stands, then goes once it is known.
    world_live.update(on=True, known=False)
    assert run_until(lambda: states[-1].mode == "no_target", 10.0), planner.output
    run_until(lambda: False, 0.3)
    assert states[-1].mode == "no_target" and all(c.linear.x == 0.0 and c.angular.z == 0.0 for c in cmds[-5:])
    world_live["known"] = True
    assert run_until(lambda: states[-1].mode == "tracking" and cmds[-1].linear.x > 0.0, 10.0), planner.output


BAD_PLANNER_STARTS = [
    (["-p", "k_p:=0.0"], "invalid parameter 'k_p' = 0.0", "(0, 1000] 1/s²"),
    (["-p", "rho_o:=-1.0"], "invalid parameter 'rho_o' = -1.0", "(0, 100] m"),
    (["-p", "v_max:=20.0"], "invalid parameter 'v_max' = 20.0", "(0, 10] m/s"),
    (["-p", "k_s:=fast"], "invalid parameter 'k_s' = 'fast'", "(0, 100] 1/s"),
    (["-p", "rho_o:=0.01"], "invalid parameter 'rho_o' = 0.01", "above min_distance = 0.02 m"),  # inconsistent
    (["-p", "stuck_time:=0.2"], "invalid parameter 'stuck_progress' = 0.2", "below v_max * stuck_time"),
    (["-p", "robot_radius:=0.5", "-p", "rho_o:=0.4"], "invalid parameter 'rho_o' = 0.4",
     "at least robot_radius = 0.5 m"),  # inconsistent: a detection range smaller than the robot
]


@pytest.mark.parametrize(("args", "names", "valid"), BAD_PLANNER_STARTS)
def test_bad_planner_parameters_stop_the_node_with_one_clear_message(launch, args, names, valid):
    from conftest import assert_refused_at_start

    assert_refused_at_start(launch("twbr_planner", "planner_node", *args, params=("planner.yaml",)), names, valid)
