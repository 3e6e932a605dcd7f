"""The moving obstacles' predicted paths (robust addition 8): straight where nothing is in the way, round a
post the way the world's walkers go round it."""

import math

import numpy as np
import pytest

from twbr_planner import yielding
from twbr_planner.apf import N_MEMORY, R_LAST_V, settings_vector
from twbr_planner.planner_params import resolve
from twbr_planner.prediction import PREDICTION_STEP, hypotheses, predict_paths, predicted_position
from twbr_sim import agents as ag


def scene(*obstacles):
    """(positions, velocities, radii) of (x, y, vx, vy, radius) tuples."""
    rows = np.array(obstacles, dtype=float).reshape(-1, 5)
    return rows[:, :2].copy(), rows[:, 2:4].copy(), rows[:, 4].copy()


def social(cfg, *obstacles, horizon=5.0):
    return predict_paths(*scene(*obstacles), horizon, cfg["prediction_strength"], cfg["prediction_range"],
                         cfg["prediction_relaxation_time"])


def test_without_a_push_every_obstacle_keeps_its_line_and_the_static_ones_stay():
    positions, velocities, radii = scene((1.0, 2.0, 0.5, -0.25, 0.3), (4.0, 0.0, 0.0, 0.0, 0.5))
    paths = predict_paths(positions, velocities, radii, 3.0, 0.0, 1.0, 1.0)
    assert paths.shape == (2, int(3.0 / PREDICTION_STEP + 1e-9) + 1, 2)
    for t in (0.0, 0.05, 1.23, 3.0, 4.0):  # between samples and past the last one, on the same line
        assert predicted_position(paths, 0, t) == pytest.approx((1.0 + 0.5 * t, 2.0 - 0.25 * t), abs=1e-12)
        assert predicted_position(paths, 1, t) == pytest.approx((4.0, 0.0), abs=1e-12)


def test_a_walker_with_nothing_near_its_way_walks_straight_and_a_post_in_its_way_is_gone_round():
    cfg = resolve({"method": "robust"})
    alone = social(cfg, (0.0, 0.0, 0.5, 0.0, 0.3), (0.0, 5.0, 0.0, 0.0, 0.4))
    assert alone[0, -1] == pytest.approx((0.5 * (alone.shape[1] - 1) * PREDICTION_STEP, 0.0), abs=1e-9)
    # a post 0.3 m beside its line, 2 m ahead: the straight line runs into it; the prediction slows, passes it
    # on the side away from its centre with its disc clear of the post's, and walks on past it
    paths = social(cfg, (0.0, 0.0, 0.5, 0.0, 0.3), (2.0, 0.3, 0.0, 0.0, 0.4), horizon=8.0)
    gaps = np.hypot(paths[0, :, 0] - 2.0, paths[0, :, 1] - 0.3) - 0.7
    assert gaps.min() > 0.1
    assert paths[0, :, 1].min() < -0.5 and paths[0, -1, 0] > 2.5


def test_a_mover_overlapping_a_static_disc_keeps_its_line():
    """A moving track inside a wall's disc is no walker keeping its distance (a LiDAR sliver of a disc seen
    through a gap slides as the robot moves, suite/narrow_passage): the push, exponential in the overlap, would
    throw it off the disc across the robot's way within a step. It is predicted on its straight line."""
    cfg = resolve({"method": "robust"})
    # 0.2 m into a wall disc below it, sliding along the wall at 0.4 m/s; another disc 1 m ahead of it
    paths = social(cfg, (0.0, 0.0, 0.4, 0.0, 0.3), (0.0, -0.6, 0.0, 0.0, 0.5), (1.0, 0.9, 0.0, 0.0, 0.4),
                   horizon=3.0)
    t = PREDICTION_STEP * np.arange(paths.shape[1])
    assert paths[0, :, 0] == pytest.approx(0.4 * t, abs=1e-12) and np.abs(paths[0, :, 1]).max() < 1e-12
    # just clear of the wall disc, the same mover is pushed off it (the rule is the overlap, not the nearness)
    clear = social(cfg, (0.0, 0.0, 0.4, 0.0, 0.3), (0.0, -0.81, 0.0, 0.0, 0.5), horizon=3.0)
    assert clear[0, -1, 1] > 0.02


def test_the_prediction_follows_a_world_walker_round_a_post_where_the_straight_line_does_not():
    """The world's walker (twbr_sim.agents, social force, heading for a far waypoint) passing a post: from its
    state at 1.5 s the prediction stays within 0.1 m of where it walks over the next 4 s (0.07 m when written);
    its straight line ends 0.3 m or more away."""
    cfg = resolve({"method": "robust"})
    spec = np.zeros((2, ag.N_AGENT))
    post, walker = spec
    post[[ag.AP_MOTION, ag.AP_X0, ag.AP_Y0, ag.AP_RADIUS, ag.AP_ID]] = ag.STRAIGHT, 2.0, 0.3, 0.4, 1
    walker[[ag.AP_MOTION, ag.AP_X0, ag.AP_Y0, ag.AP_RADIUS, ag.AP_SPEED, ag.AP_N_WAYPOINTS, ag.AP_SOCIAL,
            ag.AP_STRENGTH, ag.AP_RANGE, ag.AP_RELAXATION_TIME, ag.AP_ANISOTROPY, ag.AP_ID]] = (
        ag.WAYPOINTS, -0.5, 0.0, 0.3, 0.55, 1, 1.0, 2.1, 0.3, 0.5, 0.5, 2)
    waypoints = np.zeros((2, 1, 2))
    waypoints[1, 0] = (30.0, 0.0)
    state = np.zeros((2, ag.N_AGENT_STATE))
    ag.agents_begin(spec, state)
    positions = np.zeros((2, 2))
    velocities = np.zeros((2, 2))
    steps = ag.agents_advance(spec, waypoints, state, 0.0, 1.5, np.nan, np.nan, 0.0)
    ag.agents_at(spec, state, steps, 1.5, positions, velocities)
    radii = spec[:, ag.AP_RADIUS].copy()
    paths = predict_paths(positions, velocities, radii, 4.0, cfg["prediction_strength"], cfg["prediction_range"],
                          cfg["prediction_relaxation_time"])
    start = positions[1].copy()
    start_velocity = velocities[1].copy()
    worst = 0.0
    for k in range(1, 41):
        t = 1.5 + k * 0.1
        steps = ag.agents_advance(spec, waypoints, state, steps, t, np.nan, np.nan, 0.0)
        ag.agents_at(spec, state, steps, t, positions, velocities)
        worst = max(worst, float(np.hypot(*(np.array(predicted_position(paths, 1, k * 0.1)) - positions[1]))))
    straight_end = start + 4.0 * start_velocity
    assert worst < 0.1
    assert np.hypot(*(straight_end - positions[1])) > 0.3


def test_the_look_ahead_sees_a_walker_stepping_round_a_post_into_the_robots_way():
    """A walker passes the robot 1 m to its left and meets a post 0.3 m to the left of its own line: on its
    straight line it never comes near the robot, stepping round the post it does. The yielding look-ahead
    (robust addition 5) meets it only on its bent path, and then stops holding the field's command."""
    cfg = resolve({"method": "robust"})
    a = settings_vector(cfg)
    positions, velocities, radii = scene((0.5, 1.0, 0.5, 0.0, 0.3), (3.0, 1.3, 0.0, 0.0, 0.4))
    horizon = cfg["yield_horizon"]
    conflicts = []
    for strength in (0.0, cfg["prediction_strength"]):
        paths = predict_paths(positions, velocities, radii, horizon, strength, cfg["prediction_range"],
                              cfg["prediction_relaxation_time"])
        samples = hypotheses(positions, velocities, paths, horizon, yielding.ROLLOUT_STEP)
        conflicts.append(yielding.first_conflict(a, 0.0, 0.0, 0.0, 0.4, 0.0, 0.4, 0.0, math.nan, samples,
                                                 velocities, radii, horizon))
        m = np.zeros(N_MEMORY)
        m[R_LAST_V] = 0.4
        conflicts.append(yielding.yield_command(a, m, 0.0, 0.0, 0.0, 0.4, 0.0, 10.0, 0.0, positions, velocities,
                                                radii, paths)[2])
    assert conflicts[:2] == [horizon, False]  # the straight line: clear, the field's command stands
    assert conflicts[2] < 5.0 and conflicts[3]  # the bent path: a conflict within 5 s, and it yields
