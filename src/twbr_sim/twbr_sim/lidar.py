"""What a 2D LiDAR on the body of a balancing robot returns: one range per beam of a rotating scan, to the
nearest obstacle (a vertical cylinder: the world's discs) or to the floor where the leaning body tips the scan
plane down, as sensor_msgs/LaserScan carries it (REP 117: +inf no return within range_max, -inf closer than
range_min).

The scanner sits `lidar.height` above the axle along the body's axis, so its plane is pitched with the body
(roll 0, pitch theta: a beam at bearing a in the scanner's frame points along (cos a cos th, sin a,
-cos a sin th) in the yaw-aligned frame, as base_link's x tips forward-down when the body leans forward; see
imu.py). A beam hits the floor at t = z / (cos a sin th) when it points down; a cylinder's side where its
horizontal projection meets the disc. Cylinders are taken taller than the scanner (people, posts, walls).

A real scanner turns once per scan: beam i is taken `i * time_increment` after the first. `cast_scan` moves
the robot (at its speed and yaw rate) and each obstacle (at its velocity) to each beam's instant, which is
the skew a tracker sees on a moving robot. `scan_noise` then adds the device's range noise and drops returns
at random. Defaults are an RPLIDAR A1-class device (360 degrees, 1 degree steps, 0.15-12 m, 10 Hz, 1 cm).

Reference: REP 117 (Informational distance measurements), sensor_msgs/LaserScan.
"""

from __future__ import annotations

import math

import numpy as np

from twbr_common.jit import inline_kernel, kernel
from twbr_common.layout import Layout
from twbr_common.params import ParamSpec
from twbr_sim.noise import normal, uniform

LIDAR_SPECS: tuple[ParamSpec, ...] = (
    ParamSpec("lidar.rate", 10.0, "scans per second (0: no scan topic)", "Hz", 0.0, 100.0),
    ParamSpec("lidar.angle_min", -math.pi, "bearing of the first beam, counter-clockwise from ahead", "rad",
              -math.pi, math.pi),
    ParamSpec("lidar.angle_increment", math.radians(1.0), "bearing step between beams", "rad", 1e-4, 1.0,
              low_open=True),
    ParamSpec("lidar.beams", 360, "beams per scan", "", 1, 10000),
    ParamSpec("lidar.range_min", 0.15, "nearest measurable range (closer: -inf, REP 117)", "m", 0.0, 10.0),
    ParamSpec("lidar.range_max", 12.0, "farthest return (no return: +inf, REP 117)", "m", 0.1, 100.0),
    ParamSpec("lidar.height", 0.25, "scanner above the axle, along the body's axis", "m", 0.0, 5.0),
    ParamSpec("lidar.range_noise_std", 0.01, "white noise on each range", "m", 0.0, 1.0),
    ParamSpec("lidar.dropout", 0.01, "probability that a beam's return is missed (+inf)", "", 0.0, 1.0),
    ParamSpec("lidar.frame", "laser", "frame of scan: lidar.height above base_link, on /tf_static"),
)
LIDAR_STREAM = 3  # the scanner's generator stream (noise.new_generator)

SETTINGS_LAYOUT = Layout((
    "angle_min", "angle_increment", "beams", "range_min", "range_max", "height", "time_increment", "noise",
    "dropout",
))
LD_ANGLE_MIN = SETTINGS_LAYOUT["angle_min"]
LD_ANGLE_INCREMENT = SETTINGS_LAYOUT["angle_increment"]
LD_BEAMS = SETTINGS_LAYOUT["beams"]
LD_RANGE_MIN = SETTINGS_LAYOUT["range_min"]
LD_RANGE_MAX = SETTINGS_LAYOUT["range_max"]
LD_HEIGHT = SETTINGS_LAYOUT["height"]
LD_TIME_INCREMENT = SETTINGS_LAYOUT["time_increment"]  # [s] between two beams: one turn per scan period
LD_NOISE = SETTINGS_LAYOUT["noise"]
LD_DROPOUT = SETTINGS_LAYOUT["dropout"]
N_SETTINGS = len(SETTINGS_LAYOUT)


def settings_vector(cfg: dict) -> np.ndarray:
    """The kernel's settings from validated `lidar.*` parameters."""
    beams = int(cfg["lidar.beams"])
    rate = float(cfg["lidar.rate"])
    s = np.zeros(N_SETTINGS)
    s[LD_ANGLE_MIN] = cfg["lidar.angle_min"]
    s[LD_ANGLE_INCREMENT] = cfg["lidar.angle_increment"]
    s[LD_BEAMS] = beams
    s[LD_RANGE_MIN] = cfg["lidar.range_min"]
    s[LD_RANGE_MAX] = cfg["lidar.range_max"]
    s[LD_HEIGHT] = cfg["lidar.height"]
    s[LD_TIME_INCREMENT] = 1.0 / (rate * beams) if rate > 0.0 else 0.0
    s[LD_NOISE] = cfg["lidar.range_noise_std"]
    s[LD_DROPOUT] = cfg["lidar.dropout"]
    return s


@inline_kernel
def scanner_at(x, y, yaw, speed, yaw_rate, dt, lean):
    """The scanner dt [s] into a scan begun at the pose (x, y, yaw) [m, rad], the robot driving at speed
    [m/s] and yaw_rate [rad/s] (a unicycle over one turn): its position [m], `lean` [m] ahead of the axle
    (height x sin pitch), and the heading [rad]. The one rule both the scan's cast and the tracker's
    deskewing follow."""
    heading = yaw + yaw_rate * dt
    if yaw_rate != 0.0 and dt > 0.0:
        px = x + speed / yaw_rate * (math.sin(heading) - math.sin(yaw))
        py = y - speed / yaw_rate * (math.cos(heading) - math.cos(yaw))
    else:
        px = x + speed * dt * math.cos(yaw)
        py = y + speed * dt * math.sin(yaw)
    return px + lean * math.cos(heading), py + lean * math.sin(heading), heading


@kernel
def disc_hit(ox, oy, dx, dy, cx, cy, radius):
    """Horizontal distance along the unit direction (dx, dy) from (ox, oy) to the circle of `radius` at
    (cx, cy); inf when the line misses it or the circle is behind. From inside the circle: 0."""
    fx = cx - ox
    fy = cy - oy
    along = fx * dx + fy * dy
    off2 = fx * fx + fy * fy - along * along
    r2 = radius * radius
    if fx * fx + fy * fy <= r2:
        return 0.0
    if along <= 0.0 or off2 > r2:
        return math.inf
    return along - math.sqrt(r2 - off2)


@kernel
def cast_scan(s, x, y, yaw, pitch, speed, yaw_rate, axle_height, positions, velocities, radii, ranges):
    """Noise-free ranges [m] of one scan started at the state (x, y, yaw [rad], pitch [rad], forward speed
    [m/s], yaw rate [rad/s]) with the axle at `axle_height` [m] (the wheel radius), among discs at
    `positions` [m] moving at `velocities` [m/s] with `radii` [m]; REP 117's -inf / +inf outside the range."""
    beams = int(s[LD_BEAMS])
    sin_th = math.sin(pitch)
    cos_th = math.cos(pitch)
    height = s[LD_HEIGHT]
    z = axle_height + height * cos_th  # the scanner above the floor
    for i in range(beams):
        dt = i * s[LD_TIME_INCREMENT]
        sx, sy, heading = scanner_at(x, y, yaw, speed, yaw_rate, dt, height * sin_th)  # at this beam's instant
        bearing = s[LD_ANGLE_MIN] + i * s[LD_ANGLE_INCREMENT]
        ca = math.cos(bearing)
        sa = math.sin(bearing)
        # the beam in the yaw-aligned frame: forward ca * cos_th, left sa, down ca * sin_th
        fwd = ca * cos_th
        horizontal = math.sqrt(fwd * fwd + sa * sa)
        best = math.inf
        down = ca * sin_th
        if down > 0.0:
            best = z / down  # where the tipped plane meets the floor
        if horizontal > 0.0:
            c = math.cos(heading)
            sn = math.sin(heading)
            dx = (fwd * c - sa * sn) / horizontal
            dy = (fwd * sn + sa * c) / horizontal
            for o in range(radii.shape[0]):
                hit = disc_hit(sx, sy, dx, dy, positions[o, 0] + velocities[o, 0] * dt,
                               positions[o, 1] + velocities[o, 1] * dt, radii[o])
                t = hit / horizontal  # along the beam, which climbs or sinks as it goes
                if t < best:
                    best = t
        if best < s[LD_RANGE_MIN]:
            ranges[i] = -math.inf
        elif best > s[LD_RANGE_MAX]:
            ranges[i] = math.inf
        else:
            ranges[i] = best


@kernel
def scan_noise(s, generator, ranges):
    """The device's noise on a cast scan: a missed return (+inf) with probability `dropout`, else Gaussian
    range noise, clipped into [range_min, range_max] (a measured range stays a measurement)."""
    for i in range(ranges.shape[0]):
        if not math.isfinite(ranges[i]):
            continue
        if s[LD_DROPOUT] > 0.0 and uniform(generator) < s[LD_DROPOUT]:
            ranges[i] = math.inf
            continue
        if s[LD_NOISE] > 0.0:
            ranges[i] = min(max(ranges[i] + s[LD_NOISE] * normal(generator), s[LD_RANGE_MIN]), s[LD_RANGE_MAX])
