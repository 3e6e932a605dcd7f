"""The avoidability check on cases whose answer follows from the limits by hand."""

import pytest

from twbr_batch.avoidability import Limits, classify, collision_avoidable

LIMITS = Limits(v_max=0.6, acceleration=0.06, braking=0.12, yaw_rate=1.5, yaw_acceleration=1.0)


def test_a_static_obstacle_seen_beyond_the_stopping_distance_is_avoidable():
    # 0.6 m/s brakes to rest in 0.6^2 / (2 * 0.12) = 1.5 m: seen 2 m ahead of the footprint, it is avoidable.
    assert collision_avoidable((0.0, 0.0, 0.0, 0.6, 0.0), (3.0, 0.0, 0.0, 0.0), 0.7, 0.3, LIMITS)


def test_inside_the_stopping_distance_only_turning_avoids_and_only_in_time():
    # A small disc 0.8 m from the footprint at 0.6 m/s: braking alone needs 1.5 m (a robot that cannot turn
    # hits it), but turning aside while braking clears it...
    robot, disc = (0.0, 0.0, 0.0, 0.6, 0.0), (1.2, 0.0, 0.0, 0.0)
    assert collision_avoidable(robot, disc, 0.1, 0.3, LIMITS)
    no_turning = Limits(v_max=0.6, acceleration=0.06, braking=0.12, yaw_rate=1e-6, yaw_acceleration=1e-6)
    assert not collision_avoidable(robot, disc, 0.1, 0.3, no_turning)
    # ...but not a wall 20 m wide seen 0.1 m ahead: the robot covers that in 0.17 s, in which it turns by
    # at most 1.0 * 0.17^2 / 2 = 0.014 rad and slows by 0.02 m/s.
    assert not collision_avoidable((0.0, 0.0, 0.0, 0.6, 0.0), (10.4, 0.0, 0.0, 0.0), 10.0, 0.3, LIMITS)


def test_an_obstacle_faster_than_the_robot_can_ever_move_aside_is_unavoidable():
    # Stopped robot, an obstacle of radius 0.5 m at 2 m/s from 3 m away: it arrives in about 1.1 s, and in
    # 1.1 s the robot moves at most 0.06 * 1.1^2 / 2 = 0.04 m of the 0.8 m it needs.
    assert not collision_avoidable((0.0, 0.0, 0.0, 0.0, 0.0), (3.0, 0.0, -2.0, 0.0), 0.5, 0.3, LIMITS)


def test_the_same_obstacle_seen_earlier_is_avoidable():
    # From 30 m away it takes 15 s: time enough to drive 0.8 m aside.
    assert collision_avoidable((0.0, 0.0, 0.0, 0.0, 0.0), (30.0, 0.0, -2.0, 0.0), 0.5, 0.3, LIMITS)


def test_an_obstacle_that_misses_anyway_is_avoidable_and_touching_is_not():
    assert collision_avoidable((0.0, 0.0, 0.0, 0.0, 0.0), (5.0, 3.0, -1.0, 0.0), 0.5, 0.3, LIMITS)
    assert not collision_avoidable((0.0, 0.0, 0.0, 0.0, 0.0), (0.7, 0.0, 0.0, 0.0), 0.5, 0.3, LIMITS)


def test_the_limits_matter():
    # The head-on case of the suite: 0.4 m/s towards a robot at 0.3 m/s, seen 2 m from the footprint.
    robot = (0.0, 0.0, 0.0, 0.3, 0.0)
    obstacle = (2.9, 0.0, -0.4, 0.0)
    assert collision_avoidable(robot, obstacle, 0.6, 0.3, LIMITS)
    frozen = Limits(v_max=0.6, acceleration=1e-6, braking=1e-6, yaw_rate=1e-6, yaw_acceleration=1e-6)
    assert not collision_avoidable(robot, obstacle, 0.6, 0.3, frozen)


@pytest.mark.parametrize(("args", "outcome"), [
    ((True, False, None, False, False, False), "success"),
    ((True, True, True, False, False, False), "collision_avoidable"),
    ((False, True, False, False, False, True), "collision_unavoidable"),
    ((False, False, None, True, False, False), "fall"),
    ((False, False, None, False, True, False), "trapped"),
    ((False, False, None, False, False, True), "outrun"),
    ((False, False, None, False, False, False), "late"),
    ((False, False, None, False, False, False, 0.3), "trapped"),
])
def test_each_outcome_has_one_cause(args, outcome):
    assert classify(*args) == outcome
