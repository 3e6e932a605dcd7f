"""Metrics read only what the nodes would accept: injected garbage in a bag does not move them."""

import math
from types import SimpleNamespace as NS

from twbr_runner.metrics import series_from_messages


def _odom(t: float, x: float, v: float = 0.1) -> NS:
    sec = int(t)
    return NS(header=NS(stamp=NS(sec=sec, nanosec=round((t - sec) * 1e9))),
              pose=NS(pose=NS(position=NS(x=x, y=0.0), orientation=NS(x=0.0, y=0.0, z=0.0, w=1.0))),
              twist=NS(twist=NS(linear=NS(x=v), angular=NS(z=0.0))))


def test_injected_odom_is_left_out_and_counted():
    real = [_odom(0.005 * k, 0.001 * k) for k in range(1, 101)]
    items = [(k, m) for k, m in enumerate(real)]
    for bad in (_odom(0.2, math.nan), _odom(0.2, math.inf), _odom(0.2, 1e9),  # non-finite, absurd
                _odom(0.0, 0.3), _odom(0.1, 0.3)):  # unstamped, out of order (older than the newest)
        items.insert(60, (59.5, bad))
    s = series_from_messages({"/odom": items})
    assert len(s.odom_t) == 100 and s.refused == {"/odom": 5}
    assert s.x_c.max() == 0.1 and s.x_c[0] == 0.001


def test_equal_stamps_keep_the_first_state_and_the_last_status():
    first, again = _odom(0.0, 0.0), _odom(0.0, 0.5)
    status = [NS(header=first.header, pitch=0.0, steps=k) for k in (1, 2)]
    s = series_from_messages({"/odom": [(0, first), (1, again)], "/sim_status": [(0, status[0]), (1, status[1])]})
    assert list(s.x_c) == [0.0]
    assert [m.steps for m in s.sim_status] == [2]


def test_obstacle_lists_are_kept_as_snapshots_and_moved_to_the_instant_asked():
    """A recording's obstacle arrays are not held whole (5,000 obstacles at 50 Hz made the metrics step
    take > 5 GB): one every OBSTACLE_SNAPSHOT_PERIOD and the last, moved along their velocity when drawn."""
    from rclpy.serialization import serialize_message

    from twbr_msgs.msg import Obstacle, ObstacleArray
    from twbr_runner.figures import obstacles_at
    from twbr_runner.metrics import OBSTACLE_SNAPSHOT_PERIOD

    def array(t: float) -> bytes:
        msg = ObstacleArray()
        msg.header.stamp.sec, msg.header.stamp.nanosec = int(t), round((t - int(t)) * 1e9)
        for i in range(200):
            o = Obstacle(id=i, radius=0.3)
            o.position.x, o.position.y, o.velocity.x = float(i) + 0.5 * t, 1.0, 0.5
            msg.obstacles.append(o)
        return bytes(serialize_message(msg))

    items = [(k, array(0.01 * k)) for k in range(1, 1001)]  # 10 s at 100 Hz, as raw bytes
    clock = [(k, NS(clock=NS(sec=int(0.01 * k), nanosec=round((0.01 * k % 1) * 1e9)))) for k in range(1, 1001)]
    s = series_from_messages({"/clock": clock, "/obstacles": items})
    assert s.counts["/obstacles"] == 1000
    assert len(s.obstacles) <= 10.0 / OBSTACLE_SNAPSHOT_PERIOD + 2 and s.obstacles[-1][0] == 10.0
    for t in (0.013, 3.337, 9.999):
        at = obstacles_at(s, t)
        assert len(at) == 200 and all(math.isclose(x, i + 0.5 * t, abs_tol=1e-9) for i, x, _, _ in at)


def _clock(t: float) -> NS:
    sec = int(t)
    return NS(clock=NS(sec=sec, nanosec=round((t - sec) * 1e9)))


def test_a_clock_held_back_by_the_recorder_leaves_no_odom_out_and_still_refuses_one_from_ahead():
    """Measured on a loaded 2-core host: one /clock sample missed by the recorder was resent 1.2 s later,
    and the 660 after it (3.3 s of sim time) waited for it; odom and joint_states came on time meanwhile.
    Every odom of the gap is the run's, and an odom stamped 1 s ahead inside the gap is still not."""
    steps, missed = 4000, 1263  # 200 Hz of sim time at real-time factor 2: 2.5 ms of wall time apart
    send = [2_500_000 * k for k in range(steps)]
    resent = send[missed] + 1_200_000_000
    # in order: every sample from the missed one on waits for it, and comes 1 us after the one before
    clock = [(send[k] + 100_000 if k < missed else max(send[k] + 100_000, resent + 1_000 * (k - missed)),
              _clock(0.005 * k)) for k in range(steps)]
    odom = [(send[k] + 200_000, _odom(0.005 * k, 0.001 * k)) for k in range(steps)]
    joints = [(send[k] + 250_000, NS(header=_odom(0.005 * k, 0.0).header, effort=[0.01, 0.01])) for k in range(steps)]
    ahead = [(send[k] + 300_000, _odom(0.005 * k + 1.0, 5.0)) for k in (1400, 1600, 1800)]
    s = series_from_messages({"/clock": clock, "/odom": odom + ahead, "/joint_states": joints})
    assert len(s.odom_t) == steps and len(s.joints_t) == steps and s.refused == {"/odom": 3}
    assert s.x_c.max() == 0.001 * (steps - 1)
