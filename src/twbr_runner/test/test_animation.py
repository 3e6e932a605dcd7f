"""The run's animation: one frame per 0.8 s of sim time, the robot moving over the field."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

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


def movie_frames(path: Path, tmp_path: Path) -> list[np.ndarray]:
    """Every frame of the gif (pillow) or the mp4 (decoded by ffmpeg to png files), as RGB arrays."""
    if path.suffix == ".gif":
        gif = Image.open(path)
        frames = []
        for k in range(gif.n_frames):
            gif.seek(k)
            frames.append(np.asarray(gif.convert("RGB")).astype(int))
        return frames
    out = tmp_path / "decoded"
    out.mkdir()
    subprocess.run([shutil.which("ffmpeg"), "-loglevel", "error", "-i", str(path), "-vsync", "0",
                    str(out / "%04d.png")], check=True)
    return [np.asarray(Image.open(f).convert("RGB")).astype(int) for f in sorted(out.glob("*.png"))]


def test_the_animation_has_a_frame_per_step_and_the_robot_moves(tmp_path):
    s = straight_run()
    path = run_animation(s, tmp_path, "straight")
    assert len(frame_times(s)) == 14  # 0, 0.8, ..., 9.6 s and the end
    frames = movie_frames(path, tmp_path)  # mp4 where ffmpeg is installed, else gif
    assert len(frames) == 14

    def red(frame: np.ndarray) -> int:  # the robot's path and dot (and its legend line); mp4 blurs colours a bit
        return int(((frame[..., 0] > 170) & (frame[..., 1] < 90) & (frame[..., 2] < 90)).sum())

    assert red(frames[-1]) > red(frames[0]) + 100  # a 4 m path drawn since
