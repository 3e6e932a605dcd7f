"""Property tests of the planner core: finite in, finite out; 0 <= v <= v_max; |omega| limited (both methods);
mirror symmetry (the paper's: the robust method breaks ties to one side, the way round tries left first)."""

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from twbr_common.params import defaults
from twbr_planner.apf import Obstacles
from twbr_planner.planner import ApfPlanner, Target
from twbr_planner.planner_params import APF_SPECS

G = {**defaults(APF_SPECS), "method": "paper"}
ROBUST = {**defaults(APF_SPECS), "method": "robust"}
coord = st.floats(-50.0, 50.0)
obstacle = st.tuples(coord, coord, st.floats(0.05, 5.0))
situation = st.tuples(coord, coord, st.floats(-math.pi, math.pi), st.floats(-2.0, 2.0),  # robot x, y, yaw, v
                      coord, coord, st.floats(-1.0, 1.0), st.floats(-1.0, 1.0),  # target x, y, vx, vy
                      st.lists(obstacle, max_size=5))


def plan(planner, x, y, yaw, v, tx, ty, tvx, tvy, obstacles, steps=5):
    obs = Obstacles.of([(k, ox, oy, r) for k, (ox, oy, r) in enumerate(obstacles)])
    return [planner.step(0.05 * k, x, y, yaw, v, Target(tx, ty, tvx, tvy), obs) for k in range(steps)]


@pytest.mark.parametrize("cfg", [G, ROBUST], ids=["paper", "robust"])
@settings(max_examples=300, deadline=None)
@given(s=situation)
def test_commands_are_finite_and_inside_their_limits(cfg, s):
    for out in plan(ApfPlanner(cfg), *s):
        assert math.isfinite(out.velocity_cmd) and math.isfinite(out.yaw_rate_cmd)
        assert 0.0 <= out.velocity_cmd <= cfg["v_max"]  # static obstacles: nothing to back away from
        assert abs(out.yaw_rate_cmd) <= cfg["max_yaw_rate"]
        assert all(math.isfinite(f) for f in (*out.attractive_force, *out.repulsive_force))


@settings(max_examples=200, deadline=None)
@given(situation)
def test_the_mirrored_world_gives_the_mirrored_command(s):
    x, y, yaw, v, tx, ty, tvx, tvy, obstacles = s
    a = plan(ApfPlanner(G), x, y, yaw, v, tx, ty, tvx, tvy, obstacles)
    b = plan(ApfPlanner(G), x, -y, -yaw, v, tx, -ty, tvx, -tvy, [(ox, -oy, r) for ox, oy, r in obstacles])
    for oa, ob in zip(a, b, strict=True):
        assert math.isclose(oa.velocity_cmd, ob.velocity_cmd, rel_tol=1e-9, abs_tol=1e-9)
        if abs(abs(oa.heading_error) - math.pi) > 1e-6:  # exactly behind: either way round is right
            assert math.isclose(oa.yaw_rate_cmd, -ob.yaw_rate_cmd, rel_tol=1e-9, abs_tol=1e-9)
        assert oa.mode is ob.mode


def test_the_start_up_line_names_the_method_that_runs_and_its_additions():
    from twbr_planner.planner_params import describe, resolve

    assert describe(resolve({"method": "paper"})).startswith("the paper's potential field (eqs. 19-28): K_p 1,")
    robust = describe(resolve({"method": "robust", "yield_horizon": 0.0, "safety_filter": False}))
    assert robust.startswith("the robust potential field") and "K_v" not in robust
    assert ("with goal-reachable field, escape, evasion, speed policy, dynamic window, social prediction; off:"
            " yielding, safety filter") in robust
    assert describe(resolve({"method": "dwa"})).startswith("the dynamic window (Fox et al. 1997): 3 s rollouts")
    assert describe(resolve({"method": "vo"})).startswith("velocity obstacles (Fiorini & Shiller 1998): 5 s")
