"""The compiled Hungarian assignment gives scipy's optimum, and never matches beyond the gate."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment

from twbr_tracker.assignment import assign


def matched(cost: np.ndarray, gate: float) -> np.ndarray:
    out = np.empty(cost.shape[0], dtype=np.int64)
    assign(cost, gate, out)
    return out


@pytest.mark.parametrize("shape", [(1, 1), (3, 3), (4, 7), (7, 4), (12, 12), (1, 5), (6, 1)])
def test_the_total_cost_is_scipy_s_optimum(shape):
    rng = np.random.default_rng(sum(shape))
    for _ in range(30):
        cost = rng.uniform(0.0, 10.0, shape)
        match = matched(cost, np.inf)
        rows, cols = linear_sum_assignment(cost)
        assert sum(1 for j in match if j >= 0) == min(shape)
        assert len(set(match[match >= 0])) == min(shape)  # one-to-one
        ours = sum(cost[i, j] for i, j in enumerate(match) if j >= 0)
        assert ours == pytest.approx(cost[rows, cols].sum(), abs=1e-9)


def test_nothing_is_matched_beyond_the_gate_and_the_rest_stays_optimal():
    # track 0 near detection 1, track 1 near nothing, track 2 near detection 0
    cost = np.array([[5.0, 0.2, 4.0], [3.0, 3.5, 9.0], [0.4, 6.0, 2.5]])
    assert list(matched(cost, 1.0)) == [1, -1, 0]
    ungated = matched(cost, np.inf)
    best = min(sum(cost[i, j] for i, j in enumerate(p)) for p in itertools.permutations(range(3)))
    assert sum(cost[i, j] for i, j in enumerate(ungated)) == pytest.approx(best)
    assert list(matched(np.zeros((0, 3)), 1.0)) == []
    assert list(matched(np.zeros((2, 0)), 1.0)) == [-1, -1]


def test_a_gated_pair_never_displaces_two_good_ones():
    """Greedy nearest-first would give track 0 detection 0 (0.5) and leave track 1 without its only one."""
    cost = np.array([[0.5, 0.6], [0.55, 5.0]])
    assert list(matched(cost, 1.0)) == [1, 0]
