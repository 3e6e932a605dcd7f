"""Discs from scans the simulator's LiDAR casts: people-sized discs found where they are, walls as chains,
the floor a leaning scan sweeps left out, no object cut at the scan's seam."""

from __future__ import annotations

import math

import numpy as np
import pytest

from twbr_common.params import defaults
from twbr_sim.lidar import LIDAR_SPECS, cast_scan
from twbr_sim.lidar import settings_vector as lidar_vector
from twbr_tracker.detection import DC_RADIUS, DC_WALL, DC_X, DC_Y, DETECTION_SPECS, N_DISC, detect, settings_vector

AXLE = 0.10
HEIGHT = defaults(LIDAR_SPECS)["lidar.height"]


STEP = 0.1 / 360  # [s] between beams: one turn per 10 Hz scan


def scan_of(discs, x=0.0, y=0.0, yaw=0.0, pitch=0.0, speed=0.0, yaw_rate=0.0) -> np.ndarray:
    s = lidar_vector(defaults(LIDAR_SPECS))
    positions = np.array([d[:2] for d in discs], dtype=float).reshape(-1, 2)
    radii = np.array([d[2] for d in discs], dtype=float)
    ranges = np.empty(360)
    cast_scan(s, x, y, yaw, pitch, speed, yaw_rate, AXLE, positions, np.zeros_like(positions), radii, ranges)
    return ranges


def detected(ranges, x=0.0, y=0.0, yaw=0.0, pitch=0.0, speed=0.0, yaw_rate=0.0, **detection) -> np.ndarray:
    out = np.empty((len(ranges), N_DISC))
    cfg = {**defaults(DETECTION_SPECS), **{f"detection.{k}": v for k, v in detection.items()}}
    n = detect(settings_vector(cfg), ranges, -math.pi, math.radians(1.0), STEP, x, y, yaw,
               speed, yaw_rate, pitch, AXLE, HEIGHT, out, np.empty((len(ranges), 2)))
    return out[:n]


@pytest.mark.parametrize(("cx", "cy", "radius"), [(3.0, 0.0, 0.3), (-2.0, 1.5, 0.25), (0.0, -4.0, 0.4),
                                                 (-3.0, 0.0, 0.3)])  # the last straddles the scan's seam
def test_a_person_sized_disc_is_found_where_it_is(cx, cy, radius):
    discs = detected(scan_of([(cx, cy, radius)]))
    assert len(discs) == 1
    assert math.hypot(discs[0, DC_X] - cx, discs[0, DC_Y] - cy) < 0.06
    assert discs[0, DC_RADIUS] == pytest.approx(radius, abs=0.08) and discs[0, DC_WALL] == 0.0


def test_two_people_side_by_side_are_two_and_from_a_moved_robot_the_same():
    people = [(3.0, 0.5, 0.3), (3.0, -0.5, 0.3)]
    here = detected(scan_of(people))
    assert len(here) == 2 and sorted(np.round(here[:, DC_Y], 1)) == [-0.5, 0.5]
    moved = detected(scan_of(people, x=1.0, y=-0.5, yaw=0.4), x=1.0, y=-0.5, yaw=0.4)
    assert len(moved) == 2
    for d in moved:
        assert min(math.hypot(d[DC_X] - p[0], d[DC_Y] - p[1]) for p in people) < 0.06


@pytest.mark.parametrize("distance", [2.5, 5.0, 8.0])
@pytest.mark.parametrize("gap", [0.0, 0.02, 0.06])
def test_people_touching_side_by_side_are_split_at_the_fold(distance, gap):
    """Two people (r 0.3 m) walking side by side, closer than the breakpoint rule's gap (0.12 m + 3 % of the
    range): one segment, one disc between them or a wall's chain, unless it is split where the two arcs meet
    (a beam passing between them, or the fold behind their fronts). With 1 cm range noise, from two poses."""
    noise = np.random.default_rng(int(100 * (distance + gap))).normal(0.0, 0.01, 360)
    half = 0.3 + gap / 2.0
    for x, y, yaw in ((0.0, 0.0, 0.0), (-1.0, 0.5, 0.3)):
        people = [(x + distance, y - half, 0.3), (x + distance, y + half, 0.3)]
        ranges = scan_of(people, x=x, y=y, yaw=yaw) + noise
        discs = detected(ranges, x=x, y=y, yaw=yaw)
        assert len(discs) == 2, discs
        for cx, cy, _r in people:
            assert min(math.hypot(d[DC_X] - cx, d[DC_Y] - cy) for d in discs) < 0.1
        whole = detected(ranges, x=x, y=y, yaw=yaw, split_depth=0.0)  # one disc, or a wall's chain
        assert len(whole) == 1 or np.all(whole[:, DC_WALL] == 1.0), whole


def test_a_wall_is_a_chain_of_discs_along_it():
    wall = [(x, 2.0, 0.1) for x in np.arange(-2.0, 2.01, 0.15)]
    discs = detected(scan_of(wall))
    assert len(discs) >= 8 and np.all(discs[:, DC_WALL] == 1.0)
    # The chain covers the wall's face (y = 1.9) along its length, standing at most 7 cm out in front of it
    # (centred on the wall, chain_depth 0: 28 cm): a passage beside a wall keeps its width.
    face = np.stack([np.linspace(-1.5, 1.5, 61), np.full(61, 1.9)], axis=1)
    inside = np.hypot(face[:, None, 0] - discs[None, :, DC_X], face[:, None, 1] - discs[None, :, DC_Y]) - discs[:, DC_RADIUS]
    assert inside.min(axis=1).max() < 0.02
    assert (discs[:, DC_Y] - discs[:, DC_RADIUS]).min() > 1.83


def test_the_floor_a_leaning_scan_sweeps_is_no_obstacle():
    ranges = scan_of([(6.0, 0.0, 0.3)], pitch=0.12)
    assert np.isfinite(ranges).sum() > 100  # the floor ahead returns on many beams
    discs = detected(ranges, pitch=0.12)
    assert len(discs) == 0 or all(math.hypot(d[DC_X] - 6.0, d[DC_Y]) < 0.1 for d in discs)
    assert len(detected(scan_of([(2.0, 0.0, 0.3)], pitch=0.05), pitch=0.05)) == 1  # nearer than the floor hit


def test_a_turning_robot_s_scan_is_deskewed():
    """Turning at 3 rad/s (and driving at 0.5 m/s), the robot turns 0.3 rad during one scan: the beam that
    sees a person at 5 m left is taken 0.075 s after the first. Placed at the beam's own pose the person is
    where they are; placed as if the robot had stood still at the scan's start, ~1 m off."""
    person = [(0.0, 5.0, 0.3)]
    ranges = scan_of(person, speed=0.5, yaw_rate=3.0)
    (disc,) = detected(ranges, speed=0.5, yaw_rate=3.0)
    assert math.hypot(disc[DC_X] - 0.0, disc[DC_Y] - 5.0) < 0.06
    (skewed,) = detected(ranges)
    assert math.hypot(skewed[DC_X] - 0.0, skewed[DC_Y] - 5.0) > 0.8


@pytest.mark.parametrize("distance", [2.5, 4.0, 6.0, 9.0])
@pytest.mark.parametrize("radius", [1.0, 1.5, 2.0])
def test_a_large_disc_is_one_disc_where_it_is_not_a_wall(distance, radius):
    """The paper's moving obstacles are discs of 1.5 and 2 m: seen whole they are an arc 2-3.5 m long, longer
    than a person, and were chained as a wall (static, never tracked). On a circle, they are one disc; with
    the scanner's range noise (1 cm) its centre and radius within 5 cm."""
    noise = np.random.default_rng(int(10 * distance + radius)).normal(0.0, 0.01, 360)
    for x, y, yaw in ((0.0, 0.0, 0.0), (1.0, -0.5, 0.4)):
        cx, cy = x + distance * math.cos(0.3), y + distance * math.sin(0.3)
        ranges = scan_of([(cx, cy, radius)], x=x, y=y, yaw=yaw) + noise
        (disc,) = detected(ranges, x=x, y=y, yaw=yaw)
        assert disc[DC_WALL] == 0.0
        assert math.hypot(disc[DC_X] - cx, disc[DC_Y] - cy) < 0.05 and disc[DC_RADIUS] == pytest.approx(radius, abs=0.05)


@pytest.mark.parametrize("layout", ["row", "corner", "trap"])
def test_walls_corners_and_traps_stay_chains_with_noise(layout):
    """Straight rows, an L-shaped corner and a trap's U of 0.35 m discs are walls: however their noise fits a
    circle, they are not taken for a large disc."""
    walls = {"row": [(x, 2.0, 0.1) for x in np.arange(-2.0, 2.01, 0.15)],
             "corner": [(3.0, y, 0.1) for y in np.arange(0.0, 2.0, 0.15)] + [(x, 2.0, 0.1) for x in np.arange(1.5, 3.0, 0.15)],
             "trap": ([(7.0, y, 0.35) for y in np.linspace(-2.35, 2.35, 10)]
                      + [(x, side * 2.35, 0.35) for x in np.arange(4.0, 6.6, 0.5) for side in (-1.0, 1.0)])}[layout]
    rng = np.random.default_rng(3)
    for x in (0.0, 2.0, 4.0):
        discs = detected(scan_of(walls, x=x) + rng.normal(0.0, 0.01, 360), x=x)
        long = discs[discs[:, DC_RADIUS] > 0.5]
        assert len(long) == 0 or np.all(long[:, DC_WALL] == 1.0), long
