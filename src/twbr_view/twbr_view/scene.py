"""What the viewer draws, from the graph's messages: one implementation for the live node and for a bag.

`RunView` turns messages (rclpy's, or a bag's decoded ones: the same field names) into Rerun entities on
the sim-time timeline, through a sink `log(entity_path, archetype)`; it decides what to draw and how often,
never how it is sent. The map is a 3D scene seen from above (x east, y north, z up, metres): the robot, its
heading and path, the target and its path, each obstacle as a disc with its velocity, the planner's
detection range and force arrows, and the potential field as a coloured floor refreshed about once a
second. Time series go under `plots/`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

ROBOT_RGB = (230, 40, 40)
TARGET_RGB = (40, 200, 60)
OBSTACLE_RGB = (200, 200, 200)
FORCE_RGB = {"attractive": (0, 200, 255), "repulsive": (255, 150, 0), "total": (255, 255, 255)}
ARROW_LENGTH = 1.5  # [m] of the total force's arrow (the others to its scale, capped at twice that)
FIELD_GRID = 60  # samples per axis of the potential floor
FIELD_MARGIN = 3.0  # [m] around the robot and the target


def stamp_of(msg: Any) -> float:
    s = msg.header.stamp
    return s.sec + 1e-9 * s.nanosec


def circle(x: float, y: float, r: float, n: int = 48) -> np.ndarray:
    a = np.linspace(0.0, 2.0 * math.pi, n + 1)
    return np.column_stack([x + r * np.cos(a), y + r * np.sin(a), np.full(n + 1, 0.02)])


def _colormap(values: np.ndarray) -> np.ndarray:
    from matplotlib import colormaps

    lo, hi = float(values.min()), float(np.percentile(values, 99))
    scaled = np.clip((values - lo) / (hi - lo if hi > lo else 1.0), 0.0, 1.0)
    return (colormaps["viridis"](scaled)[..., :3] * 255).astype(np.uint8)


class RunView:
    def __init__(self, log: Callable[[str, Any], None], set_time: Callable[[float], None],
                 field_period: float = 1.0, series_period: float = 0.02, path_spacing: float = 0.05,
                 pose_period: float = 1.0 / 30.0) -> None:
        import rerun as rr

        self.rr = rr
        self._log = log
        self._set_time = set_time
        self.field_period = field_period
        self.series_period = series_period
        self.path_spacing = path_spacing
        self.pose_period = pose_period
        self.robot_xy: tuple[float, float] | None = None
        self.target_xy: tuple[float, float] | None = None
        self.obstacles: list[tuple[int, float, float, float, float, float]] = []
        self.robot_path: list[tuple[float, float]] = []
        self.target_path: list[tuple[float, float]] = []
        self.gains: dict[str, float] | None = None
        self._next_field = 0.0
        self._next_series: dict[str, float] = {}
        self.logged: dict[str, int] = {}  # entity path -> times logged (for tests and the node's report)

    def log(self, path: str, archetype: Any) -> None:
        self.logged[path] = self.logged.get(path, 0) + 1
        self._log(path, archetype)

    def _series_due(self, name: str, t: float, period: float | None = None) -> bool:
        if t + 1e-9 < self._next_series.get(name, -math.inf):
            return False
        self._next_series[name] = t + (self.series_period if period is None else period)
        return True

    @staticmethod
    def _extend(path: list[tuple[float, float]], x: float, y: float, spacing: float) -> bool:
        if path and math.hypot(x - path[-1][0], y - path[-1][1]) < spacing:
            return False
        path.append((x, y))
        return True

    # --- the map -----------------------------------------------------------------------------------
    def odom(self, t: float, x: float, y: float, yaw: float) -> None:
        self.robot_xy = (x, y)
        if not self._series_due("pose", t, self.pose_period):  # a screen shows ~30 frames a second
            return
        rr = self.rr
        self._set_time(t)
        self.log("map/robot", rr.Points3D([[x, y, 0.1]], radii=[0.12], colors=[ROBOT_RGB]))
        self.log("map/robot/heading", rr.Arrows3D(origins=[[x, y, 0.1]],
                                                  vectors=[[0.6 * math.cos(yaw), 0.6 * math.sin(yaw), 0.0]],
                                                  colors=[ROBOT_RGB]))
        if self._extend(self.robot_path, x, y, self.path_spacing):
            self.log("map/robot/path", rr.LineStrips3D([[(px, py, 0.03) for px, py in self.robot_path]],
                                                       colors=[ROBOT_RGB]))
        self._field(t)

    def target(self, t: float, x: float, y: float) -> None:
        rr = self.rr
        self._set_time(t)
        self.target_xy = (x, y)
        self.log("map/target", rr.Points3D([[x, y, 0.1]], radii=[0.15], colors=[TARGET_RGB]))
        if self._extend(self.target_path, x, y, self.path_spacing):
            self.log("map/target/path", rr.LineStrips3D([[(px, py, 0.03) for px, py in self.target_path]],
                                                        colors=[TARGET_RGB]))

    def obstacle_list(self, t: float, obstacles: list[tuple[int, float, float, float, float, float]]) -> None:
        """(id, x, y, vx, vy, radius) of every obstacle now."""
        rr = self.rr
        self._set_time(t)
        self.obstacles = obstacles
        if not obstacles:
            self.log("map/obstacles", rr.Clear(recursive=True))
            return
        self.log("map/obstacles", rr.LineStrips3D([circle(x, y, r) for _i, x, y, _vx, _vy, r in obstacles],
                                                  colors=[OBSTACLE_RGB] * len(obstacles),
                                                  labels=[str(i) for i, *_ in obstacles]))
        self.log("map/obstacles/velocity", rr.Arrows3D(origins=[[x, y, 0.05] for _i, x, y, *_ in obstacles],
                                                       vectors=[[vx, vy, 0.0] for _i, _x, _y, vx, vy, _r in obstacles],
                                                       colors=[OBSTACLE_RGB] * len(obstacles)))

    def planner(self, t: float, msg: Any) -> None:
        """planner_state: force arrows, detection range, mode, and the gains the field is drawn with."""
        rr = self.rr
        self._set_time(t)
        self.gains = {name: float(getattr(msg, name)) for name in
                      ("k_p", "k_v", "k_o", "rho_o", "robot_radius", "min_distance")}
        self.log("planner/mode", rr.TextDocument(f"{msg.mode} ({msg.method})"))
        if self.robot_xy is None:
            return
        x, y = self.robot_xy
        total = msg.total_force
        norm = math.hypot(total.x, total.y)
        scale = ARROW_LENGTH / norm if math.isfinite(norm) and norm > 0.0 else 0.0
        for name, rgb in FORCE_RGB.items():
            f = getattr(msg, f"{name}_force")
            u, v = (scale * f.x, scale * f.y) if math.isfinite(f.x + f.y) else (0.0, 0.0)
            cap = max(1.0, math.hypot(u, v) / (2.0 * ARROW_LENGTH))
            self.log(f"map/forces/{name}", rr.Arrows3D(origins=[[x, y, 0.15]], vectors=[[u / cap, v / cap, 0.0]],
                                                       colors=[rgb]))
        reach = float(getattr(msg, "repulsion_range", 0.0)) or self.gains["rho_o"]
        self.log("map/detection_range", rr.LineStrips3D([circle(x, y, reach)], colors=[(120, 120, 255)]))
        if self._series_due("planner", t):
            self.log("plots/distance/to_target", rr.Scalars(float(msg.distance_to_target)))
            self.log("plots/distance/clearance", rr.Scalars(min(float(msg.nearest_obstacle_distance), 1e3)))

    def _field(self, t: float) -> None:
        """The potential floor (eq. 24) around the robot and the target, about once per field_period."""
        if t + 1e-9 < self._next_field or self.gains is None or self.target_xy is None or self.robot_xy is None:
            return
        self._next_field = t + self.field_period
        from twbr_planner.apf import Obstacles, potential

        (rx, ry), (tx, ty) = self.robot_xy, self.target_xy
        x0, x1 = min(rx, tx) - FIELD_MARGIN, max(rx, tx) + FIELD_MARGIN
        y0, y1 = min(ry, ty) - FIELD_MARGIN, max(ry, ty) + FIELD_MARGIN
        xs, ys = np.linspace(x0, x1, FIELD_GRID), np.linspace(y0, y1, FIELD_GRID)
        grid = np.stack(np.meshgrid(xs, ys), axis=-1)
        obstacles = Obstacles.of([(i, x, y, r) for i, x, y, _vx, _vy, r in self.obstacles])
        u = potential(grid, np.array([tx, ty]), obstacles, self.gains)
        colors = _colormap(np.log10(1.0 + u - u.min()))
        n = FIELD_GRID
        vertices = np.column_stack([grid[..., 0].ravel(), grid[..., 1].ravel(), np.zeros(n * n)])
        k = np.arange(n * n).reshape(n, n)[:-1, :-1].ravel()
        triangles = np.concatenate([np.column_stack([k, k + 1, k + n]), np.column_stack([k + 1, k + n + 1, k + n])])
        self.log("map/field", self.rr.Mesh3D(vertex_positions=vertices, triangle_indices=triangles,
                                             vertex_colors=colors.reshape(-1, 3)))

    # --- time series -------------------------------------------------------------------------------
    def controller(self, t: float, msg: Any) -> None:
        if not self._series_due("controller", t):
            return
        rr = self.rr
        self._set_time(t)
        for path, value in (("plots/speed/reference", msg.velocity_ref), ("plots/speed/measured", msg.velocity),
                            ("plots/yaw_rate/reference", msg.yaw_rate_ref), ("plots/yaw_rate/measured", msg.yaw_rate),
                            ("plots/pitch/reference", msg.pitch_ref), ("plots/pitch/measured", msg.pitch),
                            ("plots/torque/left_commanded", msg.left_torque),
                            ("plots/torque/right_commanded", msg.right_torque)):
            self.log(path, rr.Scalars(float(value)))

    def joints(self, t: float, effort: tuple[float, float]) -> None:
        if len(effort) < 2 or not self._series_due("joints", t):
            return
        self._set_time(t)
        self.log("plots/torque/left_delivered", self.rr.Scalars(float(effort[0])))
        self.log("plots/torque/right_delivered", self.rr.Scalars(float(effort[1])))


def feed(view: RunView, topic: str, msg: Any) -> None:
    """One message of the graph (live or from a bag) into the view, by topic (a leading '/' or not)."""
    name = topic.rsplit("/", 1)[-1]
    if name == "odom":
        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        yaw = math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))
        view.odom(stamp_of(msg), p.x, p.y, yaw)
    elif name == "target":
        p = msg.pose.pose.position
        view.target(stamp_of(msg), p.x, p.y)
    elif name == "obstacles":
        view.obstacle_list(stamp_of(msg), [(int(o.id), o.position.x, o.position.y, o.velocity.x, o.velocity.y,
                                            o.radius) for o in msg.obstacles])
    elif name == "planner_state":
        view.planner(stamp_of(msg), msg)
    elif name == "controller_state":
        view.controller(stamp_of(msg), msg)
    elif name == "joint_states":
        view.joints(stamp_of(msg), tuple(msg.effort))


VIEWED_TOPICS = {
    "odom": "nav_msgs/msg/Odometry",
    "target": "nav_msgs/msg/Odometry",
    "obstacles": "twbr_msgs/msg/ObstacleArray",
    "planner_state": "twbr_msgs/msg/PlannerState",
    "controller_state": "twbr_msgs/msg/ControllerState",
    "joint_states": "sensor_msgs/msg/JointState",
}


def blueprint():
    """The layout: the map on the left (two thirds), the planner's mode and the plots on the right."""
    import rerun.blueprint as rrb

    plots = [rrb.TimeSeriesView(origin=f"/plots/{name}", name=title) for name, title in (
        ("speed", "v, v_ref [m/s]"), ("yaw_rate", "omega, omega_ref [rad/s]"), ("pitch", "pitch, pitch_ref [rad]"),
        ("torque", "wheel torques [N·m]"), ("distance", "clearance, distance to target [m]"))]
    return rrb.Blueprint(
        rrb.Horizontal(
            rrb.Vertical(rrb.Spatial3DView(origin="/map", name="map (x, y in m)"),
                         rrb.TextDocumentView(origin="/planner/mode", name="planner mode"), row_shares=[6, 1]),
            rrb.Vertical(*plots),
            column_shares=[2, 1],
        ),
        collapse_panels=True,
    )
