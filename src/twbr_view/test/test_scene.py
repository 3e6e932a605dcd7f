"""The viewer's data path without a browser: what RunView logs for a short run of messages."""

from __future__ import annotations

import math

import pytest

pytest.importorskip("rerun", reason="rerun-sdk is not installed (the viewer is optional)")

from nav_msgs.msg import Odometry
from sensor_msgs.msg import JointState

from twbr_msgs.msg import ControllerState, Obstacle, ObstacleArray, PlannerState
from twbr_view.scene import RunView, feed


def stamped(msg, t: float):
    msg.header.stamp.sec, msg.header.stamp.nanosec = int(t), round((t % 1.0) * 1e9)
    return msg


class Sink:
    def __init__(self) -> None:
        self.entries: list[tuple[float, str, object]] = []
        self.t = 0.0

    def log(self, path: str, archetype: object) -> None:
        self.entries.append((self.t, path, archetype))

    def set_time(self, t: float) -> None:
        self.t = t

    def paths(self, prefix: str) -> list[tuple[float, object]]:
        return [(t, a) for t, p, a in self.entries if p == prefix]


def drive(view: RunView, seconds: float = 4.0) -> None:
    """A robot driving along x at 0.5 m/s toward a target at (5, 0), one obstacle at (2, 1): odom and
    controller_state at 200 Hz, the world and the planner at 20 Hz."""
    for k in range(int(seconds * 200) + 1):
        t = k / 200.0
        odom = stamped(Odometry(), t)
        odom.pose.pose.position.x = 0.5 * t
        odom.pose.pose.orientation.w = 1.0
        feed(view, "/odom", odom)
        state = stamped(ControllerState(velocity_ref=0.5, velocity=0.49, pitch=0.01), t)
        feed(view, "controller_state", state)
        feed(view, "joint_states", stamped(JointState(effort=[0.1, 0.2]), t))
        if k % 10 == 0:
            target = stamped(Odometry(), t)
            target.pose.pose.position.x = 5.0
            feed(view, "target", target)
            obstacle = Obstacle(id=3, radius=0.4)
            obstacle.position.x, obstacle.position.y = 2.0, 1.0
            feed(view, "obstacles", stamped(ObstacleArray(obstacles=[obstacle]), t))
            plan = stamped(PlannerState(mode="tracking", method="paper", k_p=0.2, k_v=0.1, k_o=10.0, rho_o=2.0,
                                        robot_radius=0.3, min_distance=0.1, distance_to_target=5.0 - 0.5 * t,
                                        nearest_obstacle_distance=1.0), t)
            plan.total_force.x = plan.attractive_force.x = 1.0
            feed(view, "planner_state", plan)


def test_the_map_and_the_plots_are_logged_on_sim_time():
    sink = Sink()
    view = RunView(sink.log, sink.set_time)
    drive(view)
    logged = view.logged
    # The pose at most 30 times a second of sim time; the path once it has grown by 5 cm (2 m: ~40 points).
    assert 110 <= logged["map/robot"] <= 121 and 38 <= logged["map/robot/path"] <= 41
    last_robot = sink.paths("map/robot")[-1]
    assert last_robot[0] == pytest.approx(4.0, abs=1.0 / 30.0)  # the last pose drawn, on its own stamp
    # Time series decimated to series_rate (50 Hz): 201 of 801 controller states.
    assert logged["plots/speed/reference"] == 201
    assert logged["plots/torque/left_delivered"] == 201
    # The field about once a second, once the planner has given its gains.
    assert 4 <= logged["map/field"] <= 5
    for path in ("map/target", "map/obstacles", "map/obstacles/velocity", "map/forces/total",
                 "map/detection_range", "planner/mode", "plots/distance/to_target"):
        assert logged[path] == 81, path


def test_the_total_force_arrow_points_along_the_force_and_has_a_fixed_length():
    sink = Sink()
    view = RunView(sink.log, sink.set_time)
    drive(view, 0.5)
    _t, arrow = sink.paths("map/forces/total")[-1]
    vector = arrow.vectors.as_arrow_array().to_pylist()[0]
    assert math.hypot(vector[0], vector[1]) == pytest.approx(1.5)
    assert vector[1] == pytest.approx(0.0)
