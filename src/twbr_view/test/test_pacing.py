"""The live viewer's pacing: a round's CPU time stays within cpu_budget of one core."""

from __future__ import annotations

import pytest

pytest.importorskip("rerun", reason="rerun-sdk is not installed (the viewer is optional)")

from twbr_view.viewer_node import round_delay


def test_a_cheap_round_keeps_the_draw_rate_and_a_dear_one_waits_for_its_budget():
    assert round_delay(0.001, 1.0 / 30.0, 0.1) == pytest.approx(1.0 / 30.0)
    assert round_delay(0.008, 1.0 / 30.0, 0.1) == pytest.approx(0.08)  # 8 ms of CPU at 10 %: 12.5 rounds/s

