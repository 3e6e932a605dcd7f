"""Parameters through the real processes, with the service the `ros2 param` CLI calls (rclpy's parameter
client): mistakes in params files refused at start-up, namespaced graphs, dump/get on every node, and
changes at runtime."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import CONFIG, assert_refused_at_start
from rcl_interfaces.msg import ParameterType
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient
from rclpy.qos import QoSProfile, ReliabilityPolicy

from twbr_msgs.msg import ControllerState, PlannerState
from twbr_runner.parameter_docs import NODE_PARAMETERS, RCLPY_PARAMETERS

pytestmark = pytest.mark.e2e
HERE = Path(__file__).parent
COURSE = HERE / "scenarios" / "fault_course.yaml"
RELIABLE = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
CONTROLLER_YAML = (CONFIG / "controller.yaml").read_text()


def _file(tmp_path: Path, name: str, text: str) -> str:
    path = tmp_path / name
    path.write_text(text)
    return str(path)


@pytest.mark.parametrize(("case", "expected"), [
    ("typo", ("unknown parameter 'pitch.kpp'", "did you mean 'pitch.kp'")),
    ("section", ("section '/contoller_node' names no node", "did you mean 'controller_node'")),
    ("no_ros_parameters", ("has no ros__parameters",)),
    ("yaml_syntax", ("not valid YAML at line 4",)),
    ("missing_file", ("cannot read params file", "No such file")),
    ("override_typo", ("unknown parameter 'pitch.kpp' (-p pitch.kpp:=...)", "did you mean 'pitch.kp'")),
    # rclpy's own: before, a 33-line traceback from inside Node() and exit 1
    ("use_sim_time_string", ("invalid parameter 'use_sim_time' = 'yes'", "must be true or false")),
    ("impossible_torque", ("invalid parameter 'max_wheel_torque' = 0.01", "must be at least 2.639 N·m")),
    ("use_sim_time_integer", ("invalid parameter 'use_sim_time' = 1 (-p use_sim_time:=...)", "must be true or false")),
])
def test_params_file_mistakes_stop_the_node_with_one_line_naming_them(launch, tmp_path, case, expected):
    # Before: rclpy ignored every one of them silently (the node ran on its defaults), and a missing file or
    # a YAML error was a traceback.
    files = {
        "typo": CONTROLLER_YAML.replace("    pitch.kp:", "    pitch.kpp:"),
        "section": CONTROLLER_YAML.replace("/**/controller_node:", "contoller_node:"),
        "no_ros_parameters": "controller_node:\n  rate: 100.0\n",
        "yaml_syntax": "controller_node:\n  ros__parameters:\n    rate: [100.0\n",
        "use_sim_time_string": CONTROLLER_YAML.replace("use_sim_time: true", 'use_sim_time: "yes"'),
    }
    if case in files:
        args = ("--params-file", _file(tmp_path, f"{case}.yaml", files[case]))
    elif case == "missing_file":
        args = ("--params-file", str(tmp_path / "nowhere.yaml"))
    elif case == "impossible_torque":
        args = ("--params-file", str(CONFIG / "controller.yaml"), "-p", "max_wheel_torque:=0.01")
    elif case == "use_sim_time_integer":
        args = ("--params-file", str(CONFIG / "controller.yaml"), "-p", "use_sim_time:=1")
    else:
        args = ("--params-file", str(CONFIG / "controller.yaml"), "-p", "pitch.kpp:=40.0")
    assert_refused_at_start(launch("twbr_control", "controller_node", *args), *expected)


def _client(ros, node: str) -> AsyncParameterClient:
    client = AsyncParameterClient(ros.node, node)
    assert client.wait_for_services(timeout_sec=30.0), node
    return client


def _call(ros, future, timeout: float = 10.0):
    assert ros.spin_until(future.done, timeout)
    return future.result()


def _dump(ros, node: str) -> dict[str, object]:
    """What `ros2 param dump` gets: every listed name, then all of them in one GetParameters request."""
    client = _client(ros, node)
    names = _call(ros, client.list_parameters()).result.names
    values = _call(ros, client.get_parameters(names)).values
    assert len(values) == len(names) and names, (node, len(values), len(names))
    assert all(v.type != ParameterType.PARAMETER_NOT_SET for v in values), node
    return {n: Parameter.from_parameter_msg(_msg(n, v)).value for n, v in zip(names, values, strict=True)}


def _msg(name, value):
    from rcl_interfaces.msg import Parameter as ParameterMsg

    return ParameterMsg(name=name, value=value)


def test_param_dump_and_get_work_on_every_node(launch, ros):
    # Before: an empty typed list (cpu_affinity) made GetParameters fail for the whole request: dump was empty.
    launch("twbr_control", "controller_node", params=("controller.yaml",))
    launch("twbr_planner", "planner_node", params=("planner.yaml",))
    launch("twbr_sim", "world_node", params=("world.yaml",))
    launch("twbr_sim", "command_player", params=("command_player.yaml",))
    launch("twbr_sim", "sim_node", "-p", f"scenario:={COURSE}", params=("robot.yaml", "sim.yaml"))
    dumps = {node: _dump(ros, node) for node in ("controller_node", "planner_node", "world_node", "command_player",
                                                 "sim_node")}
    assert dumps["controller_node"]["pitch.kp"] == 48.81
    assert dumps["planner_node"]["k_o"] == 10.0
    assert dumps["sim_node"]["body_mass"] == 12.0 and dumps["sim_node"]["mode"] == "lockstep"
    for dump in dumps.values():
        assert list(dump["cpu_affinity"])  # every CPU it may use
    # docs/parameters.md documents exactly what each running node declares (beyond rclpy's own).
    for node, dump in dumps.items():
        documented = {spec.name for spec in NODE_PARAMETERS[node]}
        assert set(dump) - set(RCLPY_PARAMETERS) == documented, node


def test_a_namespaced_graph_takes_the_shipped_params_files(launch, ros):
    # Before: the files were keyed `controller_node:`, which rcl applies only to /controller_node: in /robot1
    # every parameter was dropped, use_sim_time became false and the controller dropped every state.
    states: list[ControllerState] = []
    ros.node.create_subscription(ControllerState, "/robot1/controller_state", states.append, RELIABLE)
    ns = ("-r", "__ns:=/robot1")
    controller = launch("twbr_control", "controller_node", *ns, params=("controller.yaml",))
    launch("twbr_planner", "planner_node", *ns, params=("planner.yaml",))
    sim = launch("twbr_sim", "sim_node", *ns, "-p", f"scenario:={COURSE}", "-p", "duration:=3.0",
                 "-p", "wait_for_subscribers:=2", params=("robot.yaml", "sim.yaml"))
    dump = _dump(ros, "/robot1/controller_node")
    assert dump["use_sim_time"] is True and dump["pitch.kp"] == 48.81
    assert _dump(ros, "/robot1/planner_node")["k_o"] == 10.0
    assert ros.spin_until(lambda: not sim.running, 60.0), sim.output
    assert sim.wait(timeout=1) == 0, sim.output
    ros.spin_for(0.5)
    assert len(states) >= 590  # 3 s at 200 Hz, each state controlled
    assert not any(s.fallen for s in states)
    assert "dropped" not in controller.output


def test_gains_change_at_runtime_through_set_parameters_and_bad_changes_are_refused(launch, ros):
    states: list[ControllerState] = []
    plans: list[PlannerState] = []
    ros.node.create_subscription(ControllerState, "controller_state", states.append, RELIABLE)
    ros.node.create_subscription(PlannerState, "planner_state", plans.append, RELIABLE)
    controller = launch("twbr_control", "controller_node", params=("controller.yaml",))
    planner = launch("twbr_planner", "planner_node", params=("planner.yaml",))
    launch("twbr_sim", "sim_node", "-p", f"scenario:={COURSE}", "-p", "mode:=realtime", "-p", "wait_for_subscribers:=2",
           params=("robot.yaml", "sim.yaml"))
    assert ros.spin_until(lambda: len(states) > 200 and plans, 60.0)
    assert states[-1].parameter_revision == 0
    client = _client(ros, "controller_node")

    def set_(*params: tuple[str, object], atomically: bool = False):
        parameters = [Parameter(name, value=value) for name, value in params]
        call = client.set_parameters_atomically if atomically else client.set_parameters
        result = _call(ros, call(parameters))
        return result.result if atomically else result.results[0]

    ok = set_(("pitch.kp", 40.0))
    assert ok.successful, ok.reason
    assert ros.spin_until(lambda: states[-1].parameter_revision == 1, 5.0)
    assert _call(ros, client.get_parameters(["pitch.kp"])).values[0].double_value == 40.0
    assert "parameters changed at runtime: pitch.kp 48.81 -> 40.0" in controller.output

    out_of_range = set_(("pitch.kp", -1.0))
    assert not out_of_range.successful and "pitch.kp" in out_of_range.reason
    read_only = set_(("rate", 100.0))
    assert not read_only.successful and "read-only" in read_only.reason
    inconsistent = set_(("max_pitch_ref", 0.59), ("fall_pitch", 0.5), atomically=True)  # a pitch_ref that falls
    assert not inconsistent.successful and "fall_pitch" in inconsistent.reason
    both = set_(("velocity.kp", 0.5), ("pitch.kd", 9.0), atomically=True)
    assert both.successful, both.reason
    assert ros.spin_until(lambda: states[-1].parameter_revision == 2, 5.0)  # one set, one revision
    values = _call(ros, client.get_parameters(["velocity.kp", "pitch.kd", "pitch.kp", "rate"])).values
    assert [v.double_value for v in values] == [0.5, 9.0, 40.0, 200.0]
    assert not any(s.fallen for s in states)

    planner_client = _client(ros, "planner_node")
    result = _call(ros, planner_client.set_parameters([Parameter("k_o", value=12.0)])).results[0]
    assert result.successful, result.reason
    assert ros.spin_until(lambda: plans[-1].parameter_revision == 1 and plans[-1].k_o == 12.0, 5.0)
    refused = _call(ros, planner_client.set_parameters([Parameter("rho_o", value=0.01)])).results[0]
    assert not refused.successful and "rho_o" in refused.reason  # below min_distance... and robot_radius
    assert "k_o 10.0 -> 12.0" in planner.output

    # In range, but past what the robot can do (issue 34: accepted before, and the robot hit an obstacle at
    # clearance -0.515 m, or fell in ~1 s): refused naming the robot's bound and where it comes from.
    for name, value, bound in (("v_max", 10.0, "top speed"), ("max_acceleration", 100.0, "largest acceleration"),
                               ("max_yaw_rate", 20.0, "top yaw rate"),
                               ("max_yaw_acceleration", 1000.0, "largest yaw acceleration")):
        refused = _call(ros, planner_client.set_parameters([Parameter(name, value=value)])).results[0]
        assert not refused.successful and f"'{name}'" in refused.reason and bound in refused.reason, refused.reason
        assert "robot.yaml" in refused.reason
    refused = set_(("max_wheel_torque", 0.01))
    assert not refused.successful and "holds the body" in refused.reason and "2.639" in refused.reason, refused.reason
    assert _call(ros, planner_client.get_parameters(["v_max"])).values[0].double_value == 0.6
    assert ros.spin_until(lambda: len(states) > 50, 5.0) and not states[-1].fallen


def test_a_planner_asked_for_more_than_the_robot_can_do_refuses_to_start(launch, tmp_path):
    """`v_max 10` on a robot whose motors top out at 2.4 m/s; the bound follows the robot_file given."""
    installed = launch("twbr_planner", "planner_node", "-p", "v_max:=10.0", params=("planner.yaml",))
    assert_refused_at_start(installed, "invalid parameter 'v_max' = 10", "must be at most 2.4 m/s", "top speed",
                            "installed config/robot.yaml")
    faster = (CONFIG / "robot.yaml").read_text().replace("supply_voltage: 24.0", "supply_voltage: 48.0")
    robot = _file(tmp_path, "fast_robot.yaml", faster)
    ok = launch("twbr_planner", "planner_node", "-p", "v_max:=3.0", "-p", f"robot_file:={robot}",
                params=("planner.yaml",))
    slow = launch("twbr_planner", "planner_node", "-p", "v_max:=3.0", params=("planner.yaml",))
    assert_refused_at_start(slow, "'v_max' = 3", "2.4 m/s")
    assert ok.running, ok.output  # 4.8 m/s on 48 V
