"""The cascade's structure: signs, allocation with balance first, limits, fall cut-off, enable, time."""

import itertools
import math

import numpy as np
import pytest

from twbr_common.params import ConfigError, defaults
from twbr_control.cascade import CascadeController
from twbr_control.controller_params import CONTROL_SPECS, resolve
from twbr_control.state_sync import Action, StateSync

DT = 0.005


def make(**overrides):
    return CascadeController({**defaults(CONTROL_SPECS), **overrides})


def without_jerk(**overrides):
    """The hold and the rate limits alone, as the tests of each measure them (reference_jerk.* off)."""
    return make(**{"reference_jerk.yaw_rate": 0.0, "reference_jerk.velocity": 0.0, **overrides})


def test_forward_lean_is_caught_by_driving_the_wheels_forward():
    out = make().compute(0.0, 0.0, 0.0, velocity=0.0, yaw_rate=0.0, pitch=0.05, pitch_rate=0.0)
    assert out.left_torque > 0 and out.right_torque > 0 and out.left_torque == out.right_torque


def test_speeding_up_asks_for_a_forward_lean_and_first_drives_the_wheels_back():
    out = make().compute(0.0, 0.5, 0.0, velocity=0.0, yaw_rate=0.0, pitch=0.0, pitch_rate=0.0)
    assert out.pitch_ref > 0
    assert out.common_torque < 0  # the non-minimum-phase start: roll back to lean forward


def test_positive_yaw_rate_reference_drives_the_right_wheel_harder():
    out = make().compute(0.0, 0.0, 1.0, velocity=0.0, yaw_rate=0.0, pitch=0.0, pitch_rate=0.0)
    assert out.right_torque > 0 > out.left_torque
    assert out.differential_torque == pytest.approx(out.right_torque)


def test_balance_keeps_priority_over_turning_at_the_torque_limit():
    c = make(**{"max_wheel_torque": 2.0, "yaw_rate.kp": 100.0})
    out = c.compute(0.0, 0.0, 3.0, velocity=0.0, yaw_rate=0.0, pitch=0.03, pitch_rate=0.0)
    assert abs(out.common_torque) < 2.0
    assert max(abs(out.left_torque), abs(out.right_torque)) == pytest.approx(2.0)
    assert out.torque_saturated
    # The common part is whole: left + right = 2 common.
    assert out.left_torque + out.right_torque == pytest.approx(2 * out.common_torque)


def test_references_are_clipped_and_a_stale_cmd_vel_zeroes_them():
    c = make(max_velocity_ref=0.5, max_yaw_rate_ref=1.0)
    out = c.compute(0.0, 9.0, -9.0, 0.0, 0.0, 0.0, 0.0)
    assert (out.velocity_ref, out.yaw_rate_ref) == (0.5, -1.0)
    out = c.compute(DT, 9.0, -9.0, 0.0, 0.0, 0.0, 0.0, cmd_vel_stale=True)
    assert (out.velocity_ref, out.yaw_rate_ref) == (0.0, 0.0) and out.cmd_vel_stale


def test_fall_cuts_torque_until_reenabled():
    c = make(fall_pitch=0.5)
    out = c.compute(0.0, 0.0, 0.0, 0.0, 0.0, 0.6, 0.0)
    assert out.fallen and out.left_torque == 0.0 == out.right_torque
    out = c.compute(DT, 0.0, 0.0, 0.0, 0.0, 0.1, 0.0)  # stood up again: still cut until enabled
    assert out.fallen and out.left_torque == 0.0
    c.set_enabled(True)
    out = c.compute(2 * DT, 0.0, 0.0, 0.0, 0.0, 0.1, 0.0)
    assert not out.fallen and out.left_torque > 0


def test_a_new_run_forgets_the_old_runs_fall_but_not_a_disable():
    """A restarted simulator's upright robot must not stand still on the old run's fall (issue 34)."""
    c = make(fall_pitch=0.5)
    assert c.compute(40.0, 0.3, 0.0, 0.0, 0.0, 0.6, 0.0).fallen
    c.reset()  # a plain reset (loops only) keeps the latch
    assert c.compute(40.0 + DT, 0.3, 0.0, 0.0, 0.0, 0.01, 0.0).fallen
    c.new_run()
    out = c.compute(0.0, 0.3, 0.0, 0.0, 0.0, 0.01, 0.0)
    assert not out.fallen and out.enabled and abs(out.left_torque) > 0.0
    c.set_enabled(False)
    c.new_run()
    out = c.compute(DT, 0.3, 0.0, 0.0, 0.0, 0.01, 0.0)
    assert not out.enabled and out.left_torque == 0.0  # disabled by the user stays disabled


def test_disabled_means_zero_torque_and_fresh_loops_on_enable():
    c = make()
    for k in range(50):
        c.compute(k * DT, 0.3, 0.0, 0.0, 0.0, 0.01, 0.0)
    assert c.velocity_pid.integral != 0.0
    c.set_enabled(False)
    out = c.compute(50 * DT, 0.3, 0.0, 0.0, 0.0, 0.01, 0.0)
    assert out.left_torque == 0.0 == out.right_torque and not out.enabled
    c.set_enabled(True)
    assert c.velocity_pid.integral == 0.0


def test_sample_time_comes_from_the_stamps():
    c = make()
    assert c.compute(1.0, 0, 0, 0, 0, 0, 0).dt == pytest.approx(DT)  # first sample: the nominal period
    assert c.compute(1.007, 0, 0, 0, 0, 0, 0).dt == pytest.approx(0.007)
    assert c.compute(2.0, 0, 0, 0, 0, 0, 0).dt == pytest.approx(DT)  # a gap past max_sample_gap
    assert c.compute(0.5, 0, 0, 0, 0, 0, 0).dt == pytest.approx(DT)  # time went back: fresh start


def test_state_sync_pairs_equal_stamps_and_repeats_a_reoffered_state():
    sync = StateSync(rate=200.0, tolerance=0.001)
    assert sync.offer_odom(0.0, 0.1, 0.0)[0] is Action.WAIT
    action, state = sync.offer_imu(0.0, 0.02, 0.0)
    assert action is Action.COMPUTE and state.pitch == 0.02 and state.velocity == 0.1
    assert sync.offer_odom(0.0, 0.1, 0.0)[0] is Action.REPEAT
    # A new odom with the old imu is not a state; the matching imu completes it.
    assert sync.offer_odom(0.005, 0.2, 0.0)[0] is Action.WAIT
    action, state = sync.offer_imu(0.005, 0.03, 0.0)
    assert action is Action.COMPUTE and state.stamp == 0.005 and state.velocity == 0.2


def test_state_sync_decimates_fast_states_to_the_control_rate():
    sync = StateSync(rate=200.0, tolerance=0.0)
    computed = []
    for k in range(1000):  # 1 s of states at 1 kHz
        t = k * 0.001
        sync.offer_odom(t, 0.0, 0.0)
        if sync.offer_imu(t, 0.0, 0.0)[0] is Action.COMPUTE:
            computed.append(t)
    gaps = [round(b - a, 6) for a, b in itertools.pairwise(computed[1:])]
    assert set(gaps) == {0.005}  # 200 Hz once on schedule
    assert len(computed) in (200, 201)


def test_retune_changes_gains_from_the_next_sample_and_keeps_the_loops_memory():
    from twbr_common.params import defaults
    from twbr_control.controller_params import CONTROL_SPECS

    cfg = defaults(CONTROL_SPECS)
    a, b = CascadeController(cfg), CascadeController(cfg)
    for i in range(20):
        for ctl in (a, b):
            ctl.compute(i * 0.005, 0.3, 0.2, 0.1, 0.0, 0.01, 0.0)
    memory = a.k.copy()
    a.retune({**cfg, "pitch.kp": 2 * cfg["pitch.kp"]})
    assert np.array_equal(a.k, memory)  # no reset: integrals and filters carry on
    out_a = a.compute(0.1, 0.3, 0.2, 0.1, 0.0, 0.01, 0.0)
    out_b = b.compute(0.1, 0.3, 0.2, 0.1, 0.0, 0.01, 0.0)
    assert out_a.common_torque != out_b.common_torque
    with pytest.raises(ValueError):
        a.retune({**cfg, "rate": 100.0})


def test_a_cmd_vel_takes_effect_from_the_state_after_it_whatever_the_order_of_arrival():
    from twbr_control.state_sync import VelocityCommand

    # The planner's answer to the state at t = 1.0 arrives before, or after, that state is computed.
    early, late = VelocityCommand(timeout=0.5), VelocityCommand(timeout=0.5)
    early.offer(0.95, 0.1, 0.0)
    late.offer(0.95, 0.1, 0.0)
    assert early.at(0.995) == late.at(0.995) == (0.1, 0.0, False)
    early.offer(1.0, 0.3, 0.2)
    first_early = early.at(1.0)
    first_late = late.at(1.0)
    late.offer(1.0, 0.3, 0.2)
    assert first_early == first_late == (0.1, 0.0, False)  # the state of its own instant: the previous one
    assert early.at(1.005) == late.at(1.005) == (0.3, 0.2, False)
    # Stale once the one in effect is older than the timeout; one received but not yet in effect does not
    # freshen a state, and nothing is in effect before the first one or after a reset.
    assert early.at(1.5) == (0.3, 0.2, False) and early.at(1.505)[2]
    fresh = VelocityCommand(timeout=0.5)
    fresh.offer(0.0, 0.4, 0.0)
    assert fresh.at(0.0) == (0.0, 0.0, True)
    early.reset()
    assert early.at(2.0) == (0.0, 0.0, True)
    # The rule is one kernel, which the batch engine calls compiled: the same answers both ways.
    from twbr_common.timing import takes_effect, takes_effect_interpreted

    for command_stamp, state_stamp in ((1.0, 1.005), (1.0, 1.0), (1.005, 1.0), (math.nan, 1.0), (-math.inf, 0.0)):
        assert takes_effect(command_stamp, state_stamp) == takes_effect_interpreted(command_stamp, state_stamp) \
            == (command_stamp < state_stamp)


def test_a_rate_limited_yaw_rate_step_moves_the_torque_in_tenths():
    """reference_rate.yaw_rate 8 rad/s^2 at 200 Hz: a 0.4 rad/s step is reached in 10 samples in a straight line,
    so the yaw-rate loop's proportional kick is a tenth of the unlimited one per sample."""
    plain, ramped = without_jerk(), without_jerk(**{"reference_rate.yaw_rate": 8.0})
    for c in (plain, ramped):
        c.compute(0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    kick = plain.compute(0.005, 0.0, 0.4, 0.0, 0.0, 0.0, 0.0).differential_torque
    outs = [ramped.compute(0.005 * k, 0.0, 0.4, 0.0, 0.0, 0.0, 0.0) for k in range(1, 13)]
    shaped = [o.yaw_rate_ref_shaped for o in outs]
    assert shaped[:10] == pytest.approx([0.04 * k for k in range(1, 11)])
    assert shaped[10:] == pytest.approx([0.4, 0.4])
    assert all(o.yaw_rate_ref == 0.4 for o in outs)  # the command itself, as received
    steps = np.diff([0.0] + [o.differential_torque for o in outs[:10]])
    assert steps.max() < 0.11 * kick
    again = [ramped.compute(0.065 + 0.005 * k, 0.0, 0.2, 0.0, 0.0, 0.0, 0.0).yaw_rate_ref_shaped for k in range(10)]
    assert again[0] == pytest.approx(0.36) and again[-1] == pytest.approx(0.2)


def test_a_command_stream_within_the_rate_limit_passes_unchanged():
    """A planner's speed commands change by at most its max_acceleration (0.06 m/s^2: 0.003 m/s per 50 ms): under
    the controller's 0.36 m/s^2 each reaches the loop within two 5 ms samples, so the stream is not delayed."""
    c = without_jerk()
    for k in range(200):
        reference = 0.003 * (k // 10)
        shaped = c.compute(0.005 * k, reference, 0.0, 0.0, 0.0, 0.0, 0.0).velocity_ref_shaped
        if k % 10 >= 1:
            assert shaped == pytest.approx(reference)


def test_a_reset_starts_the_ramps_from_zero():
    c = without_jerk(**{"reference_rate.velocity": 1.5})
    for k in range(100):
        c.compute(0.005 * k, 0.3, 0.0, 0.0, 0.0, 0.0, 0.0)
    assert c.compute(0.5, 0.3, 0.0, 0.0, 0.0, 0.0, 0.0).velocity_ref_shaped == 0.3
    c.set_enabled(True)
    assert c.compute(0.505, 0.3, 0.0, 0.0, 0.0, 0.0, 0.0).velocity_ref_shaped == pytest.approx(1.5 * 0.005)


# The hold's lines as first shipped: the whole gap to the commands closed within one interval (the geometry
# below is exact then); the default spreads it over reference_hold.catch_up intervals (the tests after them).
CATCH_UP_AT_ONCE = {"reference_hold.catch_up": 1.0}


def _planner_stream(controller, commands, period=0.05, rate=200.0):
    """A 20 Hz planner's commands as the controller node applies them: each from the sample after it, held
    until the next; returns the outputs of every sample."""
    outs, per = [], round(period * rate)
    for i, w in enumerate(commands):
        since = (i * per + 1) / rate
        for j in range(per):
            t = (i * per + 1 + j) / rate
            outs.append(controller.compute(t, 0.0, w, 0.0, 0.0, 0.0, 0.0, command_stamp=since))
    return outs


def test_a_planner_ramp_reaches_the_yaw_rate_loop_as_a_ramp_not_a_staircase():
    """The paper's planner slews omega by 0.05 rad/s per 50 ms (1 rad/s^2): held, each command steps the
    reference and the proportional term kicks the differential torque 20 times a second; continued along the
    stream's slope, the reference is the ramp itself, with no lag behind the planner's own line."""
    ramp = [0.05 * i for i in range(1, 21)]
    held = _planner_stream(without_jerk(**{**CATCH_UP_AT_ONCE, "reference_hold.yaw_rate": 0.0}), ramp)
    smooth = _planner_stream(without_jerk(**{**CATCH_UP_AT_ONCE, "reference_hold.yaw_rate": 1.25,
                                     "reference_smoothing.yaw_rate": 0.0}), ramp)
    t = np.array([o.stamp for o in smooth])
    shaped = np.array([o.yaw_rate_ref_shaped for o in smooth])
    # the line through the commands where they apply (after one interval catching up with the first)
    line = 0.15 + 1.0 * (t - t[20])
    assert np.abs(shaped[20:] - line[20:]).max() < 1e-9
    # held: kp * 0.05 rad/s at each command; continued: kp * 1 rad/s^2 * 5 ms per sample (and the integral's share)
    kicks = [np.abs(np.diff([o.differential_torque for o in outs[20:]])).max() for outs in (held, smooth)]
    assert kicks[0] > 0.9 * 3.429 * 0.05 and kicks[1] < 0.15 * kicks[0]


def test_where_the_planner_stops_turning_the_reference_bends_back_without_a_step():
    """A ramp that stops: the reference overshoots the last command by at most one slope times the interval and
    comes back to it along a straight line within one more interval; no sample-to-sample change is larger than
    the ramp's own."""
    commands = [0.05 * i for i in range(1, 11)] + [0.5] * 6
    outs = _planner_stream(without_jerk(**{**CATCH_UP_AT_ONCE, "reference_hold.yaw_rate": 1.25,
                                   "reference_smoothing.yaw_rate": 0.0}), commands)
    shaped = np.array([o.yaw_rate_ref_shaped for o in outs])
    assert shaped.max() <= 0.55 + 1e-9
    assert shaped[-30:] == pytest.approx(np.full(30, 0.5))
    assert np.abs(np.diff(shaped[20:])).max() <= 1.0 / 200.0 + 1e-9  # once the first interval has caught up


def _velocity_stream(controller, commands, period=0.05, rate=200.0, limit=None):
    """As _planner_stream, for v; `limit(t)`: what a collision monitor lets through at t (None: nothing)."""
    outs, per = [], round(period * rate)
    for i, v in enumerate(commands):
        since = (i * per + 1) / rate
        for j in range(per):
            t = (i * per + 1 + j) / rate
            ref = v if limit is None else min(v, limit(t))
            speed = 0.06 * max(t - period, 0.0)  # a robot on the planner's ramp, not on its staircase
            outs.append(controller.compute(t, ref, 0.0, speed, 0.0, 0.0, 0.0, command_stamp=since))
    return outs


def test_a_planner_accelerating_reaches_the_velocity_loop_as_a_ramp_without_a_20_hz_sawtooth():
    """Issue 35: the planner raises v by 0.003 m/s per 50 ms (0.06 m/s^2); held, each command steps v_ref and the
    velocity loop's proportional term moves the wheel torques in a 20 Hz sawtooth; continued along the slope,
    v_ref is the ramp itself."""
    ramp = [0.003 * i for i in range(1, 41)]
    held = _velocity_stream(without_jerk(**{**CATCH_UP_AT_ONCE, "reference_hold.velocity": 0.0}), ramp)
    smooth = _velocity_stream(without_jerk(**{**CATCH_UP_AT_ONCE, "reference_hold.velocity": 0.15,
                                      "reference_smoothing.velocity": 0.0}), ramp)
    t = np.array([o.stamp for o in smooth])
    shaped = np.array([o.velocity_ref_shaped for o in smooth])
    line = 0.009 + 0.06 * (t - t[20])
    assert np.abs(shaped[20:] - line[20:]).max() < 1e-9
    steps = [np.abs(np.diff([o.common_torque for o in outs[20:]])) for outs in (held, smooth)]
    assert steps[1].max() < 0.3 * steps[0].max()
    assert steps[1].max() < 1.5 * np.median(steps[1])  # no kick at the commands: every sample alike


def test_a_collision_monitor_lowering_v_between_commands_is_not_held_back():
    """The controller node's collision monitor lowers v_ref sample by sample; the hold must not keep the
    planner's line until its next command."""
    c = make(**{"reference_hold.velocity": 0.15, "reference_rate.velocity": 0.0})
    outs = _velocity_stream(c, [0.003 * i for i in range(1, 21)], limit=lambda t: 0.04 if t > 0.8 else 1.0)
    for o in outs:
        if o.stamp > 0.8:
            assert o.velocity_ref_shaped <= 0.04 + 1e-12


def test_a_step_faster_than_the_hold_slope_and_a_silent_planner_pass_at_once():
    """A jump the planner's slew limit cannot make (a step asked for) is not extrapolated: no overshoot of the
    reference; a stale cmd_vel zeroes the reference at once, whatever ramp was under way."""
    c = make(**{"reference_hold.yaw_rate": 1.25})
    outs = _planner_stream(c, [0.0, 0.5, 0.5, 0.5])
    shaped = [o.yaw_rate_ref_shaped for o in outs]
    assert max(shaped) == 0.5 and shaped[10] == 0.5
    _planner_stream(c, [0.05 * i for i in range(1, 5)])
    out = c.compute(1.0, 0.0, 0.2, 0.0, 0.0, 0.0, 0.0, cmd_vel_stale=True, command_stamp=0.2)
    assert out.yaw_rate_ref_shaped == 0.0


def test_the_yaw_rate_setpoint_weight_scales_the_proportional_kick_of_a_step():
    full = make(**{"reference_hold.yaw_rate": 0.0}).compute(0.0, 0.0, 0.4, 0.0, 0.0, 0.0, 0.0)
    half = make(**{"reference_hold.yaw_rate": 0.0, "yaw_rate.setpoint_weight": 0.5}).compute(
        0.0, 0.0, 0.4, 0.0, 0.0, 0.0, 0.0)
    kick = 3.429 * 0.4
    assert full.differential_torque == pytest.approx(kick + 0.9293 * 0.4 * 0.005)
    assert half.differential_torque == pytest.approx(0.5 * kick + 0.9293 * 0.4 * 0.005)


def test_the_first_command_from_rest_starts_a_ramp_and_a_large_one_is_a_step():
    """A planner's first turn command (0.05 rad/s, its slew limit from 0) is eased in at the hold's slope
    instead of kicking the differential torque; a first command beyond the hold's reach is obeyed at once."""
    c = without_jerk(**{"reference_hold.yaw_rate": 1.25, "reference_smoothing.yaw_rate": 0.0})
    shaped = [o.yaw_rate_ref_shaped for o in _planner_stream(c, [0.05])]
    assert shaped[0] == 0.0 and shaped[-1] == pytest.approx(0.05)
    assert np.abs(np.diff([0.0, *shaped])).max() <= 1.25 / 200.0 + 1e-9
    big = without_jerk(**{"reference_hold.yaw_rate": 1.25})
    assert _planner_stream(big, [0.5])[0].yaw_rate_ref_shaped == 0.5


def test_where_the_planners_yaw_acceleration_reverses_the_bend_reaches_the_loop_rounded():
    """Issue 35: a planner slewing omega up at 1 rad/s^2 and then down (a weave between obstacles) bends the
    held reference by 2 rad/s^2 from one sample to the next, a jolt of the differential torque (kp * 2 rad/s^2
    * 5 ms on each wheel, ~0.07 N·m in make demo); averaged over reference_smoothing's 0.15 s it bends over 30
    samples instead, and lags the hold's line by half the window on the straight parts."""
    weave = [0.05 * i for i in range(1, 11)] + [0.5 - 0.05 * i for i in range(1, 11)]
    hold = _planner_stream(without_jerk(**{**CATCH_UP_AT_ONCE, "reference_hold.yaw_rate": 1.25,
                                   "reference_smoothing.yaw_rate": 0.0}), weave)
    rounded = _planner_stream(without_jerk(**{**CATCH_UP_AT_ONCE, "reference_hold.yaw_rate": 1.25,
                                      "reference_smoothing.yaw_rate": 0.15}), weave)
    # With the robot not turning (open loop), each sample's torque change is the ramp's own plus the bend's:
    # the bend is the change of that change (on a robot that follows the ramp, all that is left of it).
    jolts = [np.abs(np.diff([o.differential_torque for o in outs[20:]], 2)).max() for outs in (hold, rounded)]
    assert jolts[0] > 0.9 * 3.429 * 2.0 / 200.0  # the bend in one sample
    assert jolts[1] < 0.05 * jolts[0]
    lines = [np.array([o.yaw_rate_ref_shaped for o in outs]) for outs in (hold, rounded)]
    lag = lines[0][60:100] - lines[1][60:100]  # on the way up, the window past the start and short of the bend
    assert lag == pytest.approx(np.full(40, 1.0 * (0.15 - 0.005) / 2.0), abs=1e-9)


def test_smoothing_leaves_steps_and_the_collision_monitors_limit_at_once():
    """Only a planner's ramp is averaged: a step asked for, and the collision monitor lowering v between
    commands, reach the loops at the sample they come, whatever the window."""
    c = make(**{"reference_hold.yaw_rate": 1.25, "reference_smoothing.yaw_rate": 0.3})
    outs = _planner_stream(c, [0.05 * i for i in range(1, 6)] + [1.0] * 3)
    assert outs[50].yaw_rate_ref_shaped == 1.0 and outs[-1].yaw_rate_ref_shaped == 1.0
    c = make(**{"reference_hold.velocity": 0.15, "reference_rate.velocity": 0.0, "reference_smoothing.velocity": 0.3})
    outs = _velocity_stream(c, [0.003 * i for i in range(1, 21)], limit=lambda t: 0.04 if t > 0.8 else 1.0)
    assert all(o.velocity_ref_shaped <= 0.04 + 1e-12 for o in outs if o.stamp > 0.8)


def test_a_smoothing_window_longer_than_the_ring_is_refused_by_name():
    with pytest.raises(ConfigError, match=r"reference_smoothing\.yaw_rate.*at most 64 control periods, 0\.064 s"):
        resolve({"rate": 1000.0, "reference_smoothing.yaw_rate": 0.1})


def test_the_default_hold_follows_a_ramp_without_lag_once_it_has_caught_up():
    """catch_up 3: the gap left by the first command (eased in from 0) closes by a third each interval; the
    ramp itself then reaches the loop, with no step at the commands."""
    ramp = [0.05 * i for i in range(1, 41)]
    outs = _planner_stream(make(**{"reference_hold.yaw_rate": 1.25}), ramp)
    t = np.array([o.stamp for o in outs])
    shaped = np.array([o.yaw_rate_ref_shaped for o in outs])
    line = 0.15 + 1.0 * (t - t[20])  # the line through the commands where they apply
    assert np.abs(shaped[200:] - line[200:]).max() < 1e-3
    assert np.abs(np.diff(shaped[20:])).max() <= 1.25 / 200.0 + 1e-9


def test_where_the_planners_acceleration_reverses_the_default_hold_bends_a_third_more_not_twice():
    """Issue 35: a planner reversing its yaw acceleration (+1 to -1 rad/s^2, a weave) bent the hold's line by
    2 x 2 rad/s^2 in one sample when the gap was closed within one interval, a jolt of the differential
    torque of kp x 4 rad/s^2 x 5 ms = 0.069 N·m; over three intervals the bend is 2 x (1 + 1/3) rad/s^2."""
    weave = [0.05 * i for i in range(1, 21)] + [1.0 - 0.05 * i for i in range(1, 21)]
    bends = {}
    for catch_up in (1.0, 3.0):
        c = without_jerk(**{"reference_hold.yaw_rate": 1.25, "reference_hold.catch_up": catch_up})
        shaped = np.array([o.yaw_rate_ref_shaped for o in _planner_stream(c, weave)])
        bends[catch_up] = np.abs(np.diff(shaped[100:], 2)).max() * 200.0  # [rad/s^2]: the slope's change in a sample
        assert shaped.max() <= 1.0 + 0.05 + 1e-6  # past the turn's top by at most one slope x interval
    assert bends[1.0] == pytest.approx(4.0, abs=1e-6)
    assert bends[3.0] == pytest.approx(2.0 * (1.0 + 1.0 / 3.0), abs=0.02)


def test_a_jerk_limit_spreads_the_weaves_bend_over_samples_and_starts_it_at_once():
    """Issue 35: the default hold bends by 2 x (1 + 1/3) rad/s^2 in one sample where a weave reverses (a jolt of
    kp x 2.67 rad/s^2 x 5 ms = 0.046 N·m); under reference_jerk.yaw_rate 40 rad/s^3 the slope changes by at most
    0.2 rad/s^2 a sample, starts to turn at the sample the hold does, leaves the hold's line by at most
    bend^2 / (2 jerk) = 0.09 rad/s and is back on it within 3 bend / jerk = 0.2 s; the 0.15 s smoothing lags the
    line by 0.07 rad/s all along every ramp instead."""
    weave = [0.05 * i for i in range(1, 21)] + [1.0 - 0.05 * i for i in range(1, 21)]
    lines = {}
    for jerk in (0.0, 40.0):
        c = make(**{"reference_hold.yaw_rate": 1.25, "reference_jerk.yaw_rate": jerk})
        lines[jerk] = np.array([o.yaw_rate_ref_shaped for o in _planner_stream(c, weave)])
    slopes = {jerk: np.diff(line) / DT for jerk, line in lines.items()}
    bends = {jerk: np.abs(np.diff(slope)) for jerk, slope in slopes.items()}
    assert bends[0.0][100:].max() == pytest.approx(2.0 * (1.0 + 1.0 / 3.0), abs=0.02)
    assert bends[40.0].max() <= 40.0 * DT + 1e-6
    first = int(np.argmax(bends[0.0][100:] > 1.0)) + 100  # where the hold reverses
    assert bends[40.0][first] == pytest.approx(40.0 * DT, abs=1e-6)  # at once, as hard as it may
    bend = bends[0.0][first]
    off = np.abs(lines[40.0] - lines[0.0])
    assert off.max() <= bend ** 2 / (2.0 * 40.0) + 1e-3
    assert off[first + int(3.0 * bend / 40.0 / DT):].max() < 1e-6
    # [rad] the heading it costs, at the start from rest and at the top together (the planner steers it back)
    assert np.abs(np.cumsum(lines[40.0] - lines[0.0]) * DT).max() < 0.008


def test_a_jerk_limit_follows_a_ramp_without_lag_and_lets_steps_and_silence_through_at_once():
    ramp = [0.05 * i for i in range(1, 41)]
    free = np.array([o.yaw_rate_ref_shaped for o in _planner_stream(make(**{"reference_jerk.yaw_rate": 0.0}), ramp)])
    limited = np.array([o.yaw_rate_ref_shaped for o in _planner_stream(
        make(**{"reference_jerk.yaw_rate": 40.0}), ramp)])
    assert np.abs(limited[200:] - free[200:]).max() < 1e-3
    c = make(**{"reference_jerk.yaw_rate": 40.0})
    assert max(o.yaw_rate_ref_shaped for o in _planner_stream(c, [0.0, 0.5, 0.5])) == 0.5  # a step asked for
    _planner_stream(c, [0.5 + 0.05 * i for i in range(1, 5)])
    out = c.compute(1.0, 0.0, 0.2, 0.0, 0.0, 0.0, 0.0, cmd_vel_stale=True, command_stamp=0.2)
    assert out.yaw_rate_ref_shaped == 0.0


def test_a_velocity_jerk_limit_brings_the_collision_monitors_braking_within_rate_over_jerk():
    """Under reference_rate.velocity 0.36 m/s^2 and reference_jerk.velocity 2 m/s^3, v_ref lowered by the
    collision monitor turns to braking at the sample the limit comes, brakes at the full rate within (0.06 +
    0.36) / 2 s (2 cm more stopping distance from 0.5 m/s than at once) and stops at 0, not past it."""
    rate, jerk = 0.3621, 2.0
    c = make(**{"reference_hold.velocity": 0.15, "reference_rate.velocity": rate, "reference_jerk.velocity": jerk})
    outs = _velocity_stream(c, [0.003 * i for i in range(1, 41)], limit=lambda t: 0.0 if t > 1.5 else 1.0)
    t = np.array([o.stamp for o in outs])
    shaped = np.array([o.velocity_ref_shaped for o in outs])
    slope = np.diff(shaped) / DT
    assert np.abs(np.diff(slope)).max() <= jerk * DT + 1e-9
    after = np.nonzero(t[1:] > 1.5)[0]
    before = slope[after[0] - 1]  # the planner's 0.06 m/s^2
    assert slope[after[0]] == pytest.approx(before - jerk * DT, abs=1e-9)  # turns at the sample the limit comes
    assert slope[after[0] + math.ceil((before + rate) / (jerk * DT))] == pytest.approx(-rate, abs=1e-9)
    assert shaped[-1] == pytest.approx(0.0, abs=1e-9) and shaped.min() >= -jerk * DT * DT  # at most a sample past


def test_after_the_collision_monitor_lets_go_v_ref_returns_at_the_release_rate_and_a_step_asked_for_does_not():
    """The monitor lowers v_ref to 0.3 m/s while an obstacle is in the way and lets go in one step when it has
    gone; the robot leans into that step (|pitch| 0.045 rad in crowd_crossing at reference_rate.velocity 0.36
    m/s^2): v_ref climbs back at collision_monitor.release_acceleration (0.1 m/s^2) instead. Once it has caught
    up, a step the planner asks for ramps at reference_rate.velocity again."""
    def run(release):
        c = make(**{"collision_monitor.release_acceleration": release})
        outs = _velocity_stream(c, [0.5] * 80, limit=lambda t: 0.3 if 0.5 < t < 1.2 else 1.0)
        t = np.array([o.stamp for o in outs])
        return c, t, np.array([o.velocity_ref_shaped for o in outs])
    for release, rate in ((0.1, 0.1), (0.0, 0.3621)):
        c, t, shaped = run(release)
        rising = np.diff(shaped) / DT
        after = t[1:] > 1.2
        assert rising[after].max() == pytest.approx(rate, abs=1e-6)  # the climb back, at its rate at most
        assert shaped[-1] == pytest.approx(0.5, abs=1e-6)
    # caught up: a step asked for (a new command 0.5 -> 0.6) ramps at reference_rate.velocity
    c, t, shaped = run(0.1)
    outs = [c.compute(4.005 + 0.005 * i, 0.6, 0.0, 0.5, 0.0, 0.0, 0.0, command_stamp=4.005) for i in range(100)]
    step = np.diff([o.velocity_ref_shaped for o in outs]) / DT
    assert step.max() == pytest.approx(0.3621, abs=1e-6)


def test_a_reset_forgets_the_shaped_slopes_so_the_ramps_start_again_from_rest():
    """After a re-enable (or a fall, or time going backwards) the jerk-limited references start from 0 with a
    slope of 0, not along the slope they had before: the first samples move by jerk x dt^2, then 3x, 6x, ..."""
    c = make(**{"reference_jerk.velocity": 2.0, "reference_rate.velocity": 0.3621})
    for k in range(20):  # mid-way into the step's ramp: its slope 0.2 m/s^2 and rising
        c.compute(0.005 * k, 0.3, 0.0, 0.0, 0.0, 0.0, 0.0)
    c.set_enabled(True)
    shaped = [c.compute(0.1 + 0.005 * k, 0.3, 0.0, 0.0, 0.0, 0.0, 0.0).velocity_ref_shaped for k in range(1, 4)]
    step = 2.0 * DT * DT
    assert shaped == pytest.approx([step, 3 * step, 6 * step], rel=1e-9)
