"""sim_node's closing line (exchanges, wall time, real-time factor, control latency): written and read here.

The runner, the benchmarks and the tests read these figures from the simulator's log; keeping the format
and its parser in one module means a change to one cannot silently break the others.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

_RATES = re.compile(r"(\d+) exchanges in ([\d.]+) s wall: ([\d.]+) exchanges/s, real-time factor ([\d.]+)")
_LATENCY = re.compile(r"median ([\d.]+) ms, p99 ([\d.]+) ms over (\d+) exchanges")


def rates_text(exchanges: int, wall_s: float, sim_s: float) -> str:
    return (f"; {exchanges} exchanges in {wall_s:.3f} s wall: {exchanges / wall_s:.1f} exchanges/s,"
            f" real-time factor {sim_s / wall_s:.2f}")


def latency_text(median_ms: float, p99_ms: float, count: int) -> str:
    return (f"; command latency (state publish -> its command received) median {median_ms:.3f} ms,"
            f" p99 {p99_ms:.3f} ms over {count} exchanges")


@dataclass(frozen=True)
class RunReport:
    exchanges: int
    wall_s: float  # from the first step to the last
    exchanges_per_s: float
    real_time_factor: float
    latency_median_ms: float | None
    latency_p99_ms: float | None


def parse_run_report(log: str) -> RunReport | None:
    """The figures of sim_node's closing line in `log`, or None when it did not get to step."""
    rates = _RATES.search(log)
    if rates is None:
        return None
    latency = _LATENCY.search(log)
    return RunReport(
        int(rates.group(1)), float(rates.group(2)), float(rates.group(3)), float(rates.group(4)),
        float(latency.group(1)) if latency else None, float(latency.group(2)) if latency else None,
    )


class LatencyRecord:
    """Latencies in a fixed histogram (1 µs bins up to 100 ms, then one overflow bin): memory stays the same
    however long a realtime simulator runs, and the median and p99 are exact to the bin."""

    BIN_S = 1e-6
    BINS = 100_000

    def __init__(self) -> None:
        self.counts = np.zeros(self.BINS + 1, dtype=np.int64)
        self.count = 0

    def add(self, seconds: float) -> None:
        self.counts[min(max(int(seconds / self.BIN_S), 0), self.BINS)] += 1
        self.count += 1

    def quantile_ms(self, q: float) -> float:
        """The q-quantile [ms], as the upper edge of the bin it falls in (the overflow bin: 100 ms)."""
        if not self.count:
            raise ValueError("no latencies recorded")
        rank = max(1, int(np.ceil(q * self.count)))
        index = int(np.searchsorted(np.cumsum(self.counts), rank))
        return (min(index, self.BINS - 1) + 1) * self.BIN_S * 1e3

    def text(self) -> str:
        return latency_text(self.quantile_ms(0.5), self.quantile_ms(0.99), self.count) if self.count else ""
