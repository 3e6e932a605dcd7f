"""The pitch estimator on synthetic raw readings: what a robot's IMU would send."""

import math

import numpy as np
import pytest

from twbr_control.controller_params import resolve
from twbr_control.estimator import PitchEstimator, uses_estimator

G = 9.81
RATE = 200.0


def accel(pitch, forward_acceleration=0.0):
    """Specific force along body x and z of an IMU pitched by `pitch` on an axle accelerating forward."""
    c, s = math.cos(pitch), math.sin(pitch)
    return c * forward_acceleration - s * G, s * forward_acceleration + c * G


def run(pitch_of_t, seconds, bias=0.0, velocity_of_t=lambda t: 0.0, acceleration_of_t=lambda t: 0.0,
        noise=(0.0, 0.0), seed=0, **settings):
    est = PitchEstimator(resolve({"estimator.calibration_time": 0.0, **settings}))
    rng = np.random.default_rng(seed)
    out = []
    for k in range(round(seconds * RATE) + 1):
        t = k / RATE
        dt = 1e-6
        rate = (pitch_of_t(t + dt) - pitch_of_t(t - dt)) / (2 * dt)
        ax, az = accel(pitch_of_t(t), acceleration_of_t(t))
        gyro = rate + bias + noise[0] * rng.normal()
        ax += noise[1] * rng.normal()
        az += noise[1] * rng.normal()
        out.append((t, pitch_of_t(t), *est.update(t, gyro, ax, az, velocity_of_t(t))))
    return np.array(out), est


def test_starts_from_the_accelerometer_and_follows_a_swing():
    rows, _ = run(lambda t: 0.1 * math.sin(2 * math.pi * t), 3.0)
    assert rows[0, 2] == pytest.approx(0.0, abs=1e-12)
    assert np.abs(rows[:, 2] - rows[:, 1]).max() < 1e-3


def test_converges_from_a_wrong_initial_pitch():
    """Started from a wrong pitch (a reading taken mid-bump), the accelerometer pulls the estimate in with
    the filter's time constant: within 2 % of the initial error after 4 time constants."""
    est = PitchEstimator(resolve({"estimator.time_constant": 0.5, "estimator.bias_time_constant": 0.0,
                                  "estimator.calibration_time": 0.0}))
    est.update(0.0, 0.0, *accel(0.2), 0.0)  # the bump
    errors = []
    for k in range(1, 401):
        pitch, _ = est.update(k / RATE, 0.0, *accel(0.0), 0.0)
        errors.append(pitch)
    assert errors[0] == pytest.approx(0.2, rel=0.02)
    assert abs(errors[round(4 * 0.5 * RATE) - 1]) < 0.02 * 0.2


def test_rejects_a_gyro_bias():
    """0.02 rad/s of gyro bias (about 1 deg/s, a poorly calibrated MEMS gyro): without bias estimation the
    pitch settles bias*tau = 0.01 rad off; with it, within 0.5 mrad after 60 s, and the bias is learnt."""
    level = lambda t: 0.05  # noqa: E731
    plain, _ = run(level, 60.0, bias=0.02, **{"estimator.time_constant": 0.5, "estimator.bias_time_constant": 0.0})
    assert plain[-1, 2] - 0.05 == pytest.approx(0.02 * 0.5, rel=0.05)
    rows, est = run(level, 60.0, bias=0.02, **{"estimator.time_constant": 0.5})
    assert abs(rows[-1, 2] - 0.05) < 5e-4
    assert est.bias == pytest.approx(0.02, abs=1e-3)
    assert rows[-1, 3] == pytest.approx(0.0, abs=1e-3)  # the pitch rate too


def test_forward_acceleration_is_not_taken_for_a_lean():
    """Upright, accelerating at 1 m/s^2 for 2 s: the accelerometer alone reads a 0.1 rad lean; with the
    odometry's speed the estimate stays within 0.01 rad of upright."""
    accelerating = lambda t: 1.0 if 0.5 <= t < 2.5 else 0.0  # noqa: E731
    speed = lambda t: min(max(t - 0.5, 0.0), 2.0)  # noqa: E731
    rows, _ = run(lambda t: 0.0, 4.0, velocity_of_t=speed, acceleration_of_t=accelerating)
    assert np.abs(rows[:, 2]).max() < 0.01
    blind, _ = run(lambda t: 0.0, 4.0, acceleration_of_t=accelerating)  # no speed: the lean shows
    assert np.abs(blind[:, 2]).max() > 0.08


def test_noise_is_filtered():
    """MPU-6050 noise (config/sensors_realistic.yaml: 5.7e-4 rad/s, 0.026 m/s^2 per reading): the estimate's RMS
    error is < 1 mrad, against 2.7 mrad for the accelerometer alone."""
    rows, _ = run(lambda t: 0.05 * math.sin(t), 20.0, noise=(5.7e-4, 0.026), seed=3)
    rms = math.sqrt(np.mean((rows[RATE.__int__():, 2] - rows[RATE.__int__():, 1]) ** 2))
    assert rms < 1e-3


def test_which_readings_are_estimated():
    assert uses_estimator("auto", True) and not uses_estimator("auto", False)
    assert uses_estimator("estimator", False)
    assert not uses_estimator("orientation", True)


def test_start_up_calibration_learns_the_bias_of_a_robot_standing_still():
    """0.5 s on its stand: the gyro's mean is its bias (0.02 rad/s here, to 1 mrad/s with MPU-6050 noise) and
    the accelerometer's mean its pitch; the controller is told to hold meanwhile."""
    est = PitchEstimator(resolve({}))
    rng = np.random.default_rng(1)
    flags = []
    for k in range(200):
        ax, az = accel(0.03)
        est.update(k / RATE, 0.02 + 5.7e-4 * rng.normal(), ax + 0.026 * rng.normal(), az + 0.026 * rng.normal(), 0.0)
        flags.append(est.calibrating)
    assert all(flags[:99]) and not any(flags[101:])
    assert est.bias == pytest.approx(0.02, abs=1e-3)
    assert est.update(1.0, 0.02, *accel(0.03), 0.0)[0] == pytest.approx(0.03, abs=1e-3)


def test_a_moving_robot_ends_the_calibration_at_once():
    """A controller restarted on a robot that is already balancing must not hold zero torque for 0.5 s."""
    est = PitchEstimator(resolve({}))
    est.update(0.0, 0.0, *accel(0.0), 0.0)
    assert est.calibrating
    est.update(0.005, 0.3, *accel(0.0015), 0.0)  # it rotates at 0.3 rad/s
    assert not est.calibrating
