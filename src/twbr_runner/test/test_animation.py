"""The run's animation: one frame per 0.8 s of sim time, the robot moving over the field."""

from __future__ import annotations

import numpy as np
from PIL import Image

from twbr_msgs.msg import PlannerState
from twbr_runner.animation import frame_times, run_animation
from twbr_runner.metrics import RunSeries


def straight_run() -> RunSeries:
    t = np.arange(0.0, 10.0 + 1e-9, 0.05)
    planner = []
    for k, stamp in enumerate(np.arange(0.0, 10.0, 0.5)):
        m = PlannerState(k_p=0.2, k_v=0.1, k_o=10.0, rho_o=2.0, robot_radius=0.3, min_distance=0.1,
                         mode="tracking" if k < 10 else "avoiding")
        m.header.stamp.sec, m.header.stamp.nanosec = int(stamp), round((stamp % 1) * 1e9)
        m.attractive_force.x, m.repulsive_force.y = 1.0, -0.5
        m.total_force.x, m.total_force.y = 1.0, -0.5
        planner.append(m)
    return RunSeries(odom_t=t, x_c=0.4 * t, y_c=np.zeros_like(t), target_t=np.array([0.0]),
                     target_xy=np.array([[6.0, 0.0]]), obstacles=[(0.0, np.array([[1, 2.0, 1.0, 0.0, 0.0, 0.5]]))],
                     planner=planner)


def test_the_animation_has_a_frame_per_step_and_the_robot_moves(tmp_path):
    s = straight_run()
    path = run_animation(s, tmp_path, "straight")
    assert len(frame_times(s)) == 14  # 0, 0.8, ..., 9.6 s and the end
    if path.suffix == ".gif":
        gif = Image.open(path)
        assert gif.n_frames == 14
        gif.seek(0)
        first = np.asarray(gif.convert("RGB")).astype(int)
        gif.seek(13)
        last = np.asarray(gif.convert("RGB")).astype(int)

        def red(frame: np.ndarray) -> int:  # the robot's path and dot (and its legend line)
            return int(((frame[..., 0] > 180) & (frame[..., 1] < 80) & (frame[..., 2] < 80)).sum())

        assert red(last) > red(first) + 100  # a 4 m path drawn since
    else:
        assert path.stat().st_size > 10_000
