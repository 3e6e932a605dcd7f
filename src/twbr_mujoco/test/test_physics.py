"""MuJoCo as the robot: the same robot as the ideal model while both wheels hold the ground, and what the
ideal model cannot show (lift-off, slip) when they do not."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from twbr_batch.closed_loop import PlannerReference, run_closed_loop, scenario_reference
from twbr_batch.response import step_response
from twbr_common.params import ConfigError, defaults
from twbr_mujoco.model import CHASSIS, LEFT_WHEEL, MUJOCO_SPECS
from twbr_mujoco.motor import advance_current
from twbr_mujoco.physics import MujocoSimulator, euler_zyx, mujoco_simulator, quat_zyx
from twbr_sim import dynamics as dyn
from twbr_sim.robot_params import ROBOT_SPECS, robot_params
from twbr_sim.scenario import load_scenario
from twbr_sim.scenario_files import find_scenario, sensor_preset
from twbr_sim.simulator import SIM_SPECS, Simulator

ROBOT = defaults(ROBOT_SPECS)
SETTINGS = {**defaults(SIM_SPECS), **defaults(MUJOCO_SPECS)}


def tilted(sim: MujocoSimulator, pitch: float) -> MujocoSimulator:
    sim.data.qpos[3:7] = quat_zyx(0.0, pitch, 0.0)
    mujoco.mj_forward(sim.model, sim.data)
    sim.state[dyn.S_TH] = pitch
    return sim


def test_the_model_has_the_robots_masses_and_inertias():
    sim = MujocoSimulator(ROBOT, SETTINGS, None, 0)
    m = sim.model
    chassis, wheel = m.body(CHASSIS).id, m.body(LEFT_WHEEL).id
    assert m.body_mass[chassis] == pytest.approx(ROBOT["body_mass"])
    assert m.body_mass[wheel] == pytest.approx(ROBOT["wheel_mass"])
    assert m.body_ipos[chassis][2] == pytest.approx(ROBOT["com_height"])
    i1, i2, i3 = ROBOT["body_inertia_roll"], ROBOT["body_inertia_pitch"], ROBOT["body_inertia_yaw"]
    assert sorted(m.body_inertia[chassis]) == pytest.approx(sorted([i1, i2, i3]))
    assert m.body_inertia[wheel][1] == pytest.approx(ROBOT["wheel_inertia"])
    # It starts on loaded wheels: each carries half the weight, the axle sunk well under a millimetre.
    loads = sim.wheel_contacts()
    weight = (ROBOT["body_mass"] + 2 * ROBOT["wheel_mass"]) * ROBOT["gravity"]
    assert loads[:, 0] == pytest.approx([weight / 2] * 2, rel=1e-3)
    assert 0.0 < ROBOT["wheel_radius"] - sim.data.qpos[2] < 5e-4


def test_euler_angles_round_trip():
    for roll, pitch, yaw in ((0.1, -0.3, 2.0), (-0.2, 0.4, -3.0), (0.0, 0.0, 0.5)):
        assert euler_zyx(quat_zyx(roll, pitch, yaw)) == pytest.approx((roll, pitch, yaw))


def test_the_motor_delivers_the_command_within_a_few_electrical_time_constants():
    p = robot_params(ROBOT)
    n_k = ROBOT["gear_ratio"] * ROBOT["motor_constant"]
    current, torque = 0.0, 0.0
    # Wheel held; the current loop's pole is (R + k_i)/L = 1500 1/s, integrated at 1 kHz like the ideal
    # model's (RK4 at h lambda = 1.5: a factor 0.27 per step where the exact one is 0.22).
    for _ in range(8):
        current, torque = advance_current(p, 2.0, current, 0.0, 1e-3)
    assert n_k * current == pytest.approx(2.0, rel=1e-4)
    assert 1.999 < torque < 2.0  # the mean over the eighth millisecond
    # The driver's current limit caps the torque at N k I_max = 15 N*m.
    for _ in range(10):
        current, torque = advance_current(p, 40.0, current, 0.0, 1e-3)
    assert n_k * current == pytest.approx(15.0, rel=1e-3)


def test_an_unactuated_fall_agrees_with_the_ideal_model():
    """dynamics.md: from rest at 0.05 rad, |pitch| reaches 0.5 rad at 0.4137 s with the default friction."""
    engines = [tilted(MujocoSimulator(ROBOT, SETTINGS, None, 0), 0.05),
               Simulator(robot_params(ROBOT), SETTINGS, None, 0)]
    engines[1].state[dyn.S_TH] = 0.05
    times, travel = [], []
    for sim in engines:
        while abs(sim.state[dyn.S_TH]) < 0.5:
            sim.advance(1)
        times.append(sim.time)
        travel.append(sim.state[dyn.S_X])
    assert times[0] == pytest.approx(0.414, abs=0.002)
    assert times[0] == pytest.approx(times[1], abs=0.002)
    assert travel[0] == pytest.approx(travel[1], rel=0.01)


def test_the_step_response_matches_the_ideal_model():
    """The paper's step through the controller core: both engines meet it, and their speed traces differ
    by less than 1 % of the step."""
    scenario = load_scenario(find_scenario("step"))
    ideal = run_closed_loop(scenario.duration, scenario_reference(scenario), scenario=scenario)
    multibody = run_closed_loop(scenario.duration, scenario_reference(scenario), scenario=scenario,
                                engine=mujoco_simulator)
    m = step_response(multibody.t, multibody.velocity_true, multibody["velocity_ref"])
    assert m.settle_time_s <= 1.5 and m.overshoot_pct < 10.0 and m.steady_state_error_pct < 2.0
    assert np.max(np.abs(multibody.velocity_true - ideal.velocity_true)) < 1e-3
    assert np.max(np.abs(multibody.pitch_true - ideal.pitch_true)) < 1e-3
    assert multibody.traction.lift_events == 0 and multibody.traction.slip_events == 0


def test_with_realistic_sensors_it_still_balances_and_steps():
    scenario = load_scenario(find_scenario("step"))
    trace = run_closed_loop(scenario.duration, scenario_reference(scenario), scenario=scenario,
                            sim=sensor_preset("realistic"), engine=mujoco_simulator, seed=3)
    assert not trace.fallen
    assert trace.velocity_true[-200:].mean() == pytest.approx(0.1, abs=0.005)


def test_a_hard_turn_unloads_the_inner_wheel_where_the_ideal_model_keeps_both_down():
    """A 3 rad/s yaw-rate step at 1.5 m/s (the controller's limits): MuJoCo's inner wheel leaves the floor
    for tens of milliseconds while the tyres take up the turn, which the ideal model (no roll, wheels glued)
    can only report as a friction demand past mu N. Neither falls; both end on the commanded motion."""

    def reference(t, _sim):
        return (1.5 if t > 0.5 else 0.0, 3.0 if t > 4.0 else 0.0)

    ideal = run_closed_loop(6.0, reference)
    multibody = run_closed_loop(6.0, reference, engine=mujoco_simulator)
    assert ideal.traction.lift_events == 0 and ideal.traction.slip_events >= 1
    assert multibody.traction.lift_events >= 1 and multibody.traction.lifted_samples >= 3
    for trace in (ideal, multibody):
        assert not trace.fallen
        assert trace.velocity_true[-1] == pytest.approx(1.5, abs=0.01)
        assert trace.yaw_rate_true[-1] == pytest.approx(3.0, abs=0.02)


def test_on_ice_the_ideal_model_only_reports_slip_where_mujocos_robot_slips_and_falls():
    """A 1 m/s step on mu = 0.03 (mu N = 2 N per wheel): the speed ramp asks more. The ideal model,
    wheels glued, flags the slip and carries on to 1 m/s; in MuJoCo the tyres slide, the balance is lost."""

    def reference(t, _sim):
        return (1.0 if t > 0.5 else 0.0, 0.0)

    ice = {"traction.friction": 0.03}
    ideal = run_closed_loop(5.0, reference, sim=ice)
    multibody = run_closed_loop(5.0, reference, sim=ice, engine=mujoco_simulator)
    assert not ideal.fallen and ideal.velocity_true[-1] == pytest.approx(1.0, abs=0.01)
    assert ideal.traction.slipping_samples > 200 and ideal.traction.lift_events == 0
    assert multibody.traction.slip_events >= 1
    assert multibody.fallen


@pytest.mark.parametrize("name", ["static", "dynamic_target", "dynamic_obstacles"])
def test_the_navigation_scenarios_reach_their_targets(name):
    scenario = load_scenario(find_scenario(name))
    reached: dict[str, float] = {}

    def stop(sim) -> bool:
        a = sim.assess()
        if a is not None and a.target_reached:
            reached["t"] = sim.time
            return True
        return False

    trace = run_closed_loop(scenario.duration, PlannerReference(), scenario=scenario, stop=stop,
                            engine=mujoco_simulator, seed=scenario.seed)
    assert not trace.fallen
    assert "t" in reached, f"{name}: target not reached in {scenario.duration} s"
    assert math.isfinite(reached["t"])


def test_a_contact_stiffer_than_two_steps_allow_is_refused_by_name():
    with pytest.raises(ConfigError, match=r"'mujoco.contact_time_constant' = 0.001: must be at least two physics"):
        MujocoSimulator(ROBOT, {**SETTINGS, "mujoco.contact_time_constant": 0.001}, None, 0)
