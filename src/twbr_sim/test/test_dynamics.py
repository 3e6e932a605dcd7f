"""Tests that would catch a wrong equation in the dynamics and motor model (figures from dynamics.md)."""

import math

import numpy as np
import pytest

from twbr_sim import dynamics as dyn
from twbr_sim.robot_params import (
    P_D,
    P_L,
    P_R,
    P_VMAX,
    robot_params,
    top_wheel_speed,
    wheel_torque_limit,
)

H = 1e-3


@pytest.fixture
def p():
    return robot_params()


@pytest.fixture
def p_frictionless():
    return robot_params({"wheel_friction": 0.0})


def run(p, s, cmd=(0.0, 0.0), seconds=1.0, h=H):
    work = dyn.new_work()
    dyn.simulate(p, s, cmd[0], cmd[1], h, round(seconds / h), work)
    return s


def linearised_eigenvalues(p):
    s0 = dyn.initial_state()
    idx = [dyn.S_X, dyn.S_XD, dyn.S_TH, dyn.S_THD, dyn.S_PSI, dyn.S_PSID]
    a = np.zeros((6, 6))
    for j, k in enumerate(idx):
        e = 1e-7
        sp, sm = s0.copy(), s0.copy()
        sp[k] += e
        sm[k] -= e
        a[:, j] = ((dyn.state_derivative(p, sp, 0, 0) - dyn.state_derivative(p, sm, 0, 0)) / (2 * e))[idx]
    return np.sort(np.linalg.eigvals(a).real)


def test_energy_is_conserved_without_friction_and_torque(p_frictionless):
    # A large swing about the hanging position with forward and yaw motion: every coupling term is exercised.
    s = dyn.initial_state(pitch=math.pi - 0.6)
    s[dyn.S_XD], s[dyn.S_PSID], s[dyn.S_THD] = 0.3, 0.8, 0.5
    e0 = dyn.mechanical_energy(p_frictionless, s)
    drift = 0.0
    for _ in range(100):  # 10 s
        run(p_frictionless, s, seconds=0.1)
        drift = max(drift, abs(dyn.mechanical_energy(p_frictionless, s) - e0))
    # Stated drift: RK4 at 1 kHz keeps it below 1e-8 J over 10 s against |E| ~ 35 J.
    assert drift < 1e-8
    assert s[dyn.S_IL] == 0.0 and s[dyn.S_IR] == 0.0  # zero command: the driver keeps the current at zero


def test_friction_dissipates_energy(p):
    s = dyn.initial_state(pitch=math.pi - 0.6)
    e0 = dyn.mechanical_energy(p, s)
    run(p, s, seconds=5.0)
    assert dyn.mechanical_energy(p, s) < e0 - 1e-3


def test_linearised_eigenvalues_about_upright_match_reference(p, p_frictionless):
    np.testing.assert_allclose(linearised_eigenvalues(p_frictionless), [-7.5717, 0, 0, 0, 0, 7.5717], atol=1e-3)
    np.testing.assert_allclose(
        linearised_eigenvalues(p), [-7.7651, -0.2708, -0.1332, 0.0, 0.0, 7.3896], atol=1e-3
    )


def test_unstable_pole_has_the_closed_form(p_frictionless):
    p = p_frictionless
    a = p[4] + 2 * p[5] + 2 * p[6] / p[P_R] ** 2
    b = p[4] * p[P_L]
    c2 = p[9] + p[4] * p[P_L] ** 2
    expected = math.sqrt(a * p[4] * 9.81 * p[P_L] / (a * c2 - b * b))
    assert linearised_eigenvalues(p)[-1] == pytest.approx(expected, abs=1e-5)


def fall_time(p, h=H):
    s = dyn.initial_state(pitch=0.05)
    work = dyn.new_work()
    t = 0.0
    while True:
        prev = abs(s[dyn.S_TH])
        dyn.rk4_step(p, s, 0.0, 0.0, h, work)
        t += h
        if abs(s[dyn.S_TH]) >= 0.5:
            return t - h + h * (0.5 - prev) / (abs(s[dyn.S_TH]) - prev), s


@pytest.mark.parametrize(("frictionless", "reference"), [(True, 0.4071), (False, 0.4137)])
def test_unactuated_fall_reaches_half_a_radian_at_reference_time(p, p_frictionless, frictionless, reference):
    t, s = fall_time(p_frictionless if frictionless else p)
    assert t == pytest.approx(reference, abs=0.002)
    assert s[dyn.S_X] == pytest.approx(-0.10, abs=0.01)  # the axle rolls back as the body falls forward


def test_equal_torques_give_no_yaw(p):
    s = dyn.initial_state(pitch=0.02)
    run(p, s, cmd=(2.0, 2.0), seconds=0.3)
    assert s[dyn.S_PSI] == 0.0 and s[dyn.S_PSID] == 0.0
    assert s[dyn.S_YC] == 0.0
    assert s[dyn.S_X] != 0.0


def test_opposite_torques_turn_in_place(p):
    s = dyn.initial_state()
    run(p, s, cmd=(-1.0, 1.0), seconds=1.0)
    assert s[dyn.S_PSID] > 0.5  # counter-clockwise: right wheel forward
    assert abs(s[dyn.S_XC]) < 1e-12 and abs(s[dyn.S_YC]) < 1e-12 and abs(s[dyn.S_X]) < 1e-12
    assert s[dyn.S_TH] == 0.0
    assert s[dyn.S_GR] == pytest.approx(-s[dyn.S_GL])


def test_no_lateral_slip_and_wheels_roll(p):
    rng = np.random.default_rng(3)
    s = dyn.initial_state(pitch=math.pi - 0.3)  # hanging, so the run can be long and lively
    work = dyn.new_work()
    for _ in range(400):
        dyn.rk4_step(p, s, rng.uniform(-3, 3), rng.uniform(-3, 3), H, work)
        ds = dyn.state_derivative(p, s, 0.0, 0.0)
        lateral = -ds[dyn.S_XC] * math.sin(s[dyn.S_PSI]) + ds[dyn.S_YC] * math.cos(s[dyn.S_PSI])
        assert abs(lateral) < 1e-12
    r, d = p[P_R], p[P_D]
    assert r * (s[dyn.S_GR] - s[dyn.S_GL]) / d == pytest.approx(s[dyn.S_PSI], abs=1e-9)
    assert r * (s[dyn.S_GR] + s[dyn.S_GL]) / 2 == pytest.approx(s[dyn.S_X], abs=1e-9)
    assert abs(s[dyn.S_PSI]) > 0.01


def test_wheel_gets_the_motor_torque_not_the_command(p):
    s = dyn.initial_state()
    run(p, s, cmd=(5.0, 5.0), seconds=H)
    torque = dyn.wheel_torques(p, s)[0]
    # The current rises with time constant L/(R + k_i) = 0.8 ms: after 1 ms it is 1 - e^-1.25 of the way.
    assert 0.5 * 5.0 < torque < 0.8 * 5.0
    run(p, s, cmd=(5.0, 5.0), seconds=0.01)
    assert dyn.wheel_torques(p, s)[0] == pytest.approx(5.0, rel=0.01)


def test_driver_current_limit_caps_the_torque(p):
    s = dyn.initial_state()
    run(p, s, cmd=(100.0, 100.0), seconds=0.02)
    limit = wheel_torque_limit(p)
    assert limit == pytest.approx(15.0)
    assert dyn.wheel_torques(p, s)[0] == pytest.approx(limit, rel=0.02)
    v = dyn.driver_voltage(p, 100.0, s[dyn.S_IL], 0.0)
    assert abs(v) <= p[P_VMAX]


def test_driver_voltage_is_clamped(p):
    assert dyn.driver_voltage(p, 15.0, 0.0, 100.0) == p[P_VMAX]
    assert dyn.driver_voltage(p, -15.0, 0.0, -100.0) == -p[P_VMAX]


def test_back_emf_limits_the_top_wheel_speed():
    # With the centre of mass on the axle the body cannot fall, so full torque spins the wheels against
    # the body until back-EMF eats the supply voltage.
    p = robot_params({"com_height": 0.0})
    s = dyn.initial_state()
    run(p, s, cmd=(15.0, 15.0), seconds=3.0)
    relative = (s[dyn.S_XD] / p[P_R]) - s[dyn.S_THD]
    assert top_wheel_speed(p) == pytest.approx(24.0)
    assert relative == pytest.approx(24.0, rel=0.01)
    assert relative < 24.0
    # At the top speed the motor can no longer push current: the torque collapses.
    assert abs(dyn.wheel_torques(p, s)[0]) < 0.5


def test_stiff_motor_is_sub_stepped_not_blown_up():
    p = robot_params({"armature_inductance": 1e-5})  # electrical pole (R + k_i)/L = 180000 1/s: h*lambda = 180 at 1 kHz
    assert dyn.substeps(p, H) >= 90
    s = dyn.initial_state()
    run(p, s, cmd=(5.0, 5.0), seconds=0.05)
    assert np.all(np.isfinite(s))
    assert dyn.wheel_torques(p, s)[0] == pytest.approx(5.0, rel=0.01)


def test_default_motor_needs_no_sub_steps(p):
    assert dyn.substeps(p, H) == 1
    assert dyn.substeps(robot_params({"current_loop_gain": 0.0}), H) == 1


@pytest.mark.parametrize("n", [7, 2 * dyn.LANES + 7])
def test_batch_steps_equal_single_steps(p, n):
    # Whole lane groups and a partial one; in the second group one robot needs two RK4 sub-steps per step
    # (a faster electrical pole), so that group steps robot by robot.
    rng = np.random.default_rng(0)
    params = np.tile(p, (n, 1)) * rng.uniform(0.8, 1.2, (n, p.size))
    if n > dyn.LANES:
        params[dyn.LANES + 3] = robot_params({"armature_inductance": 0.0006})
        assert dyn.substeps(params[dyn.LANES + 3], H) == 2
    states = np.zeros((n, dyn.N_STATE))
    states[:, dyn.S_TH] = rng.uniform(-0.1, 0.1, n)
    commands = rng.uniform(-2, 2, (n, 2))
    expected = states.copy()
    for i in range(n):
        run(params[i], expected[i], cmd=tuple(commands[i]), seconds=0.2)
    dyn.step_batch(params, states, commands, H, 200)
    np.testing.assert_array_equal(states, expected)
