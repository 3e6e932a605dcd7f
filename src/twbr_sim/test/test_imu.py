import math

import numpy as np
import pytest

from twbr_common.params import defaults
from twbr_sim import dynamics as dyn
from twbr_sim.imu import IMU_SPECS, ImuModel, ideal_reading
from twbr_sim.robot_params import robot_params


def reading(s, cmd=(0.0, 0.0)):
    p = robot_params()
    return ideal_reading(p, s, dyn.state_derivative(p, s, *cmd))


def test_upright_at_rest_reads_gravity_up():
    r = reading(dyn.initial_state())
    assert r.linear_acceleration == pytest.approx((0.0, 0.0, 9.81))
    assert r.angular_velocity == pytest.approx((0.0, 0.0, 0.0))


def test_pitch_sign_matches_the_contract():
    s = dyn.initial_state(pitch=0.1)
    s[dyn.S_THD] = 0.4
    r = reading(s)
    assert r.pitch == 0.1
    assert r.angular_velocity[1] == 0.4  # rotation about +y: leaning further forward
    # The accelerometer sees the robot falling forward: its x axis tips down, and the axle is pushed back.
    assert r.linear_acceleration[0] < 0.0


def test_turning_adds_centripetal_acceleration_and_yaw_rate():
    s = dyn.initial_state()
    s[dyn.S_XD], s[dyn.S_PSID] = 1.0, 0.5
    r = reading(s)
    assert r.linear_acceleration[1] == pytest.approx(0.5)
    assert r.angular_velocity[2] == pytest.approx(0.5)


def model(seed=1, rate=200.0, **settings):
    return ImuModel({**defaults(IMU_SPECS), **settings}, seed, rate)


def test_noise_is_seeded_and_off_by_default():
    p = robot_params()
    s = dyn.initial_state(pitch=0.05)
    ds = dyn.state_derivative(p, s, 0, 0)
    assert model().read(p, s, ds) == ideal_reading(p, s, ds)
    noisy = {"imu.gyro_noise_std": 0.01, "imu.accel_bias_std": 0.2}
    a = [model(5, **noisy).read(p, s, ds) for _ in range(2)]
    b = model(6, **noisy).read(p, s, ds)
    assert a[0] == a[1]
    assert a[0] != b


def test_gyro_noise_has_the_requested_spread():
    p = robot_params()
    s = dyn.initial_state()
    ds = dyn.state_derivative(p, s, 0, 0)
    imu = model(2, **{"imu.gyro_noise_std": 0.02})
    rates = np.array([imu.read(p, s, ds).angular_velocity[1] for _ in range(4000)])
    assert rates.std() == pytest.approx(0.02, rel=0.05)
    assert abs(rates.mean()) < 0.002
    assert not math.isclose(rates[0], rates[1])


def test_bias_walk_spreads_as_the_square_root_of_time():
    """A rate random walk of w rad/s/sqrt(s) leaves the bias with std w*sqrt(t) after t seconds: over 400
    IMUs, 4 s at 200 Hz, the spread is 0.01*2 = 0.02 rad/s (within 15 %), and 0.01 after 1 s."""
    p = robot_params()
    s = dyn.initial_state()
    ds = dyn.state_derivative(p, s, 0, 0)
    at_1, at_4 = [], []
    for seed in range(400):
        imu = model(seed, **{"imu.gyro_bias_walk": 0.01})
        rates = [imu.read(p, s, ds).angular_velocity[1] for _ in range(800)]
        at_1.append(rates[199])
        at_4.append(rates[799])
    assert np.std(at_1) == pytest.approx(0.01, rel=0.15)
    assert np.std(at_4) == pytest.approx(0.02, rel=0.15)


def test_delay_reports_the_reading_of_earlier_states():
    """5 ms at 200 Hz is one publish period: each reading is that of the state before (the first repeats)."""
    p = robot_params()
    imu = model(**{"imu.delay": 0.005})
    states = [dyn.initial_state(pitch=0.01 * k) for k in range(4)]
    pitches = [imu.read(p, s, dyn.state_derivative(p, s, 0, 0)).pitch for s in states]
    assert pitches == pytest.approx([0.0, 0.0, 0.01, 0.02])


def test_raw_mode_is_a_setting_the_reading_keeps_its_rates():
    """Raw mode drops only the orientation (sim_node publishes none, REP 145): a pitching, turning robot's
    body rates and specific force read the same, noise and all."""
    assert model(**{"imu.raw": True}).raw and not model().raw
    p = robot_params()
    s = dyn.initial_state(pitch=0.05)
    s[dyn.S_THD] = 0.3
    s[dyn.S_PSID] = -0.2
    ds = dyn.state_derivative(p, s, 0.05, -0.02)
    noisy = {"imu.gyro_noise_std": 0.01, "imu.accel_noise_std": 0.05}
    raw, full = model(4, **noisy, **{"imu.raw": True}).read(p, s, ds), model(4, **noisy).read(p, s, ds)
    assert list(raw.angular_velocity) == list(full.angular_velocity)
    assert list(raw.linear_acceleration) == list(full.linear_acceleration)
    assert abs(raw.angular_velocity[1] - 0.3) < 0.05 and abs(raw.angular_velocity[2] + 0.2) < 0.05
