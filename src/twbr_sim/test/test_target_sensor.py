"""The target detector (target_sensor.py): it measures range and bearing with its noise, only in range, in
view, in sight, and not every time."""

from __future__ import annotations

import math

import numpy as np
import pytest

from twbr_common.params import defaults
from twbr_sim.noise import new_generator
from twbr_sim.target_sensor import TARGET_SENSOR_SPECS, TARGET_SENSOR_STREAM, measure_target, settings_vector

NONE = (np.empty((0, 2)), np.empty(0))


def sensor(**over):
    return settings_vector({**defaults(TARGET_SENSOR_SPECS), **{f"target_sensor.{k}": v for k, v in over.items()}})


def looks(s, tx, ty, obstacles=NONE, n=2000, yaw=0.0, seed=1):
    g = new_generator(seed, TARGET_SENSOR_STREAM)
    out, seen = np.empty(2), []
    for _ in range(n):
        if measure_target(s, g, 0.0, 0.0, yaw, 0.0, tx, ty, obstacles[0], obstacles[1], out):
            seen.append(out.copy())
    return np.array(seen).reshape(-1, 2)


def test_a_target_in_view_is_measured_with_the_sensors_noise_and_dropout():
    seen = looks(sensor(), 3.0, 4.0)  # 5 m away at atan2(4, 3)
    assert len(seen) / 2000 == pytest.approx(0.95, abs=0.015)  # dropout 0.05
    assert np.mean(seen[:, 0]) == pytest.approx(5.0, abs=0.01) and np.std(seen[:, 0]) == pytest.approx(0.05, rel=0.1)
    assert np.mean(seen[:, 1]) == pytest.approx(math.atan2(4, 3), abs=0.002)
    assert np.std(seen[:, 1]) == pytest.approx(math.radians(1.0), rel=0.1)


def test_out_of_range_out_of_view_or_hidden_it_is_not_measured():
    assert len(looks(sensor(), 20.0, 0.0, n=50)) == 0  # beyond max_range 15 m
    forward = sensor(field_of_view=math.pi / 2)
    assert len(looks(forward, -3.0, 0.0, n=50)) == 0 and len(looks(forward, 3.0, 0.0, n=50)) > 40
    assert len(looks(forward, -3.0, 0.0, n=50, yaw=math.pi)) > 40  # the sensor turns with the body
    wall = (np.array([[2.0, 0.1]]), np.array([0.5]))  # a disc across the line of sight
    assert len(looks(sensor(), 4.0, 0.0, wall, n=50)) == 0
    beside = (np.array([[2.0, 1.0]]), np.array([0.5]))
    assert len(looks(sensor(), 4.0, 0.0, beside, n=50)) > 40


def test_the_same_seed_gives_the_same_looks_whatever_was_seen_before():
    a = looks(sensor(), 3.0, 4.0, seed=5)
    b = looks(sensor(), 3.0, 4.0, seed=5)
    assert np.array_equal(a, b)
