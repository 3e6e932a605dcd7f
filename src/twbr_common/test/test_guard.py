import math

from twbr_common.geometry import quaternion_from_rpy, rpy_from_quaternion, wrap_angle
from twbr_common.guard import InputGuard, Verdict
from twbr_common.timing import Decimator


def test_guard_admits_fresh_finite_ordered_messages():
    g = InputGuard(timeout=0.1)
    assert g.is_stale(0.0)
    assert g.offer(0.0, (1.0, 2.0), now=0.0) is Verdict.ACCEPTED  # stamp 0 is real at time 0
    assert not g.is_stale(0.05)
    assert g.is_stale(0.11)


def test_guard_refuses_bad_messages_and_counts_them():
    g = InputGuard(timeout=0.1)
    assert g.offer(1.0, (1.0,), now=1.0) is Verdict.ACCEPTED
    assert g.offer(1.01, (math.nan,), now=1.01) is Verdict.NON_FINITE
    assert g.offer(1.01, (math.inf,), now=1.01) is Verdict.NON_FINITE
    assert g.offer(0.0, (1.0,), now=1.02) is Verdict.UNSTAMPED
    assert g.offer(0.5, (1.0,), now=1.02) is Verdict.STALE
    assert g.offer(0.99, (1.0,), now=1.02) is Verdict.OUT_OF_ORDER
    assert g.rejected_total == 5
    assert g.last_stamp == 1.0
    assert g.is_stale(1.2)  # refused messages never refresh the stream


def test_wrap_angle_is_in_half_open_interval():
    assert wrap_angle(math.pi) == math.pi
    assert wrap_angle(-math.pi) == math.pi
    assert wrap_angle(3 * math.pi / 2) == -math.pi / 2
    assert abs(wrap_angle(4 * math.pi + 0.1) - 0.1) < 1e-12


def test_quaternion_round_trip():
    for rpy in [(0.0, 0.3, 1.0), (0.0, -0.2, -2.5), (0.1, 0.0, 3.0)]:
        back = rpy_from_quaternion(*quaternion_from_rpy(*rpy))
        assert all(abs(a - b) < 1e-12 for a, b in zip(back, rpy, strict=True))
    # Positive pitch tips the body's z axis forward (+x): REP-103 rotation about +y.
    x, y, z, w = quaternion_from_rpy(0.0, 0.2, 0.0)
    zx = 2 * (x * z + w * y)
    assert zx > 0


def test_decimator_fires_once_per_period_without_bursts():
    d = Decimator(10.0)
    fired = [t / 1000 for t in range(0, 1000) if d.due(t / 1000)]
    assert len(fired) == 10
    d2 = Decimator(10.0)
    assert d2.due(0.0) and not d2.due(0.05) and d2.due(0.1)
    assert d2.due(5.0) and not d2.due(5.01)  # a stall does not queue up a burst
