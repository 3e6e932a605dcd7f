"""What the runner starts: the planner gets what the scenario pins, under --planner-method, or nothing starts."""

from pathlib import Path

import pytest

from twbr_common.params import ConfigError
from twbr_common.paths import config_dir
from twbr_planner.planner_params import resolve
from twbr_runner.runner import plan, run_perception
from twbr_sim.scenario import load_scenario, parse_scenario, vary
from twbr_sim.scenario_files import find_scenario


def planner_args(scenario, method=None) -> list[str]:
    nodes = plan(scenario, Path("scenario.yaml"), config_dir(), 1, Path("bag"), method)
    (planner,) = [n for n in nodes if n.label == "planner"]
    return planner.ros_args


def methods(args: list[str]) -> list[str]:
    return [a for a in args if a.startswith("method:=")]


def test_the_papers_scenarios_run_the_papers_planner_unless_told_otherwise():
    static = load_scenario(find_scenario("static"))
    assert methods(planner_args(static)) == ["method:=paper"]
    assert methods(planner_args(static, "robust")) == ["method:=robust"]
    head_on = load_scenario(find_scenario("suite/head_on"))
    assert methods(planner_args(head_on)) == []  # planner.yaml's, the robust default
    assert methods(planner_args(head_on, "paper")) == ["method:=paper"]


def test_a_scenarios_pinned_parameters_reach_the_node_and_bad_ones_are_refused_before_it_starts():
    base = {"name": "pins", "duration": 10.0, "target": {"position": [5.0, 0.0]}}
    pins = parse_scenario({**base, "planner": {"method": "robust", "goal_fade": 0.0, "safety_filter": False}})
    args = planner_args(pins)
    assert "goal_fade:=0.0" in args and "safety_filter:=false" in args
    assert resolve(None, pins)["goal_fade"] == 0.0 and resolve({"goal_fade": 2.0}, pins)["goal_fade"] == 2.0
    for bad, message in (({"goal_fad": 1.0}, "unknown parameter 'goal_fad'"), ({"k_p": -1.0}, "k_p")):
        scenario = parse_scenario({**base, "planner": bad})
        with pytest.raises(ConfigError) as e:
            planner_args(scenario)
        assert "scenario 'pins', field 'planner'" in str(e.value) and message in str(e.value)


def test_the_controller_and_planner_run_compiled_unless_the_caller_says_otherwise(monkeypatch):
    scenario = load_scenario(find_scenario("dynamic_obstacles"))
    monkeypatch.delenv("TWBR_JIT", raising=False)
    nodes = {n.label: n for n in plan(scenario, Path("scenario.yaml"), config_dir(), 1, Path("bag"))}
    assert nodes["controller"].env == nodes["planner"].env == {"TWBR_JIT": "on"}
    assert nodes["sim"].env == nodes["recorder"].env == {}  # the simulator is compiled anyway
    monkeypatch.setenv("TWBR_JIT", "off")  # e.g. to run the graph as the robot's computer would
    nodes = {n.label: n for n in plan(scenario, Path("scenario.yaml"), config_dir(), 1, Path("bag"))}
    assert nodes["controller"].env == nodes["planner"].env == {}


def test_the_lockstep_timeout_reaches_the_simulator_only_when_asked():
    scenario = load_scenario(find_scenario("step"))

    def sim_args(**options) -> list[str]:
        nodes = plan(scenario, find_scenario("step"), config_dir(), 1, Path("bag"), **options)
        return next(n for n in nodes if n.label == "sim").ros_args

    assert not any(a.startswith("lockstep_timeout:=") for a in sim_args())
    assert "lockstep_timeout:=5.0" in sim_args(lockstep_timeout=5.0)


def test_with_the_lidar_the_planner_avoids_what_the_tracker_sees_and_the_truth_is_kept_apart(tmp_path):
    crowd = load_scenario(find_scenario("suite/crowd_crossing"))
    assert run_perception(crowd, None) == "lidar"  # every scenario's default
    assert run_perception(load_scenario(find_scenario("dynamic_obstacles")), None) == "truth"  # the paper pins it
    assert run_perception(load_scenario(find_scenario("step")), "lidar") == "truth"  # no planner: nothing to see
    nodes = {n.label: n for n in plan(crowd, Path("scenario.yaml"), config_dir(), 1, Path("bag"), perception="lidar")}
    assert list(nodes)[-1] == "sim" and nodes["tracker"].executable == "tracker_node"
    assert "obstacles:=obstacles_truth" in nodes["sim"].ros_args  # the world's own list, for the metrics only
    assert "obstacles_period:=0.1" in nodes["planner"].ros_args  # a plan at a scan's instant waits for it
    assert "wait_for_subscribers:=4" in nodes["sim"].ros_args  # recorder, controller, planner and tracker
    # the planner follows the tracker's target (10 Hz looks), told where the seed's layout starts it
    assert "target:=target_tracked" in nodes["planner"].ros_args and "world_period:=0.1" in nodes["planner"].ros_args
    assert "target:=target_tracked" in nodes["tracker"].ros_args
    start = vary(crowd, 1).target
    assert f"target.prior_x:={float(start.x)!r}" in nodes["tracker"].ros_args and "target.prior_std:=0.1" in nodes[
        "tracker"].ros_args
    mujoco = {n.label: n for n in plan(crowd, Path("scenario.yaml"), config_dir(), 1, Path("bag"), perception="lidar",
                                       driver="mujoco")}
    assert not any("target:=" in a for a in mujoco["planner"].ros_args)  # no target detector: the world's target
    truth = {n.label: n for n in plan(crowd, Path("scenario.yaml"), config_dir(), 1, Path("bag"), perception="truth")}
    assert "tracker" not in truth and not any("obstacles" in a for a in truth["sim"].ros_args)
    assert "wait_for_subscribers:=3" in truth["sim"].ros_args
    # a robot without a LiDAR cannot run on it: refused before anything starts, naming the parameter
    (tmp_path / "sim.yaml").write_text("/**/sim_node:\n  ros__parameters:\n    lidar.rate: 0.0\n")
    for name in ("robot.yaml", "planner.yaml", "controller.yaml", "tracker.yaml"):
        (tmp_path / name).write_text((config_dir() / name).read_text())
    with pytest.raises(ConfigError, match=r"lidar.rate = 0 in sim.yaml"):
        plan(crowd, Path("scenario.yaml"), tmp_path, 1, Path("bag"), perception="lidar")


def test_what_a_node_saw_of_another_graph_is_read_from_its_log():
    """A neighbour that came and went between the runner's own looks is still counted: the nodes report it."""
    from twbr_runner.runner import graph_findings

    log = ("[INFO] [1.0] [sim_node]: stepping\n"
           "[ERROR] [1732880000.1] [sim_node]: a second publisher on /clock, which this node owns (1 more, from"
           " /sim_node): another graph on this ROS_DOMAIN_ID? Nodes reading /clock now mix two sources\n"
           "[ERROR] [1732880000.2] [controller_node]: a publisher of std_msgs/msg/String on /cmd_vel (/x): the"
           " contract's type is geometry_msgs/msg/Twist and its messages cannot reach this node\n"
           "[WARN] [2.0] [sim_node]: a second publisher on /odom is only a warning here\n")
    found = graph_findings(log)
    assert [f.split(",")[0].split(" (")[0] for f in found] == ["a second publisher on /clock",
                                                                "a publisher of std_msgs/msg/String on /cmd_vel"]
    assert graph_findings("[ERROR] [1.0] [planner_node]: dropped obstacles: no stamp\n") == []
