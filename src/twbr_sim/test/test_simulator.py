import math
from pathlib import Path

import pytest

from twbr_common.guard import Verdict
from twbr_common.param_files import node_parameters
from twbr_common.params import ConfigError, defaults
from twbr_sim import dynamics as dyn
from twbr_sim.robot_params import ROBOT_SPECS, robot_params
from twbr_sim.scenario import load_scenario
from twbr_sim.simulator import SIM_SPECS, Simulator

CONFIG = Path(__file__).resolve().parents[3] / "config"


def make(**overrides):
    return Simulator(robot_params(), {**defaults(SIM_SPECS), **overrides}, None, seed=0)


def test_robot_yaml_holds_the_design_defaults():
    values = node_parameters(CONFIG / "robot.yaml", "sim_node")
    assert values == defaults(ROBOT_SPECS)


def test_sim_yaml_declares_only_known_parameters_with_valid_values():
    values = node_parameters(CONFIG / "sim.yaml", "sim_node")
    values.pop("use_sim_time")
    specs = {s.name: s for s in SIM_SPECS}
    assert set(values) == set(specs)
    for name, value in values.items():
        specs[name].validate(value)


def test_inconsistent_robot_parameters_are_refused():
    with pytest.raises(ConfigError) as e:
        robot_params({"robot_radius": 0.1})
    assert "'robot_radius' = 0.1: must be >= wheel_separation/2" in str(e.value)
    with pytest.raises(ConfigError) as e:
        robot_params({"wheel_radius": -0.1})
    assert "'wheel_radius' = -0.1: must be (0, 5] m" in str(e.value)


def test_publish_rate_must_divide_physics_rate():
    with pytest.raises(ConfigError) as e:
        make(publish_rate=300.0)
    assert "'publish_rate' = 300: must divide physics_rate" in str(e.value)
    assert make(publish_rate=250.0).steps_per_publish == 4


def test_non_finite_commands_never_reach_the_motors():
    sim = make()
    assert sim.offer_command(0.0, 1.0, 1.0).verdict is Verdict.ACCEPTED
    assert sim.offer_command(0.0, math.nan, 1.0).verdict is Verdict.NON_FINITE
    assert sim.offer_command(0.0, 1.0, -math.inf).verdict is Verdict.NON_FINITE
    assert sim.applied_command() == (1.0, 1.0)
    sim.advance(5)
    assert all(math.isfinite(v) for v in sim.state)


def test_commands_past_the_limit_are_clipped_and_flagged():
    sim = make()
    result = sim.offer_command(0.0, 40.0, -3.0)
    assert result.saturated and sim.torque_saturated
    assert sim.applied_command() == (15.0, -3.0)
    sim.offer_command(0.001, 1.0, 1.0)
    assert not sim.torque_saturated


def test_stale_command_means_zero_torque():
    sim = make()
    sim.offer_command(0.0, 2.0, 2.0)
    sim.advance(100)  # 0.1 s: still fresh
    assert sim.applied_command() == (2.0, 2.0)
    sim.advance(1)
    assert sim.command_stale and sim.applied_command() == (0.0, 0.0)
    # A late command stamped before the timeout is refused, not applied.
    assert sim.offer_command(0.0005, 2.0, 2.0).verdict is Verdict.STALE


def test_fall_is_detected_and_latched():
    sim = make()
    sim.state[dyn.S_TH] = 0.3
    sim.advance(2000)
    assert sim.fallen
    frozen = sim.state.copy()
    sim.advance(10)
    assert (sim.state == frozen).all() and abs(frozen[dyn.S_TH]) > 0.8


def test_scenario_sets_start_pose_and_world():
    sc = load_scenario(CONFIG / "scenarios" / "dynamic_obstacles.yaml")
    sim = Simulator(robot_params(), defaults(SIM_SPECS), sc, seed=sc.seed)
    assert sim.world is not None
    sim.advance(1000)
    assert sim.world.time == pytest.approx(1.0)
    assert sim.assess().target_distance == pytest.approx(math.hypot(*_xy(sim.world.target())), abs=1e-9)


def _xy(t):
    return t.x, t.y
