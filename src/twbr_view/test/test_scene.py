"""The viewer's data path without a browser: what RunView logs for a short run of messages."""

from __future__ import annotations

import math

import numpy as np
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
        self.static: dict[str, object] = {}
        self.t = 0.0

    def log(self, path: str, archetype: object, static: bool = False) -> None:
        if static:
            self.static[path] = archetype
        else:
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
    # The pose (the robot's frame) at most 30 times a second of sim time, on its own stamp.
    assert 110 <= logged["map/robot"] <= 121
    t_last, pose = sink.paths("map/robot")[-1]
    assert t_last == pytest.approx(4.0, abs=1.0 / 30.0)
    assert pose.translation.as_arrow_array().to_pylist()[0][0] == pytest.approx(0.5 * t_last)
    # The path: a point every 5 cm, re-drawn about every 0.25 s (checked at the 30 Hz pose): the last one
    # drawn is at most ~0.3 s (15 cm) behind the robot's 2 m.
    assert 13 <= logged["map/robot_path"] <= 17
    t_path, strip = sink.paths("map/robot_path")[-1]
    points = strip.strips.as_arrow_array().to_pylist()[0]
    assert t_path > 3.7 and points[-1][0] == pytest.approx(0.5 * t_path, abs=0.05)
    assert len(points) == pytest.approx(0.5 * t_path / 0.05 + 1, abs=1.5)
    # Time series decimated to series_rate (50 Hz): 201 of 801 controller states, both lines in one call.
    assert logged["plots/speed"] == 201 and logged["plots/torque/delivered"] == 201
    assert sink.paths("plots/speed")[-1][1].scalars.as_arrow_array().to_pylist() == pytest.approx([0.5, 0.49])
    assert sink.paths("plots/torque/delivered")[-1][1].scalars.as_arrow_array().to_pylist() == pytest.approx(
        [0.1, 0.2])
    # The field about once a second, once the planner has given its gains.
    assert 4 <= logged["map/field"] <= 5
    for path in ("map/forces", "plots/distance"):
        assert logged[path] == 81, path
    # What does not change is logged once: the standing target and obstacle, the mode, the detection range
    # (a circle in the robot's frame).
    for path in ("map/target", "map/obstacles", "map/obstacles/velocity", "planner/mode",
                 "map/robot/detection_range"):
        assert logged[path] == 1, path
    # Each entity's look is logged once, as static: the lines' names, the robot's colour.
    assert sink.static["plots/speed"].names.as_arrow_array().to_pylist() == ["v_ref", "v"]
    assert sink.static["map/robot/body"].colors is not None


def test_a_moving_obstacle_is_drawn_again_and_a_removed_one_disappears():
    sink = Sink()
    view = RunView(sink.log, sink.set_time)
    view.obstacle_list(0.0, [(1, 2.0, 1.0, 0.0, 0.0, 0.4), (2, 4.0, 0.0, 0.1, 0.0, 0.3)])
    view.obstacle_list(0.05, [(1, 2.0, 1.0, 0.0, 0.0, 0.4), (2, 4.005, 0.0, 0.1, 0.0, 0.3)])
    view.obstacle_list(0.10, [(1, 2.0, 1.0, 0.0, 0.0, 0.4)])
    first, moved, removed = (a for _t, a in sink.paths("map/obstacles"))
    assert moved.positions.as_arrow_array().to_pylist()[1][0] == pytest.approx(4.005)
    assert first.radii.as_arrow_array().to_pylist() == pytest.approx([0.4, 0.3])
    assert first.labels.as_arrow_array().to_pylist() == ["1", "2"] and moved.labels is None  # same ids
    assert removed.positions.as_arrow_array().to_pylist() == [[2.0, 1.0, 0.0]]
    assert removed.labels.as_arrow_array().to_pylist() == ["1"]


def test_with_the_lidar_the_scan_the_tracks_and_the_truth_are_drawn_apart():
    sink = Sink()
    view = RunView(sink.log, sink.set_time)
    view.scan(0.0, np.array([1.0]), 0.0, 0.1)  # before any pose: nowhere to draw it from
    assert not sink.paths("map/scan")
    view.odom(0.0, 1.0, 2.0, math.pi / 2)
    ranges = np.array([2.0, math.inf, 3.0, -math.inf])  # REP 117's infinities are no points
    view.scan(0.1, ranges, 0.0, math.pi / 2)
    ((_t, scan),) = sink.paths("map/scan")
    # facing +y: the first beam 2 m ahead, the third 3 m behind
    assert np.allclose(scan.positions.as_arrow_array().to_pylist(), [[1.0, 4.0, 0.2], [1.0, -1.0, 0.2]])
    view.obstacle_list(0.1, [(1, 2.0, 1.0, 0.5, 0.0, 0.3)])  # the tracks: what the planner avoids
    view.obstacle_list(0.1, [(7, 2.05, 1.0, 0.5, 0.0, 0.3)], "map/obstacles_truth")
    assert view.obstacles == [(1, 2.0, 1.0, 0.5, 0.0, 0.3)]  # the field is drawn round the tracks
    ((_t, truth),) = sink.paths("map/obstacles_truth")
    assert truth.labels.as_arrow_array().to_pylist() == ["7"]
    view.tracked_target(0.1, 5.0, 5.0)
    ((_t, target),) = sink.paths("map/target_tracked")
    assert np.allclose(target.positions.as_arrow_array().to_pylist(), [[5.0, 5.0, 0.15]])


def test_the_total_force_arrow_points_along_the_force_and_has_a_fixed_length():
    sink = Sink()
    view = RunView(sink.log, sink.set_time)
    drive(view, 0.5)
    _t, arrows = sink.paths("map/forces")[-1]
    attractive, _repulsive, total = arrows.vectors.as_arrow_array().to_pylist()
    assert math.hypot(total[0], total[1]) == pytest.approx(1.5)
    assert total[1] == pytest.approx(0.0) and attractive == pytest.approx(total)
