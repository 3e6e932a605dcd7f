"""The scan a 2D LiDAR on the leaning body returns: geometry, occlusion, the floor, REP 117, skew, noise."""

from __future__ import annotations

import math

import numpy as np
import pytest

from twbr_common.jit import kernel
from twbr_common.params import defaults
from twbr_sim.lidar import (
    BEAM_DOWN,
    BEAM_DT,
    BEAM_DX,
    BEAM_DY,
    BEAM_HORIZONTAL,
    BEAM_SX,
    BEAM_SY,
    LD_ANGLE_INCREMENT,
    LD_ANGLE_MIN,
    LD_BEAMS,
    LD_HEIGHT,
    LD_RANGE_MAX,
    LD_RANGE_MIN,
    LD_TIME_INCREMENT,
    LIDAR_SPECS,
    LIDAR_STREAM,
    N_BEAM,
    cast_scan,
    disc_hit,
    scan_geometry,
    scan_noise,
    scanner_at,
    settings_vector,
)
from twbr_sim.noise import new_generator

AXLE = 0.10  # [m] the wheel radius


def settings(**over) -> np.ndarray:
    return settings_vector({**defaults(LIDAR_SPECS), **over})


def scan(s, discs, x=0.0, y=0.0, yaw=0.0, pitch=0.0, speed=0.0, yaw_rate=0.0, velocities=None) -> np.ndarray:
    positions = np.array([[d[0], d[1]] for d in discs], dtype=float).reshape(-1, 2)
    radii = np.array([d[2] for d in discs], dtype=float)
    v = np.zeros_like(positions) if velocities is None else np.asarray(velocities, dtype=float)
    ranges = np.empty(int(s[2]))
    cast_scan(s, x, y, yaw, pitch, speed, yaw_rate, AXLE, positions, v, radii, ranges)
    return ranges


def beam(bearing_deg: float) -> int:
    """The index of the beam at this bearing with the defaults (-180 degrees first, 1 degree steps)."""
    return round(bearing_deg + 180.0) % 360


def test_a_disc_ahead_is_its_surface_and_the_rest_is_no_return():
    ranges = scan(settings(), [(3.0, 0.0, 0.5)])
    assert ranges[beam(0)] == pytest.approx(2.5, abs=1e-12)
    assert ranges[beam(5)] == pytest.approx(3.0 * math.cos(math.radians(5)) - math.sqrt(
        0.25 - (3.0 * math.sin(math.radians(5))) ** 2), abs=1e-9)
    assert math.isinf(ranges[beam(90)]) and ranges[beam(90)] > 0  # REP 117: +inf, nothing within range_max
    assert np.isfinite(ranges).sum() == 19  # +-9 degrees see a 0.5 m disc at 3 m (asin(1/6) = 9.6 degrees)


def test_the_nearer_disc_hides_the_farther_and_a_turned_robot_sees_it_turned():
    ranges = scan(settings(), [(5.0, 0.0, 0.5), (2.0, 0.0, 0.3)])
    assert ranges[beam(0)] == pytest.approx(1.7, abs=1e-12)
    turned = scan(settings(), [(0.0, 2.0, 0.3)], yaw=math.pi / 2)
    assert turned[beam(0)] == pytest.approx(1.7, abs=1e-12)


def test_rep_117_too_close_and_too_far():
    ranges = scan(settings(), [(0.4, 0.0, 0.3), (0.0, 13.0, 0.5)])
    assert ranges[beam(0)] == -math.inf  # 0.1 m < range_min 0.15 m
    assert ranges[beam(90)] == math.inf  # 12.5 m > range_max 12 m


def test_a_leaning_body_sweeps_the_floor_ahead_and_looks_up_behind():
    pitch = 0.1  # leaning forward
    ranges = scan(settings(), [], pitch=pitch)
    z = AXLE + 0.25 * math.cos(pitch)
    assert ranges[beam(0)] == pytest.approx(z / math.sin(pitch), rel=1e-12)  # 3.5 m ahead on the floor
    assert ranges[beam(60)] == pytest.approx(z / (math.cos(math.radians(60)) * math.sin(pitch)), rel=1e-12)
    assert ranges[beam(180)] == math.inf and ranges[beam(90)] == math.inf  # behind: up; sideways: level
    upright = scan(settings(), [], pitch=0.0)
    assert np.all(upright == math.inf)


def test_the_beams_of_a_turn_see_the_world_as_it_moved_during_it():
    """The last beam is taken ~0.1 s after the first: a robot at 1 m/s is ~0.1 m further on by then."""
    s = settings()
    disc = [(-3.0, 0.0, 0.5)]  # behind: the first beam (-180 degrees) and the last (179 degrees) look at it
    ranges = scan(s, disc, speed=1.0)
    first, last = ranges[beam(-180)], ranges[beam(179)]
    assert first == pytest.approx(2.5, abs=1e-12)
    moved = 359 * s[6]  # time_increment
    assert moved == pytest.approx(0.1 * 359 / 360)
    ahead = 3.0 + moved  # farther behind the robot now
    bearing = math.radians(179)
    expected = ahead * abs(math.cos(bearing)) - math.sqrt(0.25 - (ahead * math.sin(bearing)) ** 2)
    assert last == pytest.approx(expected, abs=1e-9)
    still = scan(s, disc, speed=0.0)
    assert still[beam(179)] < last - 0.09


def test_noise_and_dropouts_are_the_device_s_and_the_seed_s():
    s = settings(**{"lidar.range_noise_std": 0.02, "lidar.dropout": 0.05})
    clean = scan(s, [(0.0, 0.0, 4.0)])  # inside a 4 m ring: every beam returns (from inside: 0 -> -inf)
    wall = scan(s, [(6.0, 0.0, 1.0), (-6.0, 0.0, 1.0), (0.0, 6.0, 1.0), (0.0, -6.0, 1.0)])
    assert np.all(clean == -math.inf)
    samples, dropped = [], 0
    g = new_generator(1, LIDAR_STREAM)
    for _ in range(200):
        noisy = wall.copy()
        scan_noise(s, g, noisy)
        hit = np.isfinite(wall)
        dropped += int(np.sum(hit & np.isinf(noisy)))
        kept = hit & np.isfinite(noisy)
        samples += list(noisy[kept] - wall[kept])
    n_hits = 200 * int(np.isfinite(wall).sum())
    assert dropped / n_hits == pytest.approx(0.05, abs=0.01)
    assert np.std(samples) == pytest.approx(0.02, rel=0.05) and abs(np.mean(samples)) < 0.002
    a, b = wall.copy(), wall.copy()
    scan_noise(s, new_generator(7, LIDAR_STREAM), a)
    scan_noise(s, new_generator(7, LIDAR_STREAM), b)
    assert np.array_equal(a, b)


@kernel
def cast_scan_every_beam(s, x, y, yaw, pitch, speed, yaw_rate, axle_height, positions, velocities, radii, ranges):
    """The cast as first written: every beam against the floor and every disc (cast_scan's oracle)."""
    beams = int(s[LD_BEAMS])
    sin_th = math.sin(pitch)
    cos_th = math.cos(pitch)
    z = axle_height + s[LD_HEIGHT] * cos_th
    geometry = np.empty((beams, N_BEAM))
    scan_geometry(s[LD_ANGLE_MIN], s[LD_ANGLE_INCREMENT], s[LD_TIME_INCREMENT], x, y, yaw, speed, yaw_rate, sin_th,
                  cos_th, s[LD_HEIGHT] * sin_th, np.ones(beams, dtype=np.bool_), geometry)
    for i in range(beams):
        best = math.inf
        if geometry[i, BEAM_DOWN] > 0.0:
            best = z / geometry[i, BEAM_DOWN]
        horizontal = geometry[i, BEAM_HORIZONTAL]
        if horizontal > 0.0:
            dt = geometry[i, BEAM_DT]
            for o in range(radii.shape[0]):
                t = disc_hit(geometry[i, BEAM_SX], geometry[i, BEAM_SY], geometry[i, BEAM_DX], geometry[i, BEAM_DY],
                             positions[o, 0] + velocities[o, 0] * dt, positions[o, 1] + velocities[o, 1] * dt,
                             radii[o]) / horizontal
                if t < best:
                    best = t
        ranges[i] = -math.inf if best < s[LD_RANGE_MIN] else (math.inf if best > s[LD_RANGE_MAX] else best)


@pytest.mark.parametrize("device", [{}, {"lidar.beams": 720, "lidar.angle_increment": math.radians(0.5)},
                                    {"lidar.beams": 100, "lidar.angle_increment": math.radians(3.6), "lidar.rate": 40.0,
                                     "lidar.angle_min": 0.3},
                                    {"lidar.beams": 1000, "lidar.angle_increment": math.radians(1.0), "lidar.rate": 2.0},
                                    {"lidar.beams": 90, "lidar.angle_min": -math.pi / 4, "lidar.range_max": 4.0}])
def test_casting_each_disc_on_its_beams_only_returns_every_beams_range_bit_for_bit(device):
    """The cast skips the beams a disc cannot meet: on random states, crowds, leans, turns and devices
    (several turns per scan, a sector, a short range) it returns what casting every beam returns."""
    s = settings(**device)
    rng = np.random.default_rng(36)
    for trial in range(150):
        n = int(rng.integers(0, 40))
        positions = rng.uniform(-14.0, 14.0, (n, 2))
        velocities = rng.uniform(-3.0, 3.0, (n, 2)) * (trial % 3 != 0)
        radii = rng.uniform(0.05, 2.5, n)
        x, y = rng.uniform(-3.0, 3.0, 2)
        yaw = rng.uniform(-60.0, 60.0)
        pitch = rng.choice([0.0, rng.uniform(-0.05, 0.05), rng.uniform(-0.6, 0.6), rng.uniform(-3.1, 3.1)])
        speed = rng.uniform(-2.5, 2.5)
        yaw_rate = rng.choice([0.0, rng.uniform(-6.0, 6.0), 1e-13 * rng.uniform(-1.0, 1.0), rng.uniform(-400.0, 400.0)])
        args = (s, x, y, yaw, pitch, speed, yaw_rate, AXLE, positions, velocities, radii)
        fast = np.empty(int(s[LD_BEAMS]))
        every = np.empty(int(s[LD_BEAMS]))
        cast_scan(*args, fast)
        cast_scan_every_beam(*args, every)
        assert np.array_equal(fast, every), (trial, np.flatnonzero(fast != every))


@pytest.mark.parametrize("yaw_rate", [0.0, 1e-13, -2.5, 6.0, 400.0])
def test_the_scan_s_geometry_walked_beam_by_beam_is_the_unicycle_s_at_every_beam(yaw_rate):
    """scan_geometry steps the heading, the bearing and the axle by rotations instead of computing each beam's
    sines: over 1000 beams (nearly three turns) it stays within 1e-12 m and 1e-12 of scanner_at's scanner and
    each beam's direction computed from its own angles."""
    s = settings(**{"lidar.beams": 1000, "lidar.rate": 2.0})
    x, y, yaw, speed, pitch = 3.0, -7.0, 41.3, -1.7, 0.3
    lean = s[LD_HEIGHT] * math.sin(pitch)
    geometry = np.full((1000, N_BEAM), math.nan)
    needed = np.arange(1000) % 7 != 3  # rows only where needed; the walk goes on through the others
    scan_geometry(s[LD_ANGLE_MIN], s[LD_ANGLE_INCREMENT], s[LD_TIME_INCREMENT], x, y, yaw, speed, yaw_rate,
                  math.sin(pitch), math.cos(pitch), lean, needed, geometry)
    assert np.all(np.isnan(geometry[~needed]))
    for i in np.flatnonzero(needed):
        dt = i * s[LD_TIME_INCREMENT]
        sx, sy, heading = scanner_at(x, y, yaw, speed, yaw_rate, dt, lean)
        bearing = s[LD_ANGLE_MIN] + i * s[LD_ANGLE_INCREMENT]
        fwd, side = math.cos(bearing) * math.cos(pitch), math.sin(bearing)
        horizontal = math.hypot(fwd, side)
        direction = ((fwd * math.cos(heading) - side * math.sin(heading)) / horizontal,
                     (fwd * math.sin(heading) + side * math.cos(heading)) / horizontal)
        row = geometry[i]
        assert abs(row[BEAM_SX] - sx) < 1e-12 and abs(row[BEAM_SY] - sy) < 1e-12, i
        assert abs(row[BEAM_DX] - direction[0]) < 1e-12 and abs(row[BEAM_DY] - direction[1]) < 1e-12, i
        assert row[BEAM_HORIZONTAL] == pytest.approx(horizontal, abs=1e-12)
        assert row[BEAM_DOWN] == pytest.approx(math.cos(bearing) * math.sin(pitch), abs=1e-12)
        assert row[BEAM_DT] == dt
