"""Time and restarts through the real processes: a simulator killed and started again, and the same run on
an idle and on a loaded machine. Runs use the short course (test/scenarios/fault_course.yaml)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import PATIENT_LOCKSTEP, after_last_restart, busy_loops, contacts_while_driving
from nav_msgs.msg import Odometry
from rclpy.qos import QoSProfile, ReliabilityPolicy

from twbr_msgs.msg import ControllerState, PlannerState, WorldStatus
from twbr_runner.bag_reader import read_messages
from twbr_runner.metrics import series_from_messages

pytestmark = pytest.mark.e2e
HERE = Path(__file__).parent
COURSE = HERE / "scenarios" / "fault_course.yaml"
RELIABLE = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
SIM_PARAMS = ("robot.yaml", "sim.yaml")


def _t(msg) -> float:
    return msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9


@pytest.mark.parametrize("planner_rate", [20.0, 0.0], ids=["lockstep_planner", "lockstep_controller_only"])
def test_simulator_killed_and_started_again_the_new_run_reaches_its_target(launch, ros, planner_rate):
    # Before: the planner's schedule stayed at the old run's time (silent), the new simulator held t = 0
    # forever with no log line, and the controller re-applied the old run's last cmd_vel.
    states: list[ControllerState] = []
    plans: list[PlannerState] = []
    world: list[WorldStatus] = []
    ros.node.create_subscription(ControllerState, "controller_state", states.append, RELIABLE)
    ros.node.create_subscription(PlannerState, "planner_state", plans.append, RELIABLE)
    ros.node.create_subscription(WorldStatus, "world_status", world.append, RELIABLE)
    controller = launch("twbr_control", "controller_node", params=("controller.yaml",))
    planner = launch("twbr_planner", "planner_node", params=("planner.yaml",))
    sim_args = ("-p", f"scenario:={COURSE}", "-p", "duration:=120.0", "-p", "wait_for_subscribers:=2",
                "-p", f"lockstep_planner_rate:={planner_rate}", *PATIENT_LOCKSTEP)
    first = launch("twbr_sim", "sim_node", *sim_args, params=SIM_PARAMS)
    assert ros.spin_until(lambda: states and _t(states[-1]) > 6.0 and states[-1].velocity > 0.2, 60.0), first.output
    os.killpg(first.proc.pid, signal.SIGKILL)  # mid-run, driving, no goodbye
    killed_at = _t(states[-1])
    ros.spin_for(1.0)

    second = launch("twbr_sim", "sim_node", *sim_args, params=SIM_PARAMS)
    assert ros.spin_until(lambda: not second.running, 120.0), second.output  # ends on its target reached
    assert second.wait(timeout=1) == 0, second.output
    ros.spin_for(0.5)
    new_run = after_last_restart(states)
    assert new_run is not states and _t(new_run[0]) < 0.1, [_t(s) for s in new_run[:3]]
    # The old run's cmd_vel (the robot was driving at 0.2+ m/s) never drove the new robot.
    assert new_run[0].velocity_ref == 0.0 and new_run[0].cmd_vel_stale
    assert not any(s.fallen for s in new_run)
    new_world = after_last_restart(world)
    reached = [w for w in new_world if w.target_reached]
    assert reached
    if planner_rate:  # the simulator waits for each plan: the run is the same on any machine
        assert new_world[-1].collision_count == 0
    else:
        # The planner runs free beside a simulator faster than real time: on a loaded machine its world can
        # come late (mode stale: the robot stops), and the crossing obstacle may walk into the stopped robot.
        assert not contacts_while_driving(new_world, new_run), contacts_while_driving(new_world, new_run)
    assert "lockstep timeout at" not in second.output and "0 lockstep timeouts" in second.output, second.output[-2000:]
    assert any(_t(p) < 1.0 for p in after_last_restart(plans))  # the planner planned from the new t = 0
    assert "clock jumped back" in controller.output and "clock jumped back" in planner.output
    print(f"simulator killed at t = {killed_at:.2f} s; the new run reached its target at"
          f" t = {_t(reached[-1]):.2f} s with {len(new_run)} control samples")


def _run(out: Path, env: dict[str, str]) -> Path:
    done = subprocess.run([sys.executable, "-m", "twbr_runner.runner", str(COURSE), "--out", str(out), "--quiet",
                           "--no-figures"], env=env, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    (run_dir,) = out.iterdir()
    return run_dir


# ~50 s: make test-long. make test keeps the same property on the LiDAR graph (test_e2e_perception: the
# world's target, the tracker's obstacles, idle and loaded, gap 0 m).
@pytest.mark.long
@pytest.mark.alone
def test_the_same_run_on_an_idle_and_on_a_loaded_machine_gives_the_same_path(tmp_path, ros_env):
    # Before: under load the world reached the planner after the odom of its instant (world_timeout: the
    # robot stopped without a ramp), and cmd_vel took effect at whichever state it happened to beat.
    idle = _run(tmp_path / "idle", ros_env)
    with busy_loops():
        loaded = _run(tmp_path / "loaded", ros_env)
    series = [series_from_messages(read_messages(r / "bag", ["/odom", "/clock"])) for r in (idle, loaded)]
    a, b = series
    common, ia, ib = np.intersect1d(a.odom_t, b.odom_t, return_indices=True)
    assert len(common) >= 0.99 * max(len(a.odom_t), len(b.odom_t))  # the recorder may miss a sample
    gap = np.hypot(a.x_c[ia] - b.x_c[ib], a.y_c[ia] - b.y_c[ib])
    assert gap.max() <= 1e-9, (gap.max(), common[np.argmax(gap)])
    m = [json.loads((r / "metrics.json").read_text()) for r in (idle, loaded)]
    for key in ("reached", "time_to_reach_s", "collisions", "min_clearance_m", "pitch_min_rad", "pitch_max_rad",
                "lockstep_timeouts", "cmd_vel_stale_samples", "sim_time_s"):
        assert m[0][key] == m[1][key], (key, m[0][key], m[1][key])
    assert m[0]["lockstep_timeouts"] == 0
    print(f"idle: real-time factor {m[0]['real_time_factor']:.2f}, loaded: {m[1]['real_time_factor']:.2f};"
          f" {len(common)} states compared, largest gap {gap.max():.1e} m")


def _stopped_at(output: str) -> float:
    """The sim time sim_node says it stopped at ("stopped at t = 12.345 s ...")."""
    import re

    found = re.findall(r"stopped at t = ([0-9.]+) s", output)
    assert found, output[-2000:]
    return float(found[-1])


def _runs(odoms: list[tuple[float, float, float]]) -> list[dict[float, tuple[float, float]]]:
    """Odom samples (t, x, y) split into runs where the stamps go back (a new simulator)."""
    runs: list[dict[float, tuple[float, float]]] = []
    last = None
    for t, x, y in odoms:
        if last is None or t < last - 1e-9:
            runs.append({})
        runs[-1][round(t, 6)] = (x, y)
        last = t
    return runs


@pytest.mark.long  # ~40 s: make test-long; a restart is in make test by test_simulator_killed_and_started_again
def test_by_hand_graph_restarted_never_waits_and_repeats_its_path(launch, ros):
    """README's by-hand graph: controller and planner by hand, then a lockstep sim_node with
    lockstep_planner_rate and no wait_for_subscribers, three times over (at once, ~1 s and ~6 s after the
    last run ended), then once more started the other way round (simulator first). Before: a new simulator's
    single /clock = 0 could reach the nodes before their subscriptions matched, and it held t = 0 for good
    (the nodes, on the old run's clock, took stamp 0 for "no stamp"); and the first plan went out with or
    without its world depending on discovery, so the same scenario ended 50 ms apart from one run to the
    next."""
    odoms: list[tuple[float, float, float]] = []
    ros.node.create_subscription(
        Odometry, "odom", lambda m: odoms.append((_t(m), m.pose.pose.position.x, m.pose.pose.position.y)), RELIABLE)
    controller = launch("twbr_control", "controller_node", params=("controller.yaml",))
    planner = launch("twbr_planner", "planner_node", params=("planner.yaml",))
    # the scenario's own duration applies (sim.yaml says -1): no -p duration
    sim_args = ("-p", f"scenario:={COURSE}", "-p", "lockstep_planner_rate:=20.0")
    ends = []

    def run_to_the_end(sim) -> None:
        assert ros.spin_until(lambda: not sim.running, 90.0), \
            f"the simulator never ended:\n{sim.output[-3000:]}\nplanner:\n{planner.output[-1500:]}"
        assert sim.wait(timeout=1) == 0, sim.output
        ends.append(_stopped_at(sim.output))
        assert "lockstep timeout at" not in sim.output, sim.output[-2000:]

    for pause in (0.0, 1.0, 6.0):
        ros.spin_for(pause)
        run_to_the_end(launch("twbr_sim", "sim_node", *sim_args, params=SIM_PARAMS))
    old_nodes = controller.output, planner.output
    controller.stop()
    planner.stop()
    # The other order: the simulator first, holding t = 0, and the planner's world subscription matching
    # only later (before: the first plan went out without a target, and the run ended 50 ms later).
    sim = launch("twbr_sim", "sim_node", *sim_args, params=SIM_PARAMS)
    ros.spin_for(1.5)
    launch("twbr_control", "controller_node", params=("controller.yaml",))
    planner = launch("twbr_planner", "planner_node", params=("planner.yaml",))
    run_to_the_end(sim)
    ros.spin_for(0.5)
    assert ends[0] < 40.0 and len(set(ends)) == 1, ends  # on the target, not at the 40 s limit; all alike
    runs = _runs(odoms)
    assert len(runs) == 4, [len(r) for r in runs]
    first = runs[0]
    for other in runs[1:]:
        common = sorted(set(first) & set(other))
        assert len(common) >= 0.99 * min(len(first), len(other)), (len(common), len(first), len(other))
        gap = max(np.hypot(first[t][0] - other[t][0], first[t][1] - other[t][1]) for t in common)
        assert gap <= 1e-9, gap
    assert all(out.count("clock jumped back") >= 2 for out in old_nodes)
    print(f"four by-hand runs ended at t = {ends} s, the same path to the bit")


def test_a_fall_in_one_run_is_forgotten_by_the_next(launch, ros):
    """Realtime: the controller frozen (SIGSTOP) for 2 s lets the robot fall and latches `fallen`; a restarted
    simulator's upright robot must then drive, not stand still on the old run's fall."""
    states: list[ControllerState] = []
    ros.node.create_subscription(ControllerState, "controller_state", states.append, RELIABLE)
    controller = launch("twbr_control", "controller_node", params=("controller.yaml",))
    launch("twbr_planner", "planner_node", params=("planner.yaml",))
    sim_args = ("-p", f"scenario:={COURSE}", "-p", "mode:=realtime", "-p", "wait_for_subscribers:=2",
                "-p", "duration:=0.0")
    first = launch("twbr_sim", "sim_node", *sim_args, params=SIM_PARAMS)
    assert ros.spin_until(lambda: states and _t(states[-1]) > 2.0 and states[-1].velocity_ref > 0.1, 30.0), \
        first.output
    os.killpg(controller.proc.pid, signal.SIGSTOP)
    ros.spin_for(2.0)
    os.killpg(controller.proc.pid, signal.SIGCONT)
    assert ros.spin_until(lambda: states and states[-1].fallen, 10.0), controller.output
    first.stop()
    before = len(states)
    second = launch("twbr_sim", "sim_node", *sim_args, params=SIM_PARAMS)
    # The new run: from the first state stamped near 0 on (the old run's last states may still come in).
    def new_run_states() -> list[ControllerState]:
        later = states[before:]
        start = next((i for i, s in enumerate(later) if _t(s) < 0.5), None)
        return [] if start is None else later[start:]

    assert ros.spin_until(lambda: new_run_states() and _t(new_run_states()[-1]) > 4.0, 30.0), second.output
    new_run = [s for s in new_run_states() if _t(s) < 10.0]
    assert new_run and not any(s.fallen for s in new_run), [(round(_t(s), 3), s.fallen) for s in new_run[:5]]
    assert max(s.velocity for s in new_run) > 0.1  # it drives towards the target
    assert "old run's fall forgotten" in controller.output
