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


def test_latency_record_stays_the_same_size_however_long_the_run():
    # Before: a list of every exchange's latency (about 28 MB an hour at 200 Hz in realtime mode).
    import numpy as np

    from twbr_sim.run_report import LatencyRecord

    rng = np.random.default_rng(3)
    samples = rng.gamma(4.0, 0.25e-3, size=200_000)  # ~1 ms, a tail past 2 ms
    record = LatencyRecord()
    size = record.counts.nbytes
    for s in samples:
        record.add(float(s))
    record.add(5.0)  # a stall past the histogram: the overflow bin
    assert record.counts.nbytes == size < 1_000_000 and record.count == len(samples) + 1
    assert record.quantile_ms(0.5) == pytest.approx(np.median(samples) * 1e3, abs=0.002)
    assert record.quantile_ms(0.99) == pytest.approx(np.percentile(samples, 99) * 1e3, abs=0.002)
    assert "median" in record.text() and LatencyRecord().text() == ""
