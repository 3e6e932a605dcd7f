import numpy as np
import pytest

from twbr_sim import dynamics as dyn
from twbr_sim.robot_params import robot_params
from twbr_sim.traction import (
    N_OUTPUTS,
    TF_DEMAND_LEFT,
    TF_DEMAND_RIGHT,
    TF_NORMAL_LEFT,
    TF_NORMAL_RIGHT,
    traction_flags,
    wheel_loads,
)


def loads(s, cmd=(0.0, 0.0), p=None):
    p = robot_params() if p is None else p
    out = np.zeros(N_OUTPUTS)
    wheel_loads(p, s, dyn.state_derivative(p, s, *cmd), out)
    return out


def test_at_rest_each_wheel_carries_half_the_weight_and_needs_no_friction():
    out = loads(dyn.initial_state())
    assert out[TF_NORMAL_LEFT] == pytest.approx(0.5 * 14.0 * 9.81)
    assert out[TF_NORMAL_RIGHT] == pytest.approx(out[TF_NORMAL_LEFT])
    assert out[TF_DEMAND_LEFT] == pytest.approx(0.0, abs=1e-9)
    assert traction_flags(out, 0.8) == (False, False)


def test_a_left_turn_loads_the_outer_right_wheel():
    s = dyn.initial_state()
    s[dyn.S_XD], s[dyn.S_PSID] = 1.0, 1.0
    out = loads(s)
    assert out[TF_NORMAL_RIGHT] > out[TF_NORMAL_LEFT] > 0.0
    # 12 kg at 0.4 m and 2 kg at 0.1 m, 1 m/s^2 sideways, 0.4 m track: 12.5 N moved across.
    assert out[TF_NORMAL_RIGHT] - out[TF_NORMAL_LEFT] == pytest.approx(2 * 12.5, rel=1e-6)


def test_a_fast_spin_lifts_the_inner_wheel():
    s = dyn.initial_state()
    s[dyn.S_XD], s[dyn.S_PSID] = 3.0, 4.0  # 12 m/s^2 sideways
    lifted, _ = traction_flags(loads(s), 0.8)
    assert lifted


def test_torque_from_rest_slips_on_ice_not_on_concrete():
    s = dyn.initial_state()
    s[dyn.S_IL] = s[dyn.S_IR] = 1.0  # 1 N*m on each wheel: about 10 N of ground force each
    out = loads(s)
    assert out[TF_DEMAND_LEFT] == pytest.approx(out[TF_DEMAND_RIGHT])
    assert 5.0 < out[TF_DEMAND_LEFT] < 10.0  # less what spinning up the wheel itself takes
    assert traction_flags(out, 0.8) == (False, False)
    assert traction_flags(out, 0.05) == (False, True)
    s[dyn.S_IL] = s[dyn.S_IR] = 10.0  # full torque: 100 N asked of 69 N of normal force
    assert traction_flags(loads(s), 0.8) == (False, True)
