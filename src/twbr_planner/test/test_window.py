"""The dynamic window among moving obstacles (robust addition 7): when it acts, what it picks, and what it
leaves to the field."""

import math

import numpy as np
from unicycle import drive as drive_unicycle

from twbr_planner import window
from twbr_planner.apf import A_MAX_ACCELERATION, N_MEMORY, R_LAST_V, Mode
from twbr_planner.apf import settings_vector as vector
from twbr_planner.dwa import ROLLOUT_STEP, every_obstacle, rollout, rollout_among
from twbr_planner.planner_params import resolve
from twbr_planner.prediction import predict_paths, straight_hypotheses


def settings(**overrides):
    return resolve({"method": "robust", **overrides})


def world(*obstacles):
    """(positions, velocities, radii) of (x, y, vx, vy, radius) tuples."""
    rows = np.array(obstacles, dtype=float).reshape(-1, 5)
    velocities = rows[:, 2:4].copy()
    return rows[:, :2].copy(), velocities, rows[:, 4].copy()


def lines(positions, velocities, radii, horizon=10.0):
    """What a rollout meets: the obstacles on their straight lines (the dynamic window baseline's prediction)."""
    return straight_hypotheses(positions, velocities, horizon, ROLLOUT_STEP)


def command(cfg, obstacles, v0=0.4, alpha=0.0, v_nominal=0.6, omega_nominal=0.0):
    m = np.zeros(N_MEMORY)
    m[R_LAST_V] = v0
    paths = predict_paths(*obstacles, cfg["window_horizon"], cfg["prediction_strength"], cfg["prediction_range"],
                          cfg["prediction_relaxation_time"])
    return window.window_command(vector(cfg), m, 0.0, 0.0, 0.0, v_nominal, omega_nominal, alpha, 10.0, 0.0, 10.0,
                                 False, *obstacles, paths)


def test_without_a_mover_in_reach_the_field_drives():
    cfg = settings()
    disc_ahead = world((1.5, 0.0, 0.0, 0.0, 0.4))  # static: the field's and the safety filter's
    far_walker = world((40.0, 0.0, -0.5, 0.0, 0.3))  # cannot come near within window_horizon
    for obstacles in (disc_ahead, far_walker):
        assert command(cfg, obstacles, v_nominal=0.33, omega_nominal=0.2) == (0.33, 0.2, False)
    assert command(settings(window_horizon=0.0), world((2.0, 0.0, -0.5, 0.0, 0.3)),
                   v_nominal=0.33, omega_nominal=0.2) == (0.33, 0.2, False)


def test_a_walker_crossing_the_way_is_passed_clear_where_the_fields_command_meets_it():
    cfg = settings()
    a = vector(cfg)
    walker = world((1.6, -1.0, 0.0, 0.5, 0.3))  # crosses the robot's line 1.6 m ahead in 2 s
    positions, velocities, radii = walker
    paths = lines(positions, velocities, radii)
    straight = rollout(a, 0.0, 0.0, 0.0, 0.4, 0.0, 0.6, 0.0, paths, radii, cfg["window_horizon"],
                       cfg["window_margin"])
    assert straight[1] < cfg["window_horizon"]  # the field's command (straight on) touches the walker
    v, omega, windowed = command(cfg, walker)
    assert windowed
    chosen = rollout(a, 0.0, 0.0, 0.0, 0.4, 0.0, v, omega, paths, radii, cfg["window_horizon"],
                     cfg["window_margin"])
    assert chosen[1] == math.inf  # never within window_margin over the horizon
    assert chosen[0] > cfg["window_margin"]


def test_with_the_way_clear_it_drives_the_fields_direction_at_full_speed():
    cfg = settings()
    walker_behind = world((-3.0, 0.0, -0.5, 0.0, 0.3))  # in reach, walking away
    v, omega, windowed = command(cfg, walker_behind, alpha=0.0, v_nominal=0.2)
    assert windowed and v == cfg["v_max"] and omega == 0.0
    v, omega, _ = command(cfg, walker_behind, alpha=1.0)
    assert omega > 0.0  # turns towards a field pointing left
    v, omega, _ = command(cfg, walker_behind, alpha=-1.0)
    assert omega < 0.0


def test_a_walker_crossing_ahead_is_passed_clear_and_sooner_than_the_field_alone_passes_it():
    # A person crossing the robot's line 3 m ahead: the field alone yields and waits for it; the window
    # drives on behind it (measured: arrived after 24.6 s against 30.2 s, clearance 0.41 against 1.10 m).
    walker = [(1, 3.0, -6.0, 0.3, 0.0, 0.5)]
    _, windowed, clearance = drive_unicycle("robust", (10.0, 0.0), walker, seconds=60.0)
    _, field_only, _ = drive_unicycle("robust", (10.0, 0.0), walker, seconds=60.0, window_horizon=0.0)
    assert windowed[-1].mode is Mode.ARRIVED and field_only[-1].mode is Mode.ARRIVED
    assert clearance > settings()["safety_margin"]
    assert len(windowed) < 0.9 * len(field_only)


def test_the_obstacles_out_of_reach_change_no_rollout():
    """within_reach, and the plan's table of each step's obstacles (gap_table), keep every obstacle that can
    change a rollout's admissibility or its capped clearance: on random scenes (discs and walkers up to 12 m
    off), every rollout of the grid over the window's horizon has the same contact time and the same
    clearance capped at window_clearance_cap with the kept obstacles as with all of them (and stopped at its
    contact, the same contact) and the end heading end_yaw gives, and some scenes do leave obstacles out."""
    from twbr_planner.dwa import (
        OMEGA_SAMPLES,
        V_SAMPLES,
        candidate,
        end_yaw,
        gap_table,
        rollout_among,
        within_reach,
    )

    cfg = settings()
    a = vector(cfg)
    horizon, margin, cap = cfg["window_horizon"], cfg["window_margin"], cfg["window_clearance_cap"]
    rng = np.random.default_rng(7)
    left_out = 0
    for _ in range(30):
        n = 20
        positions = rng.uniform(-12.0, 12.0, (n, 2))
        velocities = rng.uniform(-0.8, 0.8, (n, 2)) * (rng.random((n, 1)) < 0.3)
        radii = rng.uniform(0.2, 0.6, n)
        v0 = rng.uniform(-0.2, 0.6)
        near = within_reach(a, 0.0, 0.0, v0, positions, velocities, radii, horizon, max(cap, margin))
        left_out += n - len(near)
        paths = lines(positions, velocities, radii)
        steps_near, steps_count = gap_table(a, 0.0, 0.0, v0, paths, radii, max(cap, margin))
        left_out += steps_count.size * n - steps_count.sum()
        for i in range(V_SAMPLES):
            for k in range(OMEGA_SAMPLES):
                v_goal, w_goal = candidate(a, cfg["v_max"], i, k)
                every = rollout(a, 0.0, 0.0, 0.3, v0, 0.0, v_goal, w_goal, paths, radii,
                                horizon, margin)
                kept = rollout(a, 0.0, 0.0, 0.3, v0, 0.0, v_goal, w_goal, paths[:, near], radii[near], horizon,
                               margin)
                assert kept[1] == every[1] and min(kept[0], cap) == min(every[0], cap)
                assert end_yaw(a, 0.3, 0.0, w_goal, horizon) == every[4]  # the window's bound's heading
                for until_contact in (False, True):
                    stepped = rollout_among(a, 0.0, 0.0, 0.3, v0, 0.0, v_goal, w_goal, paths, radii, steps_near,
                                            steps_count, horizon, margin, until_contact)
                    assert stepped[1] == every[1]
                    if not until_contact or every[1] == math.inf:
                        assert min(stepped[0], cap) == min(every[0], cap)
    assert left_out > 0


def test_among_walkers_the_speed_may_rise_at_window_acceleration_and_elsewhere_at_max_acceleration():
    cfg = settings()
    a = vector(cfg)
    walker = world((-2.0, 0.5, 0.6, 0.0, 0.3))  # behind, overtaking: within reach over the horizon
    disc = world((1.5, 0.0, 0.0, 0.0, 0.4))
    limited = window.window_limits(a, 0.0, 0.0, *walker, False)
    assert limited[A_MAX_ACCELERATION] == cfg["window_acceleration"] > cfg["max_acceleration"]
    assert a[A_MAX_ACCELERATION] == cfg["max_acceleration"]  # the settings themselves are left as they are
    for b in (window.window_limits(a, 0.0, 0.0, *disc, False), window.window_limits(a, 0.0, 0.0, *walker, True),
              window.window_limits(vector(settings(window_acceleration=0.0)), 0.0, 0.0, *walker, False)):
        assert b[A_MAX_ACCELERATION] == cfg["max_acceleration"]


def test_near_a_static_target_it_picks_the_rollout_that_comes_nearest_to_it_not_one_along_the_start_direction():
    cfg = settings()
    a = vector(cfg)
    walker = world((-2.0, -2.0, 0.5, 0.0, 0.3))  # in reach, clear of every rollout: the window drives
    paths = predict_paths(*walker, cfg["window_horizon"], cfg["prediction_strength"], cfg["prediction_range"],
                          cfg["prediction_relaxation_time"])
    samples = lines(*walker)
    near, counts = every_obstacle(samples, walker[2])

    def closest_approach(target, moving_target):
        """How near the chosen rollout comes to a target on the robot's left, 0.85 m away (the robot at 0.5
        m/s, heading past it)."""
        m = np.zeros(N_MEMORY)
        m[R_LAST_V] = 0.5
        distance = math.hypot(*target)
        v, omega, windowed = window.window_command(a, m, 0.0, 0.0, 0.0, 0.5, 0.0, math.atan2(target[1], target[0]),
                                                   *target, distance, moving_target, *walker, paths)
        assert windowed
        return rollout_among(a, 0.0, 0.0, 0.0, 0.5, 0.0, v, omega, samples, walker[2], near, counts,
                             cfg["window_horizon"], cfg["window_margin"], False, *target)[5]

    target = (0.3, 0.8)
    # scored by the field's direction at the start (as for a moving target), its best rollout circles past
    assert closest_approach(target, True) > cfg["capture_radius"] + 0.15
    assert closest_approach(target, False) <= cfg["capture_radius"]


def test_a_threat_walking_along_the_way_leaves_the_window_the_fields_own_direction():
    cfg = settings()
    a = vector(cfg)
    pushed = 1.2  # the field's direction with the evasion's push, to the left of the field's own (+x)
    for velocity, own in (((-0.5, 0.05), True),  # towards the robot, nearly along its way
                          ((0.9, -0.1), True),  # after it, faster
                          ((0.05, 0.5), False),  # across the way: the push stands
                          ((-0.4, 0.4), False)):  # 45 degrees off the way
        velocities = np.array([velocity])
        got = window.window_direction(a, pushed, 2.0, 0.0, 0, velocities)
        assert got == (0.0 if own else pushed)
    assert window.window_direction(a, pushed, 2.0, 0.0, -1, np.zeros((1, 2))) == pushed  # no threat
    off = vector(settings(window_lane_angle=0.0))
    assert window.window_direction(off, pushed, 2.0, 0.0, 0, np.array([[-0.5, 0.0]])) == pushed


def test_a_walker_coming_head_on_is_passed_clear_without_the_evasions_push():
    """The window alone keeps the robot clear of a walker on its line (one that does not give way, here),
    and steps less far off its way than with the push."""
    margin = settings()["window_margin"] - 0.05  # less a sample's travel: the unicycle samples at 20 Hz
    detours = []
    for lane_angle in (0.0, settings()["window_lane_angle"]):
        poses, outputs, clearance = drive_unicycle("robust", (12.0, 0.0), [(1, 9.0, 0.05, 0.3, -0.5, 0.0)],
                                                   seconds=45.0, window_lane_angle=lane_angle)
        assert outputs[-1].mode is Mode.ARRIVED
        assert clearance > margin
        detours.append(np.abs(poses[:, 1]).max())
    assert detours[1] < detours[0] - 0.2
