"""Property tests of the dynamics core: finite in, finite out; the motors' limits hold; mirror symmetry."""

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from twbr_sim import dynamics as dyn
from twbr_sim.robot_params import robot_params, wheel_torque_limit

P = robot_params()
LIMIT = wheel_torque_limit(P)
H = 1e-3

speed = st.floats(-2.0, 2.0)
state_strategy = st.tuples(
    speed,  # x_dot
    st.floats(-0.7, 0.7),  # pitch
    st.floats(-5.0, 5.0),  # pitch rate
    st.floats(-math.pi, math.pi),  # yaw
    st.floats(-3.0, 3.0),  # yaw rate
    st.floats(-15.0, 15.0), st.floats(-15.0, 15.0),  # currents
)
torque = st.floats(-1e6, 1e6)


def make_state(v, pitch, pitch_rate, yaw, yaw_rate, i_l, i_r) -> np.ndarray:
    s = dyn.initial_state(yaw=yaw, pitch=pitch)
    s[dyn.S_XD], s[dyn.S_THD], s[dyn.S_PSID], s[dyn.S_IL], s[dyn.S_IR] = v, pitch_rate, yaw_rate, i_l, i_r
    return s


@settings(max_examples=200, deadline=None)
@given(state_strategy, torque, torque)
def test_any_command_gives_a_finite_state_and_torques_inside_the_motor_limit(state, left, right):
    s = make_state(*state)
    work = dyn.new_work()
    for _ in range(20):
        dyn.rk4_step(P, s, left, right, H, work)
    assert np.all(np.isfinite(s))
    t_l, t_r = dyn.wheel_torques(P, s)
    assert abs(t_l) <= LIMIT * 1.0001 and abs(t_r) <= LIMIT * 1.0001


@settings(max_examples=100, deadline=None)
@given(state_strategy, st.floats(-15.0, 15.0), st.floats(-15.0, 15.0))
def test_mirrored_turn_gives_the_mirrored_motion(state, left, right):
    """Swapping the wheels' commands mirrors the robot: yaw, yaw rate and y change sign, the rest stays."""
    v, pitch, pitch_rate, _, yaw_rate, i_l, i_r = state
    a = make_state(v, pitch, pitch_rate, 0.0, yaw_rate, i_l, i_r)
    b = make_state(v, pitch, pitch_rate, 0.0, -yaw_rate, i_r, i_l)
    wa, wb = dyn.new_work(), dyn.new_work()
    for _ in range(50):
        dyn.rk4_step(P, a, left, right, H, wa)
        dyn.rk4_step(P, b, right, left, H, wb)
    for i in (dyn.S_X, dyn.S_XD, dyn.S_TH, dyn.S_THD, dyn.S_XC):
        assert math.isclose(a[i], b[i], rel_tol=1e-9, abs_tol=1e-9)
    for i in (dyn.S_PSI, dyn.S_PSID, dyn.S_YC):
        assert math.isclose(a[i], -b[i], rel_tol=1e-9, abs_tol=1e-9)
    assert math.isclose(a[dyn.S_GL], b[dyn.S_GR], rel_tol=1e-9, abs_tol=1e-9)
