"""PoseHistory: a scan gets its own instant's odom, whatever came between."""

from __future__ import annotations

from twbr_tracker.pose_history import PoseHistory


def odoms(history: PoseHistory, start: float, stop: float, dt: float = 0.01) -> None:
    """Odoms at 100 Hz of a robot driving at 1 m/s along x (x = stamp)."""
    n = round((stop - start) / dt)
    for i in range(n + 1):
        t = start + i * dt
        history.add(t, t, 0.0, 0.0, 1.0, 0.0, 0.0)


def test_a_scan_that_arrives_after_later_odoms_is_placed_with_its_own_instant_s():
    """A scan at 1.000 s handled after the odoms up to 1.500 s (a busy executor): it gets the odom at
    1.000 s, not the newest, which is 0.5 m further on."""
    history = PoseHistory(2.0)
    odoms(history, 0.0, 1.5)
    odom = history.at_or_after(1.0)
    assert abs(odom[0] - 1.0) < 1e-9 and abs(odom[1] - 1.0) < 1e-9
    between = history.at_or_after(1.0049)  # between two odoms: the later one
    assert abs(between[0] - 1.01) < 1e-9


def test_a_scan_newer_than_every_odom_has_none_yet():
    history = PoseHistory(2.0)
    assert history.at_or_after(0.0) is None and history.newest() == float("-inf")
    odoms(history, 0.0, 1.0)
    assert history.newest() == 1.0 and history.at_or_after(1.001) is None


def test_a_scan_older_than_the_history_is_refused_not_placed_at_the_oldest_kept():
    """With 0.5 s kept, a scan 0.8 s old has lost its odom: None, so the node drops it; one inside the
    history still finds its own."""
    history = PoseHistory(0.5)
    odoms(history, 0.0, 2.0)
    assert history.at_or_after(1.2) is None
    assert abs(history.at_or_after(1.6)[0] - 1.6) < 1e-9
    history.clear()
    assert history.at_or_after(1.6) is None
    odoms(history, 0.0, 0.2)  # after a restart, the early stamps are placed again
    assert abs(history.at_or_after(0.1)[0] - 0.1) < 1e-9


def test_the_history_stays_bounded():
    history = PoseHistory(1.0)
    odoms(history, 0.0, 100.0)
    assert len(history) <= 102
