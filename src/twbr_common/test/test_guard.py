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


def test_guard_refuses_absurdly_large_values_past_its_limit():
    g = InputGuard(timeout=0.1, limit=100.0)
    assert g.offer(1.0, (100.0, -100.0), now=1.0) is Verdict.ACCEPTED
    assert g.offer(1.01, (1e9, 0.0), now=1.01) is Verdict.IMPLAUSIBLE
    assert g.offer(1.01, (0.0, -100.5), now=1.01) is Verdict.IMPLAUSIBLE
    assert g.last_stamp == 1.0


def test_a_clock_going_back_restarts_the_stream_but_an_old_stamp_alone_does_not():
    g = InputGuard(timeout=0.5)
    assert g.offer(10.0, (1.0,), now=10.0) is Verdict.ACCEPTED
    assert g.offer(9.8, (1.0,), now=10.01) is Verdict.OUT_OF_ORDER  # injected: the clock did not go back
    assert g.clock_jumps == 0
    assert g.offer(0.02, (1.0,), now=0.02) is Verdict.ACCEPTED  # the simulator restarted: so did the clock
    assert g.clock_jumps == 1 and g.last_stamp == 0.02


def test_drop_report_warns_once_per_period_per_stream_with_the_count(monkeypatch):
    from twbr_common import guard as guard_module

    clock = [100.0]
    monkeypatch.setattr(guard_module.time, "monotonic", lambda: clock[0])
    lines: list[str] = []
    report = guard_module.DropReport(lines.append, period=1.0)
    g = InputGuard(timeout=0.1)
    for _ in range(5):
        assert not report.admit(g, "odom", 1.0, (math.nan,), now=1.0)
    report.dropped("imu", "no stamp")  # another stream is not hidden behind odom's throttle
    clock[0] += 1.0
    report.dropped("odom", "no stamp")
    report.dropped("odom", "no stamp")
    clock[0] += 1.0
    report.dropped("odom", "non-finite value")
    assert lines == ["dropped odom: non-finite value", "dropped imu: no stamp",
                     "dropped odom: no stamp; 5 dropped since the last warning: 4 non-finite value, 1 no stamp",
                     "dropped odom: non-finite value; 2 dropped since the last warning: 1 no stamp,"
                     " 1 non-finite value"]
    assert g.rejected_total == 5  # the guard keeps the counts; the report only words them


def test_drop_warning_stays_one_short_line_whatever_the_messages_carried(monkeypatch):
    # Before: the values of each refused command went into its reason, and one warning listed every one of
    # them (14.7 KB lines). The reason is a kind; the values of the triggering message only are shown.
    from twbr_common import guard as guard_module

    clock = [100.0]
    monkeypatch.setattr(guard_module.time, "monotonic", lambda: clock[0])
    lines: list[str] = []
    report = guard_module.DropReport(lines.append, period=1.0)
    for i in range(1000):
        report.dropped("wheel_torque_cmd", "non-finite value", f"left={i}.123456, right=nan, stamp {i}.000 s")
        clock[0] += 0.01
    assert len(lines) == 10
    assert max(map(len, lines)) < 200, max(lines, key=len)
    assert lines[1].endswith("100 dropped since the last warning: 100 non-finite value")


def test_guard_refuses_stamps_ahead_of_the_clock_and_keeps_the_stream():
    # Before: one message stamped with wall time on a sim-time graph was accepted, and every real message
    # after it was refused as out of order (the simulator applied zero torque; the robot fell).
    g = InputGuard(timeout=0.1, future_tolerance=0.006)
    assert g.offer(10.0, (1.0,), now=10.0) is Verdict.ACCEPTED
    for ahead in (1.0, 1000.0, 1.8e9 - 10.0):
        assert g.offer(10.0 + ahead, (1.0,), now=10.0) is Verdict.FUTURE
    assert g.offer(10.005, (1.0,), now=10.0) is Verdict.ACCEPTED  # a state just before its /clock
    assert g.offer(10.01, (1.0,), now=10.01) is Verdict.ACCEPTED  # the stream goes on
    assert g.rejected[Verdict.FUTURE] == 3


def test_future_tolerance_defaults_depend_on_the_clock():
    from twbr_common.guard import (
        SIM_FUTURE_TOLERANCE,
        SLOW_SIM_FUTURE_TOLERANCE,
        WALL_FUTURE_TOLERANCE,
        future_tolerance,
    )

    assert future_tolerance(-1.0, sim_time=True) == SIM_FUTURE_TOLERANCE < 0.01  # under two 200 Hz periods
    assert future_tolerance(-1.0, sim_time=False) == WALL_FUTURE_TOLERANCE == 0.1
    assert future_tolerance(0.3, sim_time=True) == 0.3
    # a node outside the lockstep (tracker_node) takes a few states' slack on sim time, and no more
    assert 0.01 < future_tolerance(-1.0, True, SLOW_SIM_FUTURE_TOLERANCE) == SLOW_SIM_FUTURE_TOLERANCE <= 0.05


def test_streams_restart_together_when_the_clock_goes_back():
    # Before: only the stream that saw the jump restarted; a cmd_vel of the previous run stayed fresh.
    from twbr_common.streams import InputStreams

    restarted: list[int] = []
    streams = InputStreams(lambda _line: None, future_tolerance=0.006)
    streams.add("odom", 0.2)
    cmd = streams.add("cmd_vel", 0.5, require_stamp=False)
    streams.on_restart(lambda: restarted.append(1))
    assert streams.admit("cmd_vel", 30.0, (0.5, 0.0), now=30.0)
    assert streams.admit("odom", 30.0, (0.5, 0.0), now=30.0)
    assert not cmd.is_stale(30.1)
    assert streams.admit("odom", 0.0, (0.0, 0.0), now=0.0)  # the new run's first state, judged afresh
    assert restarted == [1] and streams.restarts == 1
    assert cmd.is_stale(0.0)  # the old run's cmd_vel is gone
    assert streams.admit("odom", 0.005, (0.0, 0.0), now=0.005)


def test_decimator_restarts_its_schedule_when_time_goes_back():
    # Before: the planner's schedule stayed at the old run's time, and it never planned again.
    d = Decimator(20.0)
    assert [d.due(t / 200.0) for t in range(0, 21)].count(True) == 3  # 0, 0.05, 0.1
    assert d.due(0.0)  # a restarted simulator
    assert not d.due(0.005) and d.due(0.05)


def test_would_be_due_answers_as_due_without_taking_the_instant():
    peek, take = Decimator(20.0), Decimator(20.0)
    times = [t / 200.0 for t in range(0, 41)] + [0.0, 0.005, 0.05]  # then a restarted simulator
    for t in times:
        answer = peek.would_be_due(t)
        assert answer == peek.would_be_due(t)  # asking again changes nothing
        assert answer == take.due(t)
        if answer:
            peek.due(t)


def test_the_stamp_is_judged_before_the_values_and_arrays_are_judged_whole():
    """A flood of 5,000-obstacle arrays with bad stamps is refused without reading the values; an array's
    values are judged as the same numbers in a list are."""
    import numpy as np

    g = InputGuard(0.5, limit=1e5, future_tolerance=0.1)
    bad = np.full((5000, 5), np.nan)
    assert g.offer(0.0, bad, now=10.0) is Verdict.UNSTAMPED  # no stamp, whatever the values
    assert g.offer(20.0, bad, now=10.0) is Verdict.FUTURE
    assert g.offer(10.0, bad, now=10.0) is Verdict.NON_FINITE
    assert g.offer(10.0, np.full((3, 5), 2e5), now=10.0) is Verdict.IMPLAUSIBLE
    ok = np.arange(15.0).reshape(3, 5)
    assert g.offer(10.0, ok, now=10.0) is Verdict.ACCEPTED
    assert InputGuard(0.5, limit=1e5).offer(10.0, ok.ravel().tolist(), now=10.0) is Verdict.ACCEPTED
    assert g.offer(10.0, np.empty((0, 5)), now=10.0) is Verdict.ACCEPTED  # an empty obstacle list
