import math
from pathlib import Path

import numpy as np
import pytest

from twbr_sim.scenario import load_scenario, parse_scenario
from twbr_sim.world import World, arc

CONFIG = Path(__file__).resolve().parents[3] / "config" / "scenarios"


def moving_target(max_yaw_rate=1.0, speed=0.25, obstacles=()):
    return parse_scenario(
        {
            "duration": 60.0,
            "seed": 4,
            "target": {"position": [10.0, 15.0], "speed": speed, "max_yaw_rate": max_yaw_rate},
            "obstacles": list(obstacles),
        }
    )


def test_arc_matches_numerical_integration():
    x, y, h = 1.0, 2.0, 0.3
    dt = 1e-4
    for _ in range(20000):
        x += 0.25 * math.cos(h) * dt
        y += 0.25 * math.sin(h) * dt
        h += 0.7 * dt
    ax, ay, ah = arc(1.0, 2.0, 0.3, 0.25, 0.7, 2.0)
    assert (ax, ay, ah) == pytest.approx((x, y, h), abs=1e-4)
    assert arc(0, 0, 0.0, 1.0, 0.0, 2.0) == pytest.approx((2.0, 0.0, 0.0))


def test_target_moves_at_constant_speed_with_bounded_random_turns():
    w = World(moving_target(), robot_radius=0.3, seed=11)
    rates = set()
    path = []
    for k in range(1, 2001):
        w.advance_to(k * 0.01)
        t = w.target()
        rates.add(round(t.yaw_rate, 12))
        path.append((t.x, t.y))
    assert all(abs(r) <= 1.0 for r in rates)
    assert len(rates) >= 19  # redrawn every second: 20 s gives 20 draws
    steps = np.diff(np.array(path), axis=0)
    assert np.hypot(steps[:, 0], steps[:, 1]) == pytest.approx(0.25 * 0.01, rel=1e-3)


def test_world_does_not_depend_on_when_it_is_sampled():
    coarse = World(moving_target(), 0.3, seed=3)
    fine = World(moving_target(), 0.3, seed=3)
    for k in range(1, 1001):
        fine.advance_to(k * 0.0137)
    coarse.advance_to(1000 * 0.0137)
    a, b = coarse.target(), fine.target()
    assert (a.x, a.y, a.heading) == pytest.approx((b.x, b.y, b.heading), abs=1e-12)


def test_same_seed_same_world_other_seed_other_world():
    def end(seed):
        w = World(moving_target(), 0.3, seed)
        w.advance_to(30.0)
        return w.target()

    assert end(5) == end(5)
    assert end(5) != end(6)


def test_obstacles_move_at_constant_velocity():
    sc = load_scenario(CONFIG / "dynamic_obstacles.yaml")
    w = World(sc, 0.3, seed=sc.seed)
    w.advance_to(10.0)
    o1, o2 = w.obstacles()
    assert (o1.x, o1.y) == pytest.approx((5.0 - 2.8 / math.sqrt(2), 3.0 + 2.8 / math.sqrt(2)))
    assert (o2.x, o2.y) == pytest.approx((5.5, 9.0))
    assert (o1.radius, o2.radius) == (1.5, 2.0)
    assert math.hypot(o1.vx, o1.vy) == pytest.approx(0.28)


def test_collision_clearance_and_capture():
    sc = moving_target(max_yaw_rate=0.0, speed=0.0, obstacles=[{"id": 7, "position": [3.0, 0.0], "radius": 1.0}])
    w = World(sc, robot_radius=0.3, seed=0)
    far = w.assess(0.0, 0.0)
    assert far.clearance == pytest.approx(1.7) and not far.collision and far.collision_obstacle_id == -1
    hit = w.assess(1.8, 0.0)
    assert hit.collision and hit.collision_obstacle_id == 7 and hit.clearance == pytest.approx(-0.1)
    w.assess(1.75, 0.0)
    assert w.collision_count == 1  # one collision, however long it lasts
    w.assess(0.0, 0.0)
    w.assess(1.8, 0.0)
    assert w.collision_count == 2
    assert w.assess(10.0, 14.6).target_reached
    assert not w.assess(10.0, 14.4).target_reached


def test_world_without_target_or_obstacles():
    w = World(load_scenario(CONFIG / "step.yaml"), 0.3, seed=0)
    w.advance_to(1.0)
    a = w.assess(0.0, 0.0)
    assert w.target() is None and a.clearance == math.inf and not a.target_reached
    with pytest.raises(ValueError):
        w.advance_to(0.5)
