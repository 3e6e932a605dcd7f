"""Faults the graph survives, through the real processes: garbage on every input, a killed planner, a
killed controller. Runs use a short course (test/scenarios/fault_course.yaml, about 22 s of sim time)."""

from __future__ import annotations

import dataclasses
import json
import math
import os
import re
import signal
import subprocess
import sys
import time
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import RUNNER, contacts_while_driving
from rclpy.qos import QoSProfile, ReliabilityPolicy

from twbr_msgs.msg import ControllerState, PlannerState, SimStatus, WorldStatus
from twbr_runner.bag_reader import read_messages
from twbr_runner.metrics import series_from_messages
from twbr_runner.spawn import NodeProcess
from twbr_sim.scenario import load_scenario

pytestmark = pytest.mark.e2e
HERE = Path(__file__).parent
COURSE = HERE / "scenarios" / "fault_course.yaml"
INJECTOR = HERE / "fault_injector.py"
RELIABLE = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
SIM_PARAMS = ("robot.yaml", "sim.yaml")


def course_on_the_cores() -> tuple[Any, Any]:
    """The course run headless by the same cores, without DDS: what an undisturbed run gives, and its path."""
    from twbr_batch.montecarlo import run_one_traced

    return run_one_traced(str(COURSE), load_scenario(COURSE).seed, perturbation=0.0)


def injector(env: dict[str, str], log_dir: Path, *params: str) -> NodeProcess:
    argv = [sys.executable, str(INJECTOR), "--ros-args", *[a for p in params for a in ("-p", p)]]
    return NodeProcess(argv, env, log_dir, "injector")


def injected_counts(proc: NodeProcess) -> dict[str, int]:
    assert proc.stop(timeout=10) == 0, proc.output
    return json.loads(proc.output.strip().splitlines()[0])


def run_beside_injector(tmp_path: Path, env: dict[str, str], *params: str) -> tuple[int, str, str, dict[str, int]]:
    """The course through the runner into tmp_path/runs, the injector (with `params`) joining once the graph
    runs (the runner refuses to start beside one): (exit code, stdout, stderr, what the injector sent)."""
    started = time.monotonic()
    runner = subprocess.Popen(
        [*RUNNER, str(COURSE), "--out", str(tmp_path / "runs"), "--quiet",
         "--no-figures"], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    neighbour = None
    try:
        while time.monotonic() - started < 60 and not list((tmp_path / "runs").glob("*/logs/sim.err")):
            time.sleep(0.05)
        neighbour = injector(env, tmp_path, *params)
        out, err = runner.communicate(timeout=300)
    finally:
        if runner.poll() is None:  # the run hung: stop it (its nodes go with it) and the injector
            runner.kill()
            runner.wait()
            if neighbour is not None:
                neighbour.stop()
    return runner.returncode, out, err, injected_counts(neighbour)


def drop_warnings(log: str, stream: str) -> list[str]:
    return re.findall(rf"dropped {stream}: [^\n]*", log)


# Alone: the bag is judged in the order the recorder received it, and beside another graph the recorder's
# reliable odom stream lagged the injector's by more than 0.1 s, so an out-of-order garbage odom (x = -3 m)
# came first with a stamp the real one then repeated (two-worker CI, eighth session).
@pytest.mark.alone
def test_garbage_on_every_input_is_dropped_and_the_run_is_unchanged(tmp_path, ros_env):
    started = time.monotonic()
    returncode, out, err, sent = run_beside_injector(tmp_path, ros_env, "use_sim_time:=true")
    wall = time.monotonic() - started
    # A run beside a foreign publisher on its topics is not its graph's alone: it says so and exits 1.
    assert returncode == 1, out + err
    (run_dir,) = (tmp_path / "runs").iterdir()
    m = json.loads((run_dir / "metrics.json").read_text())
    assert any(f.startswith("/fault_injector publishing /odom") for f in m["foreign_publishers"]), m
    assert "publishers that are not this run's were on its topics" in err and "/fault_injector" in err, err
    assert m["ended_by"] == "target reached"  # it ran to its end: the injector is reported, not fatal

    # Every input of every node in the graph got every kind of garbage while the robot drove.
    topics = ("odom", "imu", "cmd_vel", "wheel_torque_cmd", "target", "obstacles", "planner_state")
    kinds = ("nan", "inf", "absurd", "unstamped", "out_of_order", "future_1s", "future_1000s", "wall_time")
    for topic in topics:
        for kind in kinds[:3] if topic == "cmd_vel" else kinds:
            assert sent.get(f"{topic}:{kind}", 0) >= 5, sent

    # Each node dropped its streams' garbage with a warning, at most one per stream per second.
    logs = {name: (run_dir / "logs" / f"{name}.err").read_text() for name in ("sim", "controller", "planner")}
    streams = {"sim": ("wheel_torque_cmd",), "controller": ("odom", "imu", "cmd_vel"),
               "planner": ("odom", "target", "obstacles")}
    for name, names in streams.items():
        for stream in names:
            warnings = drop_warnings(logs[name], stream)
            assert warnings, (name, stream, logs[name][-3000:])
            assert len(warnings) <= wall + 1, (name, stream, len(warnings), wall)
            assert max(map(len, warnings)) < 400, max(warnings, key=len)  # one short line each (was 14.7 KB)
    reasons = " ".join(w for name, names in streams.items() for s in names for w in drop_warnings(logs[name], s))
    for reason in ("non-finite value", "absurdly large value", "no stamp", "stamp ahead of the clock"):
        assert reason in reasons, reason
    assert "older than" in reasons  # out of order, or already stale on arrival at a short timeout
    assert m["commands_rejected"] >= 10  # the simulator's count of refused torque commands
    assert all(m["messages_refused"].get(t, 0) > 0 for t in ("/odom", "/target", "/obstacles", "/planner_state"))

    # The run is the undisturbed one: the cores' run of the same course, within the graph's own spread.
    core, path = course_on_the_cores()
    outcome = {k: m.get(k) for k in ("reached", "time_to_reach_s", "collisions", "min_clearance_m", "fallen",
                                     "sim_time_s", "ended_by", "bag")}
    assert m["reached"] and m["collisions"] == 0 and not m["fallen"], outcome
    assert m["lockstep_timeouts"] == 0
    # No garbage made cmd_vel go stale. Only the state at t = 0 may be controlled before the planner's first
    # cmd_vel arrives: the two answer that state at once, in whichever order the executors take it.
    states = read_messages(run_dir / "bag", ["/controller_state"])["/controller_state"]
    assert all(_t(s) == 0.0 for _, s in states if s.cmd_vel_stale), m["cmd_vel_stale_samples"]
    # The path, each second until 2 s before the cores reach the target, is the cores' path within 5 cm
    # (measured: 2 mm until 9 s, 1-2 cm through the stuck episode and at 20 s). The course ends in a chase
    # that amplifies centimetres: a pass 6 cm wide of the capture radius circles the target for 2-5 s more,
    # so the time to reach is bounded, not matched.
    # The bag holds the injector's odom too, some stamped with the very instant of a simulator's state and
    # recorded before it (x = 1e12 at 18.0 s in one CI run): read it as the nodes and the metrics do.
    odom = series_from_messages(read_messages(run_dir / "bag", ["/odom", "/clock"]))
    assert odom.refused["/odom"] >= 20  # the garbage was there, and it was left out
    t_core, x_core, y_core = (np.asarray(a) for a in (path.t, path.x_c, path.y_c))
    for second in np.arange(1.0, core.time_to_reach_s - 2.0):
        i = int(np.argmin(np.abs(t_core - second)))
        j = int(np.argmin(np.abs(odom.odom_t - second)))  # the recorder may miss a sample
        assert abs(odom.odom_t[j] - second) <= 0.02, second
        assert math.hypot(odom.x_c[j] - x_core[i], odom.y_c[j] - y_core[i]) < 0.05, (second, odom.x_c[j], x_core[i])
    assert core.time_to_reach_s - 1.0 <= m["time_to_reach_s"] <= core.time_to_reach_s + 6.0
    assert m["min_clearance_m"] == pytest.approx(core.min_clearance_m, abs=0.05)
    assert m["pitch_min_rad"] == pytest.approx(core.pitch_min_rad, abs=0.002)
    assert m["pitch_max_rad"] == pytest.approx(core.pitch_max_rad, abs=0.002)
    (run_dir / "fault_comparison.json").write_text(json.dumps({"core": dataclasses.asdict(core), "sent": sent}, indent=1))


def _t(msg) -> float:
    return msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9


def test_planner_killed_the_robot_stops_balanced_and_a_restarted_planner_reaches_the_target(launch, ros):
    states: list[ControllerState] = []
    world: list[WorldStatus] = []
    ros.node.create_subscription(ControllerState, "controller_state", states.append, RELIABLE)
    ros.node.create_subscription(WorldStatus, "world_status", world.append, RELIABLE)
    plans: list[PlannerState] = []
    ros.node.create_subscription(PlannerState, "planner_state", plans.append, RELIABLE)
    launch("twbr_control", "controller_node", params=("controller.yaml",))
    planner = launch("twbr_planner", "planner_node", params=("planner.yaml",))
    sim = launch("twbr_sim", "sim_node", "-p", f"scenario:={COURSE}", "-p", "duration:=120.0",
                 "-p", "wait_for_subscribers:=2", params=SIM_PARAMS)
    assert ros.spin_until(lambda: states and states[-1].velocity > 0.25, 60.0), sim.output

    os.killpg(planner.proc.pid, signal.SIGKILL)  # no goodbye: cmd_vel just stops
    killed_at = _t(states[-1])  # as this test saw it: the graph may already be a little further on
    timeout = 0.5  # cmd_vel_timeout of config/controller.yaml

    def stale_from() -> float | None:
        last_plan = max(_t(p) for p in plans)
        return next((_t(s) for s in states if _t(s) > last_plan and s.cmd_vel_stale), None)

    # On a loaded machine this test sees the graph late: wait for the watchdog in the stamps, not the clock.
    assert ros.spin_until(lambda: stale_from() is not None and _t(states[-1]) > stale_from() + 4.0, 60.0)
    # The planner's last output is stamped with the state it answered: the watchdog counts from there
    # (plus the cmd_vel's way to the controller, well under 0.1 s of sim time).
    # The planner is not in the lockstep here: on a loaded machine its last cmd_vel can reach the controller
    # some states after the odom it answered, and the watchdog counts from that arrival.
    last_plan, first_stale = max(_t(p) for p in plans), stale_from()
    assert last_plan + timeout - 0.005 <= first_stale <= last_plan + timeout + 0.5, (last_plan, first_stale)
    after = [s for s in states if _t(s) >= first_stale]
    assert all(s.cmd_vel_stale and s.velocity_ref == 0.0 and s.yaw_rate_ref == 0.0 for s in after)
    last_second = [s for s in after if _t(s) > _t(after[-1]) - 1.0]
    assert max(abs(s.velocity) for s in last_second) < 0.02  # stopped
    assert max(abs(s.pitch) for s in last_second) < 0.01  # and balanced
    assert not any(s.fallen for s in states)

    stopping = [s for s in states if _t(s) > killed_at]
    still = next(_t(s) for s in stopping if all(abs(x.velocity) < 0.02 for x in stopping if _t(x) >= _t(s)))
    print(f"planner killed at t = {killed_at:.2f} s (its last plan: {last_plan:.2f} s) at {stopping[0].velocity:.3f}"
          " m/s: stopped (|v| < 0.02 m/s)"
          f" at t = {still:.2f} s, |pitch| <= {max(abs(s.pitch) for s in stopping):.4f} rad while stopping")
    restarted_at = _t(states[-1])
    launch("twbr_planner", "planner_node", params=("planner.yaml",))
    assert ros.spin_until(lambda: not sim.running, 120.0)  # the scenario ends on the target reached
    assert sim.wait(timeout=1) == 0, sim.output
    ros.spin_for(0.5)
    modes = Counter(p.mode for p in plans if _t(p) > restarted_at)
    assert any(w.target_reached for w in world), (f"t = {_t(world[-1]):.1f} s, {world[-1].target_distance:.2f} m"
                                                  f" from the target; modes since the restart: {dict(modes)}")
    # Stopped by the watchdog the robot can be walked into by the crossing obstacle (where it stops depends on
    # when this test saw it driving); it never drives into one, before the kill or after the restart.
    assert not contacts_while_driving(world, states), contacts_while_driving(world, states)
    assert not any(s.fallen for s in states)
    assert not states[-1].cmd_vel_stale
    reached = next(_t(w) for w in world if w.target_reached)
    print(f"planner restarted at t = {restarted_at:.2f} s; target reached at t = {reached:.2f} s")


def test_controller_killed_the_robot_side_zeroes_the_torque_reports_it_and_nothing_hangs(launch, ros):
    from geometry_msgs.msg import Twist

    status: list[SimStatus] = []
    cmd_vel: list[Twist] = []
    ros.node.create_subscription(SimStatus, "sim_status", status.append, RELIABLE)
    ros.node.create_subscription(Twist, "cmd_vel", cmd_vel.append, RELIABLE)
    controller = launch("twbr_control", "controller_node", params=("controller.yaml",))
    planner = launch("twbr_planner", "planner_node", params=("planner.yaml",))
    sim = launch("twbr_sim", "sim_node", "-p", f"scenario:={COURSE}", "-p", "mode:=realtime",
                 "-p", "wait_for_subscribers:=2", params=SIM_PARAMS)
    assert ros.spin_until(lambda: status and _t(status[-1]) > 2.0, 60.0), sim.output
    assert not status[-1].command_stale and status[-1].commands_received > 100

    os.killpg(controller.proc.pid, signal.SIGKILL)
    killed, killed_sim = time.monotonic(), _t(status[-1])
    assert ros.spin_until(lambda: status[-1].command_stale, 30.0), sim.output  # patience, judged in stamps below
    noticed = time.monotonic() - killed
    # command_timeout is 0.1 s of sim time; statuses come at 20 Hz and this test sees the graph a little late.
    # Judged in sim time: a stall of the whole machine (seen once in CI: 1.6 s) stops sim time too.
    first_stale = next(_t(m) for m in status if m.command_stale and _t(m) > 1.0)
    assert first_stale <= killed_sim + 0.1 + 0.15, (killed_sim, first_stale)
    received = status[-1].commands_received
    assert ros.spin_until(lambda: status[-1].fallen, 10.0)  # zero torque: a balancing robot falls over
    print(f"controller killed at t >= {killed_sim:.3f} s: command_stale after {noticed * 1e3:.0f} ms wall"
          f" (t = {first_stale:.3f} s),"
          f" fallen at t = {_t(next(m for m in status if m.fallen)):.3f} s")
    n_cmd, steps = len(cmd_vel), status[-1].steps
    ros.spin_for(2.0)
    assert status[-1].commands_received == received  # nothing drove the wheels since
    assert status[-1].steps > steps and len(cmd_vel) > n_cmd  # the simulator and the planner still run
    assert "zero torque" in sim.stderr  # and the simulator said why
    for proc in (sim, planner):  # nothing hangs: each ends on SIGINT (exit 0), not on the SIGKILL after 20 s
        assert proc.stop(timeout=20) == 0, proc.output


@pytest.mark.long  # two runs through the runner (~60 s): make test-long; the parts are unit-tested in test_cdr,
# test_guard and test_metrics_admission
def test_a_flood_of_large_obstacle_arrays_does_not_change_the_run(tmp_path, ros_env):
    """5,000 obstacles per message at ~48 Hz, unstamped (as `ros2 topic pub` sends them), through the runner.
    Before: 6 lockstep timeouts and a later arrival (`make demo`: 77.0 s against 69.65 s); the metrics of a
    467 MB bag took 2.5 min and 5 GB. Now: the run of an undisturbed graph, the flood refused by its stamp
    before its 5,000 rows are judged, named as a foreign publisher (exit 1)."""
    quiet = _run_course(tmp_path / "quiet", ros_env)
    returncode, out, err, sent = run_beside_injector(tmp_path, ros_env, "use_sim_time:=true", "rate:=48.0",
                                                     "flood_obstacles:=5000")
    assert returncode == 1 and "/fault_injector" in err, out + err  # reported, not fatal
    (run_dir,) = (tmp_path / "runs").iterdir()
    m = json.loads((run_dir / "metrics.json").read_text())
    assert sent.get("obstacles:flood", 0) >= 100, sent
    assert m["messages"]["/obstacles"] >= 100 + quiet["messages"]["/obstacles"]  # the bag has the flood
    assert m["messages_refused"].get("/obstacles", 0) >= 100
    for key in ("reached", "time_to_reach_s", "collisions", "min_clearance_m", "pitch_min_rad", "pitch_max_rad",
                "lockstep_timeouts"):
        assert m[key] == quiet[key], (key, m[key], quiet[key])
    assert m["lockstep_timeouts"] == 0
    planner = (run_dir / "logs" / "planner.err").read_text()
    assert "dropped obstacles: no stamp" in planner, planner[-2000:]


def _run_course(out: Path, env: dict[str, str]) -> dict:
    done = subprocess.run([*RUNNER, str(COURSE), "--out", str(out), "--quiet",
                           "--no-figures"], env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    (run_dir,) = out.iterdir()
    return json.loads((run_dir / "metrics.json").read_text())


WALL_AHEAD = """name: wall_ahead
description: the robot alone with an obstacle 2.5 m straight ahead; no target (nothing plans)
duration: 12.0
seed: 1
robot: {x: 0.0, y: 0.0, yaw: 0.0}
obstacles:
  - {id: 1, position: [2.5, 0.0], radius: 0.3}
"""


@pytest.mark.parametrize("monitor", [True, False], ids=["monitored", "unmonitored"])
def test_a_foreign_cmd_vel_cannot_drive_the_robot_into_an_obstacle(launch, ros, tmp_path, monitor):
    """Any cmd_vel passes the controller's collision monitor. Before: a foreign publisher driving straight at
    an obstacle hit it (clearance -0.173 m). With the monitor off (the test's control) it still does."""
    from geometry_msgs.msg import Twist

    scenario = tmp_path / "wall_ahead.yaml"
    scenario.write_text(WALL_AHEAD)
    states: list[ControllerState] = []
    world: list[WorldStatus] = []
    ros.node.create_subscription(ControllerState, "controller_state", states.append, RELIABLE)
    ros.node.create_subscription(WorldStatus, "world_status", world.append, RELIABLE)
    launch("twbr_control", "controller_node", "-p", f"collision_monitor.enabled:={str(monitor).lower()}",
           params=("controller.yaml",))
    sim = launch("twbr_sim", "sim_node", "-p", f"scenario:={scenario}", "-p", "wait_for_subscribers:=1",
                 params=SIM_PARAMS)
    foreign = ros.node.create_publisher(Twist, "cmd_vel", 10)
    push = Twist()
    push.linear.x = 0.8
    deadline = time.monotonic() + 120.0
    while sim.running and time.monotonic() < deadline:
        foreign.publish(push)
        ros.executor.spin_once(timeout_sec=0.001)
    assert sim.wait(timeout=5) == 0, sim.output
    ros.spin_for(0.5)
    clearance = min(w.clearance for w in world)
    driven = max(s.velocity for s in states)
    assert driven > 0.5, driven  # the foreign command did drive the robot
    assert not any(s.fallen for s in states)
    if monitor:
        assert 0.0 < clearance < 0.2 and world[-1].collision_count == 0, clearance  # stopped short of it
        assert sum(s.collision_limited for s in states) > 100
    else:
        assert clearance < 0.0 and world[-1].collision_count >= 1, clearance
        assert not any(s.collision_limited for s in states)
    print(f"collision monitor {'on' if monitor else 'off'}: min clearance {clearance:.3f} m")
