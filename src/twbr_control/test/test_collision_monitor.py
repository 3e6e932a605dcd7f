"""The collision monitor: the speed any command may drive at, given the obstacles in the way."""

import math

import numpy as np
import pytest

from twbr_control.collision_monitor import CollisionMonitor, allowed_speed
from twbr_control.controller_params import resolve


def _allowed(v, x=0.0, y=0.0, yaw=0.0, obstacles=((3.0, 0.0, 0.3),), velocities=None, age=0.0, footprint=0.3,
             margin=0.05, decel=0.25, react=0.3):
    positions = np.array([o[:2] for o in obstacles], dtype=float).reshape(-1, 2)
    radii = np.array([o[2] for o in obstacles], dtype=float)
    vel = np.zeros_like(positions) if velocities is None else np.array(velocities, dtype=float)
    return allowed_speed(v, x, y, yaw, positions, vel, radii, age, footprint, margin, decel, react)


def test_the_speed_allowed_stops_the_robot_at_the_margin():
    free = 3.0 - 0.6 - 0.05  # centre distance less both radii, less the stop margin
    v = _allowed(5.0)
    assert v * 0.3 + v * v / (2 * 0.25) == pytest.approx(free)
    assert _allowed(0.2) == 0.2  # slower than allowed: unchanged, to the bit
    assert _allowed(1.0, x=2.35) == 0.0 and _allowed(1.0, x=2.5) == 0.0  # in the stop zone, and in contact


def test_only_what_lies_in_the_way_counts():
    assert _allowed(1.0, yaw=math.pi) == 1.0  # facing away: the obstacle is behind
    assert -1.0 < _allowed(-1.0, x=1.0, yaw=math.pi) < 0.0  # backing into it
    assert _allowed(2.0, y=0.61) == 2.0 and _allowed(2.0, y=0.59) < 2.0  # beside the way, or grazing it
    assert _allowed(0.0) == 0.0  # turning in place is never limited (the footprint is a disc)


def test_obstacles_are_moved_to_the_states_instant():
    # An obstacle crossing into the way: listed 1.2 m to the side 1 s ago, moving 1.2 m/s towards it.
    assert _allowed(1.0, obstacles=((2.0, 1.2, 0.3),), velocities=((0.0, -1.2),), age=0.0) == 1.0
    assert _allowed(1.0, obstacles=((2.0, 1.2, 0.3),), velocities=((0.0, -1.2),), age=1.0) < 1.0


def test_the_node_monitor_counts_and_forgets_stale_lists():
    m = CollisionMonitor(resolve())
    assert m.limit(0.0, 1.0, 0.0, 0.0, 0.0) == (1.0, False)  # no list yet: commands pass, not counted
    m.obstacles(0.0, np.array([[1, 3.0, 0.0, 0.0, 0.0, 0.3]]))
    v, limited = m.limit(0.5, 1.0, 2.0, 0.0, 0.0)
    assert limited and 0.0 < v < 1.0 and m.interventions == 1
    assert m.limit(1.6, 1.0, 2.0, 0.0, 0.0) == (1.0, False)  # older than obstacle_timeout (1 s)
    off = CollisionMonitor(resolve({"collision_monitor.enabled": False}))
    off.obstacles(0.0, np.array([[1, 3.0, 0.0, 0.0, 0.0, 0.3]]))
    assert off.limit(0.0, 1.0, 2.0, 0.0, 0.0) == (1.0, False)


def test_a_list_applies_from_the_state_after_its_stamp_whenever_it_arrived():
    """The state at t limited on the list of before t, whether the list of t came before it or after it:
    the graph's order of arrival never changes the command (a race the batch engine cannot copy)."""
    old = np.array([[1, 3.0, 0.0, 0.0, 0.0, 0.3]])  # ahead, in the way
    new = np.array([[1, 3.0, 5.0, 0.0, 0.0, 0.3]])  # gone aside
    early, late = CollisionMonitor(resolve()), CollisionMonitor(resolve())
    for m in (early, late):
        m.obstacles(0.1, old)
    early.obstacles(0.2, new)  # the list of 0.2 reached this one before the state of 0.2
    at_02 = [m.limit(0.2, 1.0, 2.0, 0.0, 0.0) for m in (early, late)]
    late.obstacles(0.2, new)  # and this one after it
    assert at_02[0] == at_02[1] and at_02[0][1]  # both limited, on the list of 0.1
    assert early.limit(0.205, 1.0, 2.0, 0.0, 0.0) == late.limit(0.205, 1.0, 2.0, 0.0, 0.0) == (1.0, False)
