"""The APF core against hand-computed values: forces, potentials, eq. 28, the heading wrap, modes."""

import math

import numpy as np
import pytest

from twbr_common.params import defaults
from twbr_planner.apf import (
    Mode,
    Obstacles,
    attractive_force,
    potential,
    repulsive_force,
    repulsive_magnitude,
    repulsive_potential,
    speed_command,
    yaw_rate_command,
)
from twbr_planner.planner import ApfPlanner, Target
from twbr_planner.planner_params import APF_SPECS

G = defaults(APF_SPECS)


def test_attractive_force_is_eq_21():
    f = attractive_force(np.array([1.0, 2.0]), np.array([0.5, 0.0]), np.array([4.0, 6.0]), np.array([0.0, 0.25]),
                         k_p=2.0, k_v=0.5)
    # 2*(3, 4) + 0.5*(-0.5, 0.25)
    assert f == pytest.approx([5.75, 8.125])


def test_repulsive_magnitude_is_eq_23_and_zero_outside_the_range():
    # d = 0.5, rho = 2, K_o = 1: (1/0.25)(2 - 0.5) - (0.5 - 2) = 6 + 1.5
    assert repulsive_magnitude(0.5, k_o=1.0, rho_o=2.0, d_min=0.01) == pytest.approx(7.5)
    assert repulsive_magnitude(2.0, 1.0, 2.0, 0.01) == pytest.approx(0.0)  # continuous at the range
    assert repulsive_magnitude(2.5, 1.0, 2.0, 0.01) == 0.0
    # Touching counts as d_min: finite.
    assert math.isfinite(repulsive_magnitude(-0.3, 1.0, 2.0, 0.01))


def test_repulsion_is_measured_to_the_surface_and_points_from_the_obstacle_to_the_robot():
    obstacles = Obstacles.of([(1, 3.0, 0.0, 1.0)])
    # Robot at the origin, footprint 0.5: clearance d = 3 - 1 - 0.5 = 1.5.
    f, d = repulsive_force(np.zeros(2), obstacles, k_o=2.0, rho_o=2.0, robot_radius=0.5, d_min=0.01)
    assert d == pytest.approx([1.5])
    expected = 2.0 * ((1 / 1.5**2) * (1 / 1.5 - 1 / 2.0) - (1.5 - 2.0))
    assert f == pytest.approx([-expected, 0.0])  # along -x: away from the obstacle


def test_repulsion_sums_over_obstacles():
    both = Obstacles.of([(1, 1.5, 0.0, 0.5), (2, -1.5, 0.0, 0.5)])
    f, _ = repulsive_force(np.zeros(2), both, 1.0, 2.0, 0.0, 0.01)
    assert f == pytest.approx([0.0, 0.0], abs=1e-12)  # symmetric: they cancel


def test_force_is_the_negative_gradient_of_the_potential():
    obstacles = Obstacles.of([(1, 2.0, 1.0, 0.7), (2, -1.0, 3.0, 1.0)])
    target = np.array([6.0, 5.0])
    g = {**G, "k_o": 3.0, "rho_o": 2.0, "robot_radius": 0.3}
    for p in ([0.5, 0.8], [1.0, 2.5], [3.5, 1.2], [-0.5, 1.0]):
        p = np.array(p)
        h = 1e-6
        grad = np.array([(potential(p + h * e, target, obstacles, g) - potential(p - h * e, target, obstacles, g))
                         / (2 * h) for e in np.eye(2)])
        f_att = attractive_force(p, np.zeros(2), target, np.zeros(2), g["k_p"], g["k_v"])
        f_rep, _ = repulsive_force(p, obstacles, g["k_o"], g["rho_o"], g["robot_radius"], g["min_distance"])
        assert f_att + f_rep == pytest.approx(-grad, rel=1e-5, abs=1e-6)


def test_potential_over_a_grid_has_its_minimum_at_the_target_and_peaks_at_obstacles():
    xs = np.linspace(-2, 8, 101)
    grid = np.stack(np.meshgrid(xs, xs), axis=-1)
    obstacles = Obstacles.of([(1, 3.0, 3.0, 1.0)])
    u = potential(grid, np.array([6.0, 6.0]), obstacles, G)
    i, j = np.unravel_index(np.argmin(u), u.shape)
    assert (grid[i, j] == pytest.approx([6.0, 6.0]))
    assert repulsive_potential(np.array([3.0, 4.35]), obstacles, G["k_o"], G["rho_o"], G["robot_radius"],
                               G["min_distance"]) > 100.0
    assert repulsive_potential(np.array([3.0, 7.0]), obstacles, G["k_o"], G["rho_o"], G["robot_radius"],
                               G["min_distance"]) == 0.0


def test_eq_28_with_its_conditions_the_right_way_round():
    # The paper prints v = v_max for d <= rho_o and d/rho_o otherwise; the sense is the reverse.
    assert speed_command(5.0, rho_o=2.0, v_max=0.6) == 0.6
    assert speed_command(1.0, rho_o=2.0, v_max=0.6) == pytest.approx(0.3)
    assert speed_command(0.0, 2.0, 0.6) == 0.0


def test_heading_error_wraps_around_pi():
    # Desired 170 deg, facing -170 deg: turn 20 deg the short way (negative), not 340 deg.
    omega, error = yaw_rate_command(math.radians(170), math.radians(-170), k_s=1.0, limit=10.0)
    assert error == pytest.approx(math.radians(-20))
    assert omega == pytest.approx(math.radians(-20))
    omega, _ = yaw_rate_command(math.pi / 2, 0.0, k_s=5.0, limit=1.5)
    assert omega == 1.5  # limited


def test_static_target_arrival_stops_and_a_moving_target_is_followed():
    planner = ApfPlanner(G)
    static = Target(0.3, 0.0, 0.0, 0.0)
    out = planner.step(0.0, 0.0, 0.0, 0.0, 0.0, static, Obstacles.empty())
    assert out.mode is Mode.ARRIVED and out.velocity_cmd == 0.0 and out.yaw_rate_cmd == 0.0
    planner = ApfPlanner(G)
    moving = Target(0.3, 0.0, 0.25, 0.0)
    outs = [planner.step(0.05 * k, 0.0, 0.0, 0.0, 0.0, moving, Obstacles.empty()) for k in range(40)]
    assert outs[-1].mode is Mode.FOLLOWING and outs[-1].velocity_cmd > 0.0


def test_speed_command_ramps_at_the_acceleration_limit():
    planner = ApfPlanner(G)
    far = Target(20.0, 0.0, 0.0, 0.0)
    v = [planner.step(0.05 * k, 0.0, 0.0, 0.0, 0.0, far, Obstacles.empty()).velocity_cmd for k in range(30)]
    steps = np.diff(v)
    assert steps.max() <= G["max_acceleration"] * 0.05 + 1e-12
    assert v[-1] == pytest.approx(G["max_acceleration"] * 0.05 * 30)


def test_a_local_minimum_is_reported_as_stuck():
    # Target straight behind a wide obstacle, robot not moving: attraction and repulsion balance.
    planner = ApfPlanner({**G, "stuck_time": 2.0})
    wall = Obstacles.of([(1, 1.5, 0.0, 0.5)])
    target = Target(5.0, 0.0, 0.0, 0.0)
    modes = [planner.step(0.05 * k, 0.0, 0.0, 0.0, 0.0, target, wall).mode for k in range(60)]
    assert modes[0] is not Mode.STUCK and modes[-1] is Mode.STUCK


def test_no_target_means_stop():
    out = ApfPlanner(G).step(0.0, 0.0, 0.0, 0.0, 0.3, None, Obstacles.empty())
    assert out.mode is Mode.NO_TARGET and out.velocity_cmd == 0.0 and out.yaw_rate_cmd == 0.0
