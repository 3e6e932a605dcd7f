"""Property tests of the controller core: finite in, finite out; limits hold; mirrored turns."""

import math

from hypothesis import given, settings
from hypothesis import strategies as st

from twbr_common.params import defaults
from twbr_control.cascade import CascadeController
from twbr_control.controller_params import CONTROL_SPECS

CFG = defaults(CONTROL_SPECS)
finite = st.floats(-1e6, 1e6)
sample = st.tuples(finite, finite, finite, finite, st.floats(-3.0, 3.0), finite)


@settings(max_examples=200, deadline=None)
@given(st.lists(sample, min_size=1, max_size=30), st.floats(1e-4, 0.2))
def test_finite_inputs_give_finite_torques_inside_the_limits(samples, dt):
    c = CascadeController(CFG)
    for k, (v_ref, w_ref, v, w, pitch, rate) in enumerate(samples):
        out = c.compute(k * dt, v_ref, w_ref, v, w, pitch, rate)
        for x in (out.left_torque, out.right_torque, out.common_torque, out.differential_torque, out.pitch_ref):
            assert math.isfinite(x)
        assert abs(out.left_torque) <= CFG["max_wheel_torque"] and abs(out.right_torque) <= CFG["max_wheel_torque"]
        assert abs(out.pitch_ref) <= CFG["max_pitch_ref"] + abs(CFG["pitch_offset"])
        assert abs(out.velocity_ref) <= CFG["max_velocity_ref"] and abs(out.yaw_rate_ref) <= CFG["max_yaw_rate_ref"]


@settings(max_examples=100, deadline=None)
@given(st.lists(st.tuples(st.floats(-2, 2), st.floats(-3, 3), st.floats(-2, 2), st.floats(-3, 3),
                          st.floats(-0.5, 0.5), st.floats(-5, 5)), min_size=1, max_size=20))
def test_a_mirrored_turn_swaps_the_wheels(samples):
    a, b = CascadeController(CFG), CascadeController(CFG)
    for k, (v_ref, w_ref, v, w, pitch, rate) in enumerate(samples):
        oa = a.compute(k * 0.005, v_ref, w_ref, v, w, pitch, rate)
        ob = b.compute(k * 0.005, v_ref, -w_ref, v, -w, pitch, rate)
        assert math.isclose(oa.left_torque, ob.right_torque, abs_tol=1e-9)
        assert math.isclose(oa.right_torque, ob.left_torque, abs_tol=1e-9)
