"""The escape's navigation function: a way out of every trap that has one, and none through a gap too narrow."""

import math

import numpy as np
import pytest

from twbr_planner.navigation import navigation_direction

INFLATE = 0.35  # the robust method's: robot_radius 0.3 and FREE_MARGIN 0.05


def discs(*rows):
    """(positions, radii, moving) of static discs (x, y, r)."""
    array = np.array(rows, dtype=float).reshape(-1, 3)
    return array[:, :2].copy(), array[:, 2].copy(), np.zeros(len(array), dtype=np.bool_)


def clearance(x, y, positions, radii):
    return float(np.min(np.hypot(positions[:, 0] - x, positions[:, 1] - y) - radii)) if len(radii) else math.inf


def walk(x, y, target, positions, radii, moving, step=0.05, limit=60.0):
    """A point that moves `step` down the navigation function until it is within 0.3 m of the target: its path
    length, and the smallest clearance (to the discs' surfaces) on the way; (inf, ...) when it never arrives."""
    travelled = 0.0
    closest = clearance(x, y, positions, radii)
    while math.hypot(target[0] - x, target[1] - y) > 0.3:
        ux, uy, found = navigation_direction(x, y, target[0], target[1], positions, radii, moving, INFLATE)
        assert found
        x += step * ux
        y += step * uy
        travelled += step
        closest = min(closest, clearance(x, y, positions, radii))
        if travelled > limit:
            return math.inf, closest
    return travelled, closest


def test_with_nothing_in_the_way_it_points_at_the_target():
    positions, radii, moving = discs()
    ux, uy, found = navigation_direction(0.0, 0.0, 3.0, 4.0, positions, radii, moving, INFLATE)
    assert found and math.atan2(uy, ux) == pytest.approx(math.atan2(4.0, 3.0), abs=0.1)


# A U of overlapping discs 4 m wide and 3 m deep, open towards -x; the robot inside at its bottom, the target
# straight behind the bottom wall: every potential field without an escape stalls at the wall.
U_TRAP = discs(*[(7.0, -2.35 + 0.47 * k, 0.35) for k in range(11)],
               *[(4.0 + 0.5 * k, 2.35, 0.35) for k in range(6)],
               *[(4.0 + 0.5 * k, -2.35, 0.35) for k in range(6)])


def test_the_way_out_of_a_trap_leads_round_it_to_the_target_clear_of_every_disc():
    positions, radii, moving = U_TRAP
    travelled, closest = walk(6.0, 0.3, (10.0, 0.0), positions, radii, moving)
    # out of the mouth (at x = 4), round a 2.7 m half-height and back: 2 + ~3 + ~6 + ~3 + ~3 = about 17 m
    assert travelled < 22.0
    assert closest >= INFLATE - 0.1  # the footprint and margin, less the grid's resolution


def test_a_gap_narrower_than_the_footprint_is_gone_round_and_a_wide_one_taken():
    # A wall of touching discs across the way with one gap in it, in front of the target.
    def wall(gap):  # discs of 0.3 m, 0.5 m apart out to 4 m each side, `gap` between the middle two's surfaces
        edge = gap / 2 + 0.3
        ys = [s * (edge + 0.5 * k) for s in (-1, 1) for k in range(int((4.0 - edge) / 0.5) + 1)]
        return discs(*[(3.0, y, 0.3) for y in ys])

    narrow = wall(0.3)  # the robot is 0.6 m wide
    positions, radii, moving = narrow
    travelled, closest = walk(0.0, 0.0, (6.0, 0.0), positions, radii, moving)
    assert closest >= INFLATE - 0.1 and travelled > 10.0  # round the end of the wall, not through the gap
    wide = wall(1.0)  # through it
    positions, radii, moving = wide
    travelled, closest = walk(0.0, 0.0, (6.0, 0.0), positions, radii, moving)
    assert travelled < 6.5 and closest >= INFLATE - 0.1


def test_a_target_closed_in_has_no_way_and_moving_obstacles_are_not_in_the_map():
    ring = [(5.0 + 1.5 * math.cos(a), 1.5 * math.sin(a), 0.4) for a in np.linspace(0, 2 * math.pi, 16, endpoint=False)]
    positions, radii, moving = discs(*ring)
    assert navigation_direction(0.0, 0.0, 5.0, 0.0, positions, radii, moving, INFLATE) == (0.0, 0.0, False)
    ux, _uy, found = navigation_direction(0.0, 0.0, 5.0, 0.0, positions, radii, np.ones_like(moving), INFLATE)
    assert found and ux > 0.99  # the ring all moving: straight at the target


def test_a_robot_already_closer_than_the_footprint_margin_is_led_out():
    positions, radii, moving = discs((1.0, 0.0, 0.5))
    # 0.15 m from the surface (inside the 0.35 m band), the target beyond the disc
    ux, _uy, found = navigation_direction(0.35, 0.0, 4.0, 0.0, positions, radii, moving, INFLATE)
    assert found and ux < 0.8  # round the disc, not into it
    travelled, closest = walk(0.35, 0.0, (4.0, 0.0), positions, radii, moving)
    assert travelled < 6.0 and closest >= 0.14


def test_a_target_next_to_a_disc_is_reached():
    positions, radii, moving = discs((5.0, 0.0, 1.0))
    travelled, _ = walk(0.0, 0.0, (5.0, 1.2), positions, radii, moving)  # 0.2 m from the surface
    assert travelled < 8.0
