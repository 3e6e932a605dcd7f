"""The baseline peers (method: dwa, method: vo): their rules, and that they drive a robot like the others."""

import math

import numpy as np
import pytest
from unicycle import PERIOD, drive

from twbr_planner import dwa, velocity_obstacles
from twbr_planner.apf import Mode, Obstacles, settings_vector
from twbr_planner.planner import ApfPlanner, Target
from twbr_planner.planner_params import resolve
from twbr_planner.prediction import straight_hypotheses


@pytest.mark.parametrize("method", ["dwa", "vo"])
def test_a_peer_reaches_a_static_target_round_an_obstacle_within_the_limits(method):
    poses, outputs, clearance = drive(method, (8.0, 0.5), [(1, 4.0, 0.3, 0.6, 0.0, 0.0)])
    assert outputs[-1].mode is Mode.ARRIVED
    assert math.hypot(poses[-1, 0] - 8.0, poses[-1, 1] - 0.5) <= 0.5
    assert clearance > 0.0  # (safety_margin 0.05 m is kept at the rollouts' 0.2 s points, not between them)
    g = resolve({"method": method})
    v = np.array([o.velocity_cmd for o in outputs])
    w = np.array([o.yaw_rate_cmd for o in outputs])
    assert np.diff(v).max() <= g["max_acceleration"] * PERIOD + 1e-12
    assert -np.diff(v).max() <= g["brake_deceleration"] * PERIOD + 1e-12
    assert np.abs(np.diff(w)).max() <= g["max_yaw_acceleration"] * PERIOD + 1e-12
    assert np.abs(np.diff(w, 2)).max() <= g["max_yaw_jerk"] * PERIOD ** 2 + 1e-12
    assert np.abs(v).max() <= g["v_max"] + 1e-12 and np.abs(w).max() <= g["max_yaw_rate"] + 1e-12


@pytest.mark.parametrize("method", ["dwa", "vo"])
def test_a_peer_steps_aside_for_an_obstacle_coming_head_on(method):
    # coming straight down the robot's line at 0.5 m/s; without avoiding it, they meet at ~9 s
    _, _, clearance = drive(method, (14.0, 0.0), [(1, 10.0, 0.0, 0.3, -0.5, 0.0)], seconds=40.0)
    assert clearance > 0.0


def test_time_to_contact_is_when_a_simulated_point_first_touches_the_disc():
    rng = np.random.default_rng(5)
    for _ in range(300):
        px, py = rng.uniform(-5, 5, 2)
        ux, uy = rng.uniform(-1, 1, 2)
        radius = rng.uniform(0.2, 1.5)
        got = velocity_obstacles.time_to_contact(px, py, ux, uy, radius)
        t = np.arange(0.0, 30.0, 1e-3)
        inside = np.hypot(px + ux * t, py + uy * t) <= radius
        if math.hypot(px, py) <= radius:
            assert got == 0.0 or (got == math.inf and px * ux + py * uy >= 0.0)
        elif inside.any():
            assert got == pytest.approx(t[inside.argmax()], abs=2e-3)
        else:
            assert got == math.inf


def test_vo_takes_a_velocity_outside_every_velocity_obstacle_when_there_is_one():
    g = resolve({"method": "vo"})
    planner = ApfPlanner(g)
    obstacles = Obstacles.of([(1, 3.0, 0.0, 0.5, -0.4, 0.0), (2, 3.0, 2.0, 0.5, 0.0, -0.3)])
    out = planner.step(0.0, 0.0, 0.0, 0.0, 0.0, Target(10.0, 0.0, 0.0, 0.0), obstacles)
    chosen = (math.cos(out.desired_heading), math.sin(out.desired_heading))
    # the direction it steers to, at any speed it may drive, stays out of both obstacles' way for the horizon
    straight = velocity_obstacles.first_contact(0.0, 0.0, 0.6, 0.0, obstacles.positions, obstacles.velocities,
                                                obstacles.radii, g["robot_radius"] + g["safety_margin"])
    assert straight < g["vo_horizon"]  # the way to the target is in a velocity obstacle
    free = [velocity_obstacles.first_contact(0.0, 0.0, s * chosen[0], s * chosen[1], obstacles.positions,
                                             obstacles.velocities, obstacles.radii,
                                             g["robot_radius"] + g["safety_margin"]) for s in (0.6,)]
    assert min(free) >= g["vo_horizon"]


def test_dwa_prefers_an_admissible_rollout_and_the_one_that_touches_last_when_none_is():
    g = resolve({"method": "dwa"})
    a = settings_vector(g)
    wall = np.array([[1.2, y] for y in np.arange(-3.0, 3.01, 0.4)])
    radii = np.full(len(wall), 0.25)
    still = np.zeros_like(wall)
    samples = straight_hypotheses(wall, still, g["dwa_horizon"], dwa.ROLLOUT_STEP)
    clearance, contact, *_ = dwa.rollout(a, 0.0, 0.0, 0.0, 0.6, 0.0, 0.6, 0.0, samples, radii, g["dwa_horizon"],
                                         g["safety_margin"])
    assert contact < g["dwa_horizon"] and clearance < 0.0  # full speed at the wall: it cannot brake in time
    planner = ApfPlanner(g)
    planner.m[:] = 0.0
    out = planner.step(0.0, 0.0, 0.0, 0.0, 0.0, Target(6.0, 0.0, 0.0, 0.0), Obstacles.of(
        [(i, x, y, r) for i, ((x, y), r) in enumerate(zip(wall, radii, strict=True))]))
    assert out.velocity_cmd <= g["max_acceleration"] * PERIOD + 1e-12  # it does not drive on into the wall


def test_a_rollout_s_closest_approach_is_to_the_goal_it_is_given_and_none_without():
    """The window reads a rollout's closest approach to a static target it is arriving at; the dwa peer never:
    without a goal the rollout computes none (a square root a step cost the peer a third of its rate in the
    batch engine, benchmarks/HISTORY.md, thirtieth session), and the rest of what it returns is the same."""
    a = settings_vector(resolve({"method": "dwa"}))
    samples = straight_hypotheses(np.array([[3.0, 2.0]]), np.zeros((1, 2)), 3.0, dwa.ROLLOUT_STEP)
    radii = np.array([0.3])
    near, counts = dwa.every_obstacle(samples, radii)
    args = (a, 0.0, 0.0, 0.0, 0.5, 0.0, 0.5, 0.0, samples, radii, near, counts, 3.0, 0.05, False)
    plain = dwa.rollout_among(*args)
    aimed = dwa.rollout_among(*args, 1.0, 0.5)
    assert plain[5] == math.inf
    assert plain[:5] == aimed[:5]
    # straight along x at 0.5 m/s (from 0.5 m/s): it passes (1.0, 0.5) 0.5 m off, to a step's resolution
    assert aimed[5] == pytest.approx(0.5, abs=0.5 * dwa.ROLLOUT_STEP)
