"""The obstacles' motion kinds (twbr_sim.agents), through the World that the nodes and headless runs use."""

import math

import numpy as np
import pytest

from twbr_common.params import ConfigError
from twbr_sim import agents
from twbr_sim.scenario import parse_scenario
from twbr_sim.world import World


def world_of(*obstacles, seed=1, duration=60.0):
    raw = {"duration": duration, "robot": {"x": -20.0, "y": -20.0}, "target": {"position": [30.0, 30.0]},
           "obstacles": list(obstacles)}
    return World(parse_scenario(raw), 0.3, seed)


def path_of(world, times, robot=None):
    out = []
    for t in times:
        world.advance_to(t, robot(t) if robot else None)
        out.append(world.obstacle_positions().copy())
    return np.array(out)


def test_a_straight_obstacle_is_exactly_on_its_line_whenever_it_is_sampled():
    w = world_of({"position": [1.0, 2.0], "radius": 0.3, "speed": 0.5, "heading": "pi/2"})
    for t in (0.0, 0.013, 7.77, 59.0):
        w.advance_to(t)
        assert w.obstacle_positions()[0] == pytest.approx([1.0, 2.0 + 0.5 * t], abs=1e-12)
        assert w.obstacles()[0].vy == pytest.approx(0.5)


def test_a_route_is_walked_at_its_speed_with_its_pauses_and_loops():
    w = world_of({"position": [0.0, 0.0], "radius": 0.3, "motion": "waypoints", "speed": 0.5,
                  "waypoints": [[2.0, 0.0], [0.0, 0.0]], "pause": 1.0})
    times = np.arange(0.0, 20.0, 0.05)
    p = path_of(w, times)
    # 4 s out (2 m at 0.5 m/s), 1 s standing, 4 s back, 1 s standing: a 10 s cycle
    at = {round(t, 2): x for t, x in zip(times, p[:, 0, 0], strict=True)}
    assert at[2.0] == pytest.approx(1.0, abs=0.03)
    assert at[4.5] == pytest.approx(2.0, abs=0.03)  # standing at the far end
    assert at[7.0] == pytest.approx(1.0, abs=0.06)
    assert at[12.0] == pytest.approx(at[2.0], abs=0.06)  # and again
    assert np.abs(np.diff(p[:, 0, 0])).max() <= 0.5 * 0.05 + 1e-9  # never faster than its speed


def test_a_route_that_does_not_loop_ends_at_its_last_waypoint():
    w = world_of({"position": [0.0, 0.0], "radius": 0.3, "motion": "waypoints", "speed": 1.0,
                  "waypoints": [[1.0, 0.0], [1.0, 3.0]], "loop": False})
    w.advance_to(30.0)
    assert w.obstacle_positions()[0] == pytest.approx([1.0, 3.0], abs=1e-9)
    assert (w.obstacles()[0].vx, w.obstacles()[0].vy) == (0.0, 0.0)


def test_a_wanderer_turns_stops_and_stays_within_its_range_and_its_seed_fixes_its_path():
    spec = {"position": [0.0, 0.0], "radius": 0.3, "motion": "wander", "speed": 0.5, "max_yaw_rate": 1.0,
            "turn_interval": 1.0, "speed_change": 0.4, "stop_probability": 0.2, "stop_time": 2.0, "roam_radius": 3.0}
    times = np.arange(0.0, 300.0, 0.05)
    p = path_of(world_of(spec, seed=3, duration=300.0), times)[:, 0]
    speeds = np.hypot(*np.diff(p, axis=0).T) / 0.05
    assert speeds.max() <= 0.5 * 1.4 + 1e-9
    moving = speeds > 1e-9
    assert 0.6 < moving.mean() < 0.9  # 20 % of draws stop it for 2 s of every draw's 1 s: ~ 30 % still
    assert np.hypot(*p.T).max() < 3.0 + 0.7 * 3.2  # it turns home at 1 rad/s: a half circle beyond its range
    turns = np.abs(np.diff(np.unwrap(np.arctan2(*np.diff(p, axis=0)[moving[:]].T[::-1]))))
    assert turns.max() > 0.02  # it does turn
    same = path_of(world_of(spec, seed=3, duration=300.0), times)[:, 0]
    other = path_of(world_of(spec, seed=4, duration=300.0), times)[:, 0]
    assert np.array_equal(p, same)
    assert np.abs(p - other).max() > 1.0


def test_the_draws_are_uniform_and_independent_of_channel_and_obstacle():
    u = np.array([[agents.uniform_draw(7, o, k, c) for k in range(2000)] for o, c in ((1, 0), (1, 1), (2, 0))])
    assert ((u >= 0.0) & (u < 1.0)).all()
    assert np.abs(u.mean(axis=1) - 0.5).max() < 0.03
    assert np.abs(np.corrcoef(u)[np.triu_indices(3, 1)]).max() < 0.1


def head_on_pair(react):
    extra = {"react": "social"} if react else {}
    return world_of(
        {"id": 1, "position": [0.0, 0.0], "radius": 0.3, "motion": "waypoints", "speed": 0.6,
         "waypoints": [[10.0, 0.0]], "loop": False, **extra},
        {"id": 2, "position": [10.0, 0.05], "radius": 0.3, "motion": "waypoints", "speed": 0.6,
         "waypoints": [[0.0, 0.05]], "loop": False, **extra})


@pytest.mark.parametrize("react", [False, True])
def test_people_who_react_pass_each_other_and_those_who_do_not_collide(react):
    p = path_of(head_on_pair(react), np.arange(0.0, 25.0, 0.05))
    gap = np.hypot(*(p[:, 0] - p[:, 1]).T) - 0.6
    if react:
        assert gap.min() > 0.0  # they step aside, as people do
        assert p[-1, 0] == pytest.approx([10.0, 0.0], abs=0.3)  # and still get where they go
    else:
        assert gap.min() < -0.5


@pytest.mark.parametrize("attention", [0.0, 1.0])
def test_a_person_avoids_the_robot_as_much_as_it_pays_attention(attention):
    w = world_of({"position": [0.0, 0.0], "radius": 0.3, "motion": "waypoints", "speed": 0.6,
                  "waypoints": [[10.0, 0.0]], "loop": False, "react": "social", "attention": attention})
    p = path_of(w, np.arange(0.0, 25.0, 0.05), robot=lambda t: (5.0, 0.1))  # a robot standing in its way
    gap = np.hypot(p[:, 0, 0] - 5.0, p[:, 0, 1] - 0.1) - 0.6
    if attention:
        assert gap.min() > 0.0
    else:
        assert gap.min() < -0.4  # it walks into the robot


def test_a_person_who_has_not_seen_the_robot_walks_on():
    w = world_of({"position": [0.0, 0.0], "radius": 0.3, "motion": "waypoints", "speed": 0.6,
                  "waypoints": [[10.0, 0.0]], "loop": False, "react": "social"})
    p = path_of(w, np.arange(0.0, 25.0, 0.05))  # never told where the robot is
    assert np.abs(p[:, 0, 1]).max() < 1e-9


@pytest.mark.parametrize(("field", "value", "words"), [
    ("pause", 1.0, "only for motion: waypoints"),
    ("attention", 0.5, "only for react: social"),
    ("waypoints", [[1.0, 1.0]], "only it takes one"),
    ("motion", "teleport", "must be one of .straight., .waypoints., .wander."),
])
def test_a_field_of_another_motion_kind_is_refused_by_name(field, value, words):
    with pytest.raises(ConfigError, match=words):
        parse_scenario({"obstacles": [{"position": [5.0, 5.0], "radius": 0.3, "speed": 0.5, field: value}]})


def test_a_route_needs_its_waypoints_and_a_speed():
    with pytest.raises(ConfigError, match="needs a list of waypoints"):
        parse_scenario({"obstacles": [{"position": [5.0, 5.0], "radius": 0.3, "speed": 0.5, "motion": "waypoints"}]})
    with pytest.raises(ConfigError, match=r"obstacles\[0\].speed.*above 0"):
        parse_scenario({"obstacles": [{"position": [5.0, 5.0], "radius": 0.3, "motion": "wander"}]})
    with pytest.raises(ConfigError, match=r"waypoints\[1\]"):
        parse_scenario({"obstacles": [{"position": [5.0, 5.0], "radius": 0.3, "speed": 0.5, "motion": "waypoints",
                                       "waypoints": [[1.0, 1.0], [1.0]]}]})


def test_a_seeds_variation_moves_a_route_with_its_obstacle():
    from twbr_sim.scenario import vary

    sc = parse_scenario({"obstacles": [{"position": [5.0, 5.0], "radius": 0.3, "speed": 0.5, "motion": "waypoints",
                                        "waypoints": [[8.0, 5.0]]}], "target": {"position": [0.0, 9.0]},
                         "variation": {"obstacle_position": 0.5, "obstacle_speed": 0.2}})
    o = vary(sc, 3).obstacles[0]
    dx, dy = o.x - 5.0, o.y - 5.0
    assert math.hypot(dx, dy) > 0.0
    assert o.motion.waypoints[0] == pytest.approx((8.0 + dx, 5.0 + dy))
    assert 0.4 <= o.motion.speed <= 0.6
