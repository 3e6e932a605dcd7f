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
