"""sincos agrees with libm to 2 ulp where the robot's angles live, and fails loudly on bad input."""

import math

import numpy as np
import pytest

from twbr_common.trig import sincos


@pytest.mark.parametrize("bound", [1e-6, 0.5, math.pi, 50.0, 1e5])
def test_sincos_is_within_two_ulp_of_libm(bound):
    rng = np.random.default_rng(7)
    for x in rng.uniform(-bound, bound, 20000):
        s, c = sincos(float(x))
        assert abs(s - math.sin(x)) <= 2 * math.ulp(max(abs(math.sin(x)), 1e-300)) + 1e-17 * (abs(s) < 1e-3)
        assert abs(c - math.cos(x)) <= 2 * math.ulp(max(abs(math.cos(x)), 1e-300)) + 1e-17 * (abs(c) < 1e-3)


@pytest.mark.parametrize("k", range(-8, 9))
def test_every_quadrant_has_the_right_signs(k):
    for x in (k * math.pi / 2, k * math.pi / 2 + 0.3, k * math.pi / 2 - 0.3, k * math.pi / 4):
        s, c = sincos(x)
        assert s == pytest.approx(math.sin(x), abs=1e-15)
        assert c == pytest.approx(math.cos(x), abs=1e-15)


@pytest.mark.parametrize("x", [math.nan, math.inf, -math.inf])
def test_non_finite_angles_give_nan(x):
    s, c = sincos(x)
    assert math.isnan(s) and math.isnan(c)
