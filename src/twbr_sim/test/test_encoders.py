import math

import numpy as np
import pytest

from twbr_common.params import defaults
from twbr_sim import dynamics as dyn
from twbr_sim.encoders import (
    ENCODER_SPECS,
    J_ANGLE_LEFT,
    J_RATE_LEFT,
    J_RATE_RIGHT,
    J_VELOCITY,
    J_X,
    J_Y,
    J_YAW,
    J_YAW_RATE,
    N_OUTPUTS,
    encoder_sample,
    new_memory,
    settings_vector,
)
from twbr_sim.robot_params import robot_params

RATE = 200.0


def drive(counts, v=0.5, yaw_rate=0.0, seconds=2.0, window=0.02):
    """Roll the wheels kinematically at v [m/s] and yaw_rate [rad/s]; the encoders' outputs per sample."""
    p = robot_params()
    c = settings_vector({**defaults(ENCODER_SPECS), "encoder.counts_per_rev": counts,
                         "encoder.velocity_window": window}, RATE)
    m = new_memory(c)
    s = dyn.initial_state()
    s[dyn.S_XD], s[dyn.S_PSID] = v, yaw_rate
    rows = []
    for k in range(round(seconds * RATE) + 1):
        t = k / RATE
        s[dyn.S_PSI] = yaw_rate * t
        if yaw_rate:
            s[dyn.S_XC] = v / yaw_rate * math.sin(yaw_rate * t)
            s[dyn.S_YC] = v / yaw_rate * (1 - math.cos(yaw_rate * t))
        else:
            s[dyn.S_XC] = v * t
        rate_l, rate_r = dyn.wheel_rates(p, v, yaw_rate)
        s[dyn.S_GL], s[dyn.S_GR] = rate_l * t, rate_r * t
        out = np.zeros(N_OUTPUTS)
        encoder_sample(p, c, m, s, out)
        rows.append(out)
    return np.array(rows), s


def test_exact_by_default():
    rows, s = drive(0)
    assert rows[-1][J_X] == s[dyn.S_XC] and rows[-1][J_VELOCITY] == 0.5


def test_angles_are_whole_counts_and_speed_comes_from_counts():
    rows, _ = drive(1024, v=0.5)
    step = 2 * math.pi / 1024
    angles = rows[:, J_ANGLE_LEFT] / step
    assert np.allclose(angles, np.round(angles))
    # The speed is quantised to one count per window (0.02 s: 0.0307 m/s at r = 0.1 m) and right on average.
    speeds = rows[10:, J_VELOCITY]
    assert np.abs(speeds - 0.5).max() <= 0.1 * step / 0.02 + 1e-9
    assert speeds.mean() == pytest.approx(0.5, abs=0.005)
    assert len(np.unique(np.round(speeds, 9))) >= 2  # it really is quantised, not exact


def test_odometry_dead_reckons_a_circle_within_the_quantisation():
    rows, s = drive(1024, v=0.5, yaw_rate=0.5, seconds=6.0)
    assert math.hypot(rows[-1][J_X] - s[dyn.S_XC], rows[-1][J_Y] - s[dyn.S_YC]) < 0.01
    assert rows[-1][J_YAW] == pytest.approx(s[dyn.S_PSI], abs=0.01)
    assert rows[-20:, J_YAW_RATE].mean() == pytest.approx(0.5, abs=0.05)
    assert rows[-1][J_RATE_RIGHT] > rows[-1][J_RATE_LEFT]
