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


# A beam's geometry in one scan (scan_geometry): the scanner at its instant, its direction, its shares.
BEAM_LAYOUT = Layout(("sx", "sy", "dx", "dy", "horizontal", "down", "dt"))
BEAM_SX = BEAM_LAYOUT["sx"]
BEAM_SY = BEAM_LAYOUT["sy"]
BEAM_DX = BEAM_LAYOUT["dx"]
BEAM_DY = BEAM_LAYOUT["dy"]
BEAM_HORIZONTAL = BEAM_LAYOUT["horizontal"]
BEAM_DOWN = BEAM_LAYOUT["down"]
BEAM_DT = BEAM_LAYOUT["dt"]
N_BEAM = len(BEAM_LAYOUT)
BEAM_MARGIN = 1e-9  # [rad] added to every angular window, beyond its beam of margin each side


@inline_kernel
def scanner_at(x, y, yaw, speed, yaw_rate, dt, lean):
    """The scanner dt [s] into a scan begun at the pose (x, y, yaw) [m, rad], the robot driving at speed
    [m/s] and yaw_rate [rad/s] (a unicycle over one turn): its position [m], `lean` [m] ahead of the axle
    (height x sin pitch), and the heading [rad]. The one rule of the scan's motion: scan_geometry walks it
    beam by beam for the cast and the tracker's deskewing."""
    heading = yaw + yaw_rate * dt
    if yaw_rate != 0.0 and dt > 0.0:  # the arc's chord, along the mean heading: no cancellation at slow turns
        chord = 2.0 * speed / yaw_rate * math.sin(0.5 * yaw_rate * dt)
        px = x + chord * math.cos(yaw + 0.5 * yaw_rate * dt)
        py = y + chord * math.sin(yaw + 0.5 * yaw_rate * dt)
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
def scan_geometry(angle_min, angle_increment, time_increment, x, y, yaw, speed, yaw_rate, sin_th, cos_th, lean,
                  needed, geometry):
    """The geometry of the beams i of a scan where needed[i], the scan begun at (x, y, yaw) [m, rad] moving at
    (speed, yaw_rate), pitched by (sin_th, cos_th), the scanner `lean` [m] ahead of the axle (height x sin
    pitch): into geometry[i] (BEAM_*, one row per beam; the other rows left as they are) the scanner at beam
    i's instant [m], its horizontal unit direction, its horizontal share (1 level, less tipped), the share
    pointing down, and the instant [s after the first].

    scanner_at's unicycle, walked beam by beam: the heading and the bearing turn by a fixed rotation per beam
    and the axle moves by the fixed chord of one beam's arc, so a scan costs no trigonometry per beam (the
    sines and cosines were most of the cast's and the tracker's time); it agrees with scanner_at to 1e-12 m
    and rad over thousands of beams (test_lidar)."""
    last = -1  # the walk ends at the last beam needed (none: a scan with nothing to cast or place)
    for i in range(geometry.shape[0]):
        if needed[i]:
            last = i
    turn = yaw_rate * time_increment  # the heading's step from beam to beam
    # the axle's step: the chord of one beam's arc, along the heading half a step on (speed x dt when straight)
    chord = 2.0 * speed / yaw_rate * math.sin(0.5 * turn) if turn != 0.0 else speed * time_increment
    turn_c = math.cos(turn)
    turn_s = math.sin(turn)
    beam_c = math.cos(angle_increment)
    beam_s = math.sin(angle_increment)
    hc = math.cos(yaw)  # the heading at beam i
    hs = math.sin(yaw)
    mc = math.cos(yaw + 0.5 * turn)  # the chord's direction after beam i
    ms = math.sin(yaw + 0.5 * turn)
    ca = math.cos(angle_min)  # the bearing of beam i in the scanner's frame
    sa = math.sin(angle_min)
    px = x
    py = y
    for i in range(last + 1):
        if needed[i]:
            # the beam in the yaw-aligned frame: forward ca * cos_th, left sa, down ca * sin_th
            fwd = ca * cos_th
            horizontal = math.sqrt(fwd * fwd + sa * sa)
            geometry[i, BEAM_SX] = px + lean * hc
            geometry[i, BEAM_SY] = py + lean * hs
            geometry[i, BEAM_HORIZONTAL] = horizontal
            geometry[i, BEAM_DOWN] = ca * sin_th
            geometry[i, BEAM_DT] = i * time_increment
            unit = 1.0 / horizontal if horizontal > 0.0 else 0.0  # straight down or up: no horizontal direction
            geometry[i, BEAM_DX] = (fwd * hc - sa * hs) * unit
            geometry[i, BEAM_DY] = (fwd * hs + sa * hc) * unit
        px += chord * mc
        py += chord * ms
        hc, hs = hc * turn_c - hs * turn_s, hs * turn_c + hc * turn_s
        mc, ms = mc * turn_c - ms * turn_s, ms * turn_c + mc * turn_s
        ca, sa = ca * beam_c - sa * beam_s, sa * beam_c + ca * beam_s


@kernel
def beam_window(centre, half, base, step, beams, windows):
    """The beams i whose angle base + i * step [rad] can lie within `half` of `centre` (mod 2 pi), one beam
    of margin each side: into windows[k] as (first, last) index pairs; returns how many pairs."""
    turn = 2.0 * math.pi
    last = (beams - 1) * step
    if half >= math.pi or step <= 0.0 or last + step > (windows.shape[0] - 2) * turn:  # every beam
        windows[0, 0] = 0
        windows[0, 1] = beams - 1
        return 1
    start = (centre - half - base) % turn - turn  # the window's first turn that can reach beam 0
    count = 0
    while start <= last + step and count < windows.shape[0]:
        first = max(0, math.ceil(start / step) - 1)
        end = min(beams - 1, math.floor((start + 2.0 * half) / step) + 1)
        if first <= end:
            windows[count, 0] = first
            windows[count, 1] = end
            count += 1
        start += turn
    return count


@kernel
def cast_scan(s, x, y, yaw, pitch, speed, yaw_rate, axle_height, positions, velocities, radii, ranges):
    """Noise-free ranges [m] of one scan started at the state (x, y, yaw [rad], pitch [rad], forward speed
    [m/s], yaw rate [rad/s]) with the axle at `axle_height` [m] (the wheel radius), among discs at
    `positions` [m] moving at `velocities` [m/s] with `radii` [m]; REP 117's -inf / +inf outside the range.

    Each disc is cast only on the beams that can meet it: those pointing within asin((r + e) / d) of where
    it was at the first beam, e bounding how far the scanner and the disc move in one turn and the pitch's
    bend of the beams' bearings (cast_scan_every_beam: the same ranges, bit for bit, in the tests); the
    floor only on the beams tipped down enough to meet it within range_max. Any other beam is +inf."""
    beams = int(s[LD_BEAMS])
    sin_th = math.sin(pitch)
    cos_th = math.cos(pitch)
    z = axle_height + s[LD_HEIGHT] * cos_th  # the scanner above the floor
    range_max = s[LD_RANGE_MAX]
    n_discs = radii.shape[0]
    # first the beams each disc (rows 0..n_discs-1) and the floor (row n_discs) can meet, then those beams'
    # geometry only, then the casts
    windows = np.empty((n_discs + 1, 4, 2), dtype=np.int64)
    counts = np.zeros(n_discs + 1, dtype=np.int64)
    step = s[LD_ANGLE_INCREMENT] + yaw_rate * s[LD_TIME_INCREMENT]  # beam to beam, turning with the body
    # the floor: down = cos(bearing) sin_th >= z / range_max (every beam when the scanner is not above it)
    if sin_th != 0.0:
        q = z / (range_max * abs(sin_th)) if z > 0.0 else -1.0
        if q <= 1.0:
            half = math.acos(max(q, -1.0)) + BEAM_MARGIN
            counts[n_discs] = beam_window(0.0 if sin_th > 0.0 else math.pi, half, s[LD_ANGLE_MIN],
                                          s[LD_ANGLE_INCREMENT], beams, windows[n_discs])
    turn_time = (beams - 1) * s[LD_TIME_INCREMENT]
    # how far the scanner strays from (x, y) in one turn: the drive, the lean, and the rounding of the walk
    # along the beams (scan_geometry adds one chord per beam)
    drift = abs(speed) * turn_time + abs(s[LD_HEIGHT] * sin_th)
    drift += 1e-15 * beams * (1.0 + abs(x) + abs(y) + drift)
    # the pitch bends a beam's horizontal bearing off its nominal one by at most atan((1 - c) / (2 sqrt c))
    bend = (1.0 - cos_th) / math.sqrt(cos_th) + BEAM_MARGIN if cos_th > 0.0 else math.pi
    for o in range(n_discs):
        fx = positions[o, 0] - x
        fy = positions[o, 1] - y
        distance = math.hypot(fx, fy)
        reach = (radii[o] + drift + math.hypot(velocities[o, 0], velocities[o, 1]) * turn_time) * (1.0 + 1e-9) + 1e-9
        if distance - reach > range_max:
            continue  # every beam would meet it beyond range_max: +inf whatever else it meets
        half = math.pi if distance <= reach else math.asin(reach / distance) + bend
        counts[o] = beam_window(math.atan2(fy, fx), half, yaw + s[LD_ANGLE_MIN], step, beams, windows[o])
    needed = np.zeros(beams, dtype=np.bool_)
    for o in range(n_discs + 1):
        for k in range(counts[o]):
            needed[windows[o, k, 0]:windows[o, k, 1] + 1] = True
    geometry = np.empty((beams, N_BEAM))
    scan_geometry(s[LD_ANGLE_MIN], s[LD_ANGLE_INCREMENT], s[LD_TIME_INCREMENT], x, y, yaw, speed, yaw_rate, sin_th,
                  cos_th, s[LD_HEIGHT] * sin_th, needed, geometry)
    for i in range(beams):
        ranges[i] = math.inf
    for k in range(counts[n_discs]):
        for i in range(windows[n_discs, k, 0], windows[n_discs, k, 1] + 1):
            down = geometry[i, BEAM_DOWN]
            if down > 0.0:
                ranges[i] = min(ranges[i], z / down)  # where the tipped plane meets the floor
    for o in range(n_discs):
        for k in range(counts[o]):
            for i in range(windows[o, k, 0], windows[o, k, 1] + 1):
                horizontal = geometry[i, BEAM_HORIZONTAL]
                if horizontal > 0.0:
                    dt = geometry[i, BEAM_DT]
                    hit = disc_hit(geometry[i, BEAM_SX], geometry[i, BEAM_SY], geometry[i, BEAM_DX],
                                   geometry[i, BEAM_DY], positions[o, 0] + velocities[o, 0] * dt,
                                   positions[o, 1] + velocities[o, 1] * dt, radii[o])
                    t = hit / horizontal  # along the beam, which climbs or sinks as it goes
                    if t < ranges[i]:
                        ranges[i] = t
    for i in range(beams):
        if ranges[i] < s[LD_RANGE_MIN]:
            ranges[i] = -math.inf
        elif ranges[i] > range_max:
            ranges[i] = math.inf


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
