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
from matplotlib import colormaps

from twbr_common.cdr import UNKNOWN_POSITION
from twbr_planner.apf import Obstacles, potential  # at start-up: it loads numba, seconds of CPU

ROBOT_RGB = (230, 40, 40)
TARGET_RGB = (40, 200, 60)
OBSTACLE_RGB = (200, 200, 200)
TRUTH_RGB = (110, 110, 110)  # the world's own obstacles, beside what the tracker sees (--perception lidar)
SCAN_RGB = (255, 170, 0)
TRACKED_TARGET_RGB = (150, 255, 150)
FORCE_RGB = {"attractive": (0, 200, 255), "repulsive": (255, 150, 0), "total": (255, 255, 255)}
ARROW_LENGTH = 1.5  # [m] of the total force's arrow (the others to its scale, capped at twice that)
FIELD_GRID = 60  # samples per axis of the potential floor
FIELD_MARGIN = 3.0  # [m] around the robot and the target


def stamp_of(msg: Any) -> float:
    s = msg.header.stamp
    return s.sec + 1e-9 * s.nanosec


_UNIT_CIRCLE = np.column_stack([np.cos(np.linspace(0.0, 2.0 * math.pi, 49)),
                                np.sin(np.linspace(0.0, 2.0 * math.pi, 49)), np.zeros(49)])


def circle(x: float, y: float, r: float) -> np.ndarray:
    return _UNIT_CIRCLE * (r, r, 0.0) + (x, y, 0.02)


VIRIDIS = (colormaps["viridis"](np.linspace(0.0, 1.0, 256))[:, :3] * 255).astype(np.uint8)


def _colormap(values: np.ndarray) -> np.ndarray:
    lo, hi = float(values.min()), float(np.percentile(values, 99))
    scaled = np.clip((values - lo) / (hi - lo if hi > lo else 1.0), 0.0, 1.0)
    return VIRIDIS[np.rint(scaled * 255).astype(np.intp)]


class Trail:
    """A path that grows by a point once it has moved `spacing` from the last one (numpy: cheap to log)."""

    def __init__(self, spacing: float) -> None:
        self.spacing = spacing
        self._xyz = np.empty((256, 3))
        self.n = 0

    def extend(self, x: float, y: float) -> None:
        if self.n and math.hypot(x - self._xyz[self.n - 1, 0], y - self._xyz[self.n - 1, 1]) < self.spacing:
            return
        if self.n == len(self._xyz):
            self._xyz = np.concatenate([self._xyz, np.empty_like(self._xyz)])
        self._xyz[self.n] = (x, y, 0.03)
        self.n += 1

    @property
    def points(self) -> np.ndarray:
        return self._xyz[: self.n]


# Time series, one entity per plot with a line per value (one log call for the pair):
# entity -> the lines' names, in the order RunView logs their values.
SERIES = {
    "plots/speed": ("v_ref", "v"),
    "plots/yaw_rate": ("omega_ref", "omega"),
    "plots/pitch": ("pitch_ref", "pitch"),
    "plots/torque/commanded": ("left commanded", "right commanded"),
    "plots/torque/delivered": ("left delivered", "right delivered"),
    "plots/distance": ("distance to target", "clearance"),
}


class RunView:
    """Messages in, Rerun entities out. Each entity's look (colours, sizes, names) is logged once as
    static; what changes is logged with its stamp, as few calls as the view allows: a log call costs
    about 0.1-0.3 ms of the viewer's CPU whatever its size."""

    def __init__(self, log: Callable[..., None], set_time: Callable[[float], None],
                 field_period: float = 1.0, series_period: float = 0.02, path_spacing: float = 0.05,
                 pose_period: float = 1.0 / 30.0, path_period: float = 0.25) -> None:
        import rerun as rr

        self.rr = rr
        self._log = log
        self._set_time = set_time
        self.field_period = field_period
        self.series_period = series_period
        self.pose_period = pose_period
        self.path_period = path_period
        self.robot_xy: tuple[float, float] | None = None
        self.robot_yaw = 0.0
        self.target_xy: tuple[float, float] | None = None
        self.obstacles: list[tuple[int, float, float, float, float, float]] = []  # what the planner avoids
        self._drawn: dict[str, list] = {}  # obstacle lists as last drawn, by entity
        self.robot_path = Trail(path_spacing)
        self.target_path = Trail(path_spacing)
        self.gains: dict[str, float] | None = None
        self.mode: str | None = None
        self.reach: float | None = None
        self._next_field = 0.0
        self._next_series: dict[str, float] = {}
        self.logged: dict[str, int] = {}  # entity path -> times logged (for tests and the node's report)
        self._style()

    def _style(self) -> None:
        rr = self.rr
        for path, archetype in (
                # The robot's frame moves (map/robot: one transform per pose); what is drawn in it is static.
                ("map/robot/body", rr.Points3D([[0.0, 0.0, 0.1]], radii=[0.12], colors=[ROBOT_RGB])),
                ("map/robot/heading", rr.Arrows3D(origins=[[0.0, 0.0, 0.1]], vectors=[[0.6, 0.0, 0.0]],
                                                  colors=[ROBOT_RGB])),
                ("map/robot_path", rr.LineStrips3D.from_fields(colors=[ROBOT_RGB])),
                ("map/target", rr.Points3D.from_fields(radii=[0.15], colors=[TARGET_RGB])),
                ("map/obstacles", rr.Points3D.from_fields(colors=[OBSTACLE_RGB])),
                ("map/obstacles/velocity", rr.Arrows3D.from_fields(colors=[OBSTACLE_RGB])),
                ("map/obstacles_truth", rr.Points3D.from_fields(colors=[TRUTH_RGB])),
                ("map/obstacles_truth/velocity", rr.Arrows3D.from_fields(colors=[TRUTH_RGB])),
                ("map/scan", rr.Points3D.from_fields(radii=[0.02], colors=[SCAN_RGB])),
                ("map/target_tracked", rr.Points3D.from_fields(radii=[0.1], colors=[TRACKED_TARGET_RGB])),
                ("map/target_path", rr.LineStrips3D.from_fields(colors=[TARGET_RGB])),
                ("map/robot/detection_range", rr.LineStrips3D.from_fields(colors=[(120, 120, 255)])),
                ("map/forces", rr.Arrows3D.from_fields(colors=list(FORCE_RGB.values()), labels=list(FORCE_RGB)))):
            self._log(path, archetype, static=True)
        for path, names in SERIES.items():
            self._log(path, rr.SeriesLines(names=list(names)), static=True)

    def log(self, path: str, archetype: Any) -> None:
        self.logged[path] = self.logged.get(path, 0) + 1
        self._log(path, archetype)

    def _due(self, name: str, t: float, period: float | None = None) -> bool:
        if t + 1e-9 < self._next_series.get(name, -math.inf):
            return False
        self._next_series[name] = t + (self.series_period if period is None else period)
        return True

    def _path(self, path: str, trail: Trail, t: float) -> None:
        if trail.n > 1 and self._due(path, t, self.path_period):
            self.log(path, self.rr.LineStrips3D.from_fields(strips=[trail.points]))

    # --- the map -----------------------------------------------------------------------------------
    def odom(self, t: float, x: float, y: float, yaw: float) -> None:
        self.robot_xy = (x, y)
        self.robot_yaw = yaw
        self.robot_path.extend(x, y)
        if not self._due("pose", t, self.pose_period):  # a screen shows ~30 frames a second
            return
        rr = self.rr
        self._set_time(t)
        self.log("map/robot", rr.Transform3D(translation=[x, y, 0.0],
                                             quaternion=[0.0, 0.0, math.sin(0.5 * yaw), math.cos(0.5 * yaw)]))
        self._path("map/robot_path", self.robot_path, t)
        self._field(t)

    def target(self, t: float, x: float, y: float) -> None:
        self.target_path.extend(x, y)
        if (x, y) == self.target_xy:  # a target standing still is drawn once
            return
        self._set_time(t)
        self.target_xy = (x, y)
        self.log("map/target", self.rr.Points3D.from_fields(positions=[[x, y, 0.1]]))
        self._path("map/target_path", self.target_path, t)

    def obstacle_list(self, t: float, obstacles: list[tuple[int, float, float, float, float, float]],
                      entity: str = "map/obstacles") -> None:
        """(id, x, y, vx, vy, radius) of every obstacle now: a disc each (a sphere seen from above), labelled
        with its id, and its velocity; drawn again only when something changed. `map/obstacles` is what the
        planner avoids (the world's, or the tracker's), `map/obstacles_truth` the world's beside the tracks."""
        if entity == "map/obstacles":
            self.obstacles = obstacles
        before = self._drawn.get(entity, [])
        if obstacles == before:
            return
        rr = self.rr
        self._set_time(t)
        ids = [str(i) for i, *_ in obstacles]
        relabel = ids != [str(i) for i, *_ in before]
        self._drawn[entity] = obstacles
        state = np.array([o[1:] for o in obstacles], dtype=float).reshape(-1, 5)  # x, y, vx, vy, radius
        centres = np.column_stack([state[:, :2], np.zeros(len(state))])
        self.log(entity, rr.Points3D.from_fields(positions=centres, radii=state[:, 4],
                                                 labels=ids if relabel else None))
        self.log(f"{entity}/velocity", rr.Arrows3D.from_fields(
            origins=centres + np.array([0.0, 0.0, 0.05]), vectors=np.column_stack([state[:, 2:4], np.zeros(len(state))])))

    def scan(self, t: float, ranges: np.ndarray, angle_min: float, angle_increment: float) -> None:
        """A LiDAR scan's returns as points on the map, from the robot's last pose (its lean and the
        scan's turn left out: a picture of what it sees, not the tracker's geometry)."""
        if self.robot_xy is None:
            return
        self._set_time(t)
        bearings = self.robot_yaw + angle_min + angle_increment * np.arange(len(ranges))
        hit = np.isfinite(ranges)
        r = ranges[hit]
        points = np.column_stack([self.robot_xy[0] + r * np.cos(bearings[hit]),
                                  self.robot_xy[1] + r * np.sin(bearings[hit]), np.full(len(r), 0.2)])
        self.log("map/scan", self.rr.Points3D.from_fields(positions=points))

    def tracked_target(self, t: float, x: float, y: float) -> None:
        """The tracker's fused target (from target_detections), beside the world's."""
        self._set_time(t)
        self.log("map/target_tracked", self.rr.Points3D.from_fields(positions=[[x, y, 0.15]]))

    def planner(self, t: float, msg: Any) -> None:
        """planner_state: force arrows, detection range, mode, and the gains the field is drawn with."""
        rr = self.rr
        self._set_time(t)
        self.gains = {name: float(getattr(msg, name)) for name in
                      ("k_p", "k_v", "k_o", "rho_o", "robot_radius", "min_distance")}
        mode = f"{msg.mode} ({msg.method})"
        if mode != self.mode:  # a text panel: logged when it changes
            self.mode = mode
            self.log("planner/mode", rr.TextDocument(mode))
        if self._due("planner", t):
            self.log("plots/distance", rr.Scalars([float(msg.distance_to_target),
                                                   min(float(msg.nearest_obstacle_distance), 1e3)]))
        if self.robot_xy is None:
            return
        x, y = self.robot_xy
        total = msg.total_force
        norm = math.hypot(total.x, total.y)
        scale = ARROW_LENGTH / norm if math.isfinite(norm) and norm > 0.0 else 0.0
        vectors = []
        for name in FORCE_RGB:
            f = getattr(msg, f"{name}_force")
            u, v = (scale * f.x, scale * f.y) if math.isfinite(f.x + f.y) else (0.0, 0.0)
            cap = max(1.0, math.hypot(u, v) / (2.0 * ARROW_LENGTH))
            vectors.append([u / cap, v / cap, 0.0])
        self.log("map/forces", rr.Arrows3D.from_fields(origins=[[x, y, 0.15]] * len(vectors), vectors=vectors))
        reach = float(getattr(msg, "repulsion_range", 0.0)) or self.gains["rho_o"]
        if reach != self.reach:  # drawn in the robot's frame: logged again only when it changes
            self.reach = reach
            self.log("map/robot/detection_range", rr.LineStrips3D.from_fields(strips=[circle(0.0, 0.0, reach)]))

    def _field(self, t: float) -> None:
        """The potential floor (eq. 24) around the robot and the target, about once per field_period."""
        if t + 1e-9 < self._next_field or self.gains is None or self.target_xy is None or self.robot_xy is None:
            return
        self._next_field = t + self.field_period
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
        if not self._due("controller", t):
            return
        rr = self.rr
        self._set_time(t)
        self.log("plots/speed", rr.Scalars([msg.velocity_ref, msg.velocity]))
        self.log("plots/yaw_rate", rr.Scalars([msg.yaw_rate_ref, msg.yaw_rate]))
        self.log("plots/pitch", rr.Scalars([msg.pitch_ref, msg.pitch]))
        self.log("plots/torque/commanded", rr.Scalars([msg.left_torque, msg.right_torque]))

    def joints(self, t: float, effort: tuple[float, float]) -> None:
        if len(effort) < 2 or not self._due("joints", t):
            return
        self._set_time(t)
        self.log("plots/torque/delivered", self.rr.Scalars([float(effort[0]), float(effort[1])]))


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
    elif name in ("obstacles", "obstacles_truth"):
        view.obstacle_list(stamp_of(msg), [(int(o.id), o.position.x, o.position.y, o.velocity.x, o.velocity.y,
                                            o.radius) for o in msg.obstacles], f"map/{name}")
    elif name == "scan":
        view.scan(stamp_of(msg), np.asarray(msg.ranges, dtype=float), msg.angle_min, msg.angle_increment)
    elif name == "target_tracked" and msg.pose.covariance[0] != UNKNOWN_POSITION:  # not seen yet: nothing to draw
        p = msg.pose.pose.position
        view.tracked_target(stamp_of(msg), p.x, p.y)
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
    "obstacles_truth": "twbr_msgs/msg/ObstacleArray",
    "scan": "sensor_msgs/msg/LaserScan",
    "target_tracked": "nav_msgs/msg/Odometry",
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
