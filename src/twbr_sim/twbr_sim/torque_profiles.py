"""Fixed wheel-torque profiles for smoke tests, demos and benchmarks (no controller needed)."""

from __future__ import annotations


def demo_torques(t: float, pitch: float, pitch_rate: float) -> tuple[float, float]:
    """0-3 s: a stiff pitch PD holds the robot up, with a differential torque that turns it from 1 s to 2 s
    and a common push from 2 s to 3 s; after 3 s no torque, so it falls and the simulator reports it."""
    if t >= 3.0:
        return 0.0, 0.0
    balance = 30.0 * pitch + 4.0 * pitch_rate
    turn = 0.3 if 1.0 <= t < 2.0 else 0.0
    push = 0.5 if 2.0 <= t < 3.0 else 0.0
    return balance - turn + push, balance + turn + push


PROFILES = ("echo", "demo")
