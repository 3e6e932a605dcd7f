"""sim_node's closing line reads back as the figures that went into it."""

import pytest

from twbr_sim.run_report import latency_text, parse_run_report, rates_text


def test_closing_line_round_trips():
    line = ("[INFO] [sim_node]: stopped at t = 6.000 s after 6000 steps, 0 lockstep timeouts"
            + rates_text(1200, 2.5, 6.0) + latency_text(2.4663, 6.2601, 1200))
    r = parse_run_report(line)
    assert (r.exchanges, r.wall_s, r.exchanges_per_s, r.real_time_factor) == (1200, 2.5, 480.0, 2.4)
    assert (r.latency_median_ms, r.latency_p99_ms) == pytest.approx((2.466, 6.260), abs=1e-3)


def test_no_stepping_no_report_and_latency_is_optional():
    assert parse_run_report("stopped at t = 0.000 s after 0 steps, 0 lockstep timeouts") is None
    assert parse_run_report("x" + rates_text(10, 1.0, 0.05)).latency_median_ms is None
