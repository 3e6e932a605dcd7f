"""The fused target (target.py): it follows a walking target from noisy range and bearing, keeps it on its
prediction while it is hidden, uncertainty growing, and stops extrapolating after max_extrapolation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from twbr_common.params import defaults
from twbr_tracker.target import TARGET_SPECS, TargetFilter


def follow(seconds: float, hidden: tuple[float, float] = (math.inf, math.inf), seed: int = 1):
    """A target from (5, 0) walking at 0.4 m/s along y, looked at every 0.1 s from the origin with 5 cm and 1
    degree of noise; yields (t, estimate, truth)."""
    rng = np.random.default_rng(seed)
    f = TargetFilter(defaults(TARGET_SPECS))
    for k in range(round(seconds * 10) + 1):
        t = k / 10
        tx, ty = 5.0, 0.4 * t
        if not hidden[0] <= t < hidden[1]:
            f.measure(t, math.hypot(tx, ty) + 0.05 * rng.normal(), math.atan2(ty, tx) + math.radians(1) * rng.normal(),
                      0.0, 0.0, 0.0, 0.0)
        yield t, f.estimate(t), (tx, ty)


def test_a_walking_target_is_where_it_is_and_as_fast():
    late = [(e, truth) for t, e, truth in follow(10.0) if t >= 2.0]
    errors = [math.hypot(e.x - x, e.y - y) for e, (x, y) in late]
    assert math.sqrt(np.mean(np.square(errors))) < 0.06
    assert np.mean([e.vy for e, _ in late]) == pytest.approx(0.4, abs=0.03)


def test_a_hidden_target_is_predicted_with_growing_uncertainty_then_held():
    run = {round(t, 1): e for t, e, _ in follow(12.0, hidden=(5.0, 12.1))}
    assert run[6.5].y == pytest.approx(0.4 * 6.5, abs=0.15)  # 1.5 s hidden: still on its line
    assert run[6.5].position_variance > run[5.0].position_variance
    assert run[10.0].y == pytest.approx(run[7.0].y, abs=1e-9)  # 2 s after the last look: held where it went
    assert run[10.0].vx == run[10.0].vy == 0.0 and run[10.0].since_seen == pytest.approx(5.1, abs=0.01)
    assert run[12.0].position_variance > run[10.0].position_variance


def test_nothing_before_the_first_look():
    f = TargetFilter(defaults(TARGET_SPECS))
    assert f.estimate(1.0) is None


def test_before_the_first_look_the_prior_stands_still_growing_uncertain_and_the_first_look_replaces_it():
    cfg = {**defaults(TARGET_SPECS), "target.prior_x": 4.0, "target.prior_y": -1.0, "target.prior_std": 0.1}
    f = TargetFilter(cfg)
    first, later = f.estimate(0.0), f.estimate(3.0)
    assert (first.x, first.y, first.vx, first.vy) == (4.0, -1.0, 0.0, 0.0) and first.position_variance == pytest.approx(0.01)
    assert (later.x, later.y) == (4.0, -1.0) and later.position_variance > 1.0 and later.since_seen == math.inf
    f.measure(3.0, 2.0, 0.0, 0.0, 0.0, 0.0, 0.0)  # seen 2 m ahead of the origin, 2.2 m from the prior
    seen = f.estimate(3.0)
    assert (seen.x, seen.y) == (2.0, 0.0) and seen.position_variance == pytest.approx(0.05 ** 2)
    f.reset()  # a restart forgets the sighting, not the mission's prior
    assert (f.estimate(5.0).x, f.estimate(5.0).position_variance) == (4.0, pytest.approx(0.01))
