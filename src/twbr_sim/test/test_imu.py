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


def test_noise_is_seeded_and_off_by_default():
    p = robot_params()
    s = dyn.initial_state(pitch=0.05)
    ds = dyn.state_derivative(p, s, 0, 0)
    quiet = ImuModel(defaults(IMU_SPECS), seed=1)
    assert quiet.read(p, s, ds) == ideal_reading(p, s, ds)
    noisy = {**defaults(IMU_SPECS), "imu.gyro_noise_std": 0.01, "imu.accel_bias_std": 0.2}
    a = [ImuModel(noisy, seed=5).read(p, s, ds) for _ in range(2)]
    b = ImuModel(noisy, seed=6).read(p, s, ds)
    assert a[0] == a[1]
    assert a[0] != b


def test_gyro_noise_has_the_requested_spread():
    p = robot_params()
    s = dyn.initial_state()
    ds = dyn.state_derivative(p, s, 0, 0)
    model = ImuModel({**defaults(IMU_SPECS), "imu.gyro_noise_std": 0.02}, seed=2)
    rates = np.array([model.read(p, s, ds).angular_velocity[1] for _ in range(4000)])
    assert rates.std() == pytest.approx(0.02, rel=0.05)
    assert abs(rates.mean()) < 0.002
    assert not math.isclose(rates[0], rates[1])
