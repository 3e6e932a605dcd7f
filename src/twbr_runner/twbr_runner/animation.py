"""An animation of a navigation run from its bag: the potential field under the robot, the target and the
obstacles moving over time, with the forces the planner felt. Written beside the figures (animation.gif,
or animation.mp4 where ffmpeg is installed), so a run can be watched without ROS or a browser."""

from __future__ import annotations

import math
import shutil
import subprocess
from pathlib import Path

import numpy as np
from matplotlib.patches import Circle

from twbr_runner.figures import field_extent, obstacles_at, planner_gains, plt, target_at
from twbr_runner.metrics import RunSeries

FPS = 10  # frames per second shown
SPEED = 8.0  # sim seconds per second shown
GRID = 90  # potential field samples per axis (the figure's 220 is too slow for every frame)
ARROW_LENGTH = 1.5  # [m] of the total force's arrow


def _planner_at(s: RunSeries, t: float):
    if not s.planner:
        return None
    stamps = [p.header.stamp.sec + 1e-9 * p.header.stamp.nanosec for p in s.planner]
    k = max(0, int(np.searchsorted(stamps, t, side="right")) - 1)
    return s.planner[k]


def frame_times(s: RunSeries, fps: float = FPS, speed: float = SPEED) -> np.ndarray:
    end = float(s.odom_t[-1])
    return np.append(np.arange(0.0, end, speed / fps), end)


def run_animation(s: RunSeries, out_dir: Path, title: str, fps: float = FPS, speed: float = SPEED) -> Path:
    """Animate `s` at `speed` x real time; mp4 with ffmpeg, else an animated GIF (pillow). Returns the file."""
    from twbr_planner.apf import Obstacles, potential

    params = planner_gains(s)
    x0, x1, y0, y1 = field_extent(s)
    xs, ys = np.linspace(x0, x1, GRID), np.linspace(y0, y1, GRID)
    grid = np.stack(np.meshgrid(xs, ys), axis=-1)
    times = frame_times(s, fps, speed)

    fig, ax = plt.subplots(figsize=(6.4, 6.4 * (y1 - y0) / (x1 - x0) + 0.6), dpi=60)
    heat = ax.imshow(np.zeros((GRID, GRID)), origin="lower", extent=(x0, x1, y0, y1), cmap="viridis",
                     interpolation="bilinear")
    robot_path, = ax.plot([], [], color="red", lw=2, label="robot")
    robot_dot, = ax.plot([], [], "o", color="red", ms=8)
    target_path, = ax.plot([], [], color="lime", lw=1.5, ls="--", label="target")
    target_star, = ax.plot([], [], "*", color="lime", ms=16, mec="black")
    arrows = {name: ax.quiver([0.0], [0.0], [0.0], [0.0], color=color, angles="xy", scale_units="xy", scale=1.0,
                              width=0.006, label=name)
              for name, color in (("attractive", "cyan"), ("repulsive", "orange"), ("total", "white"))}
    discs: list[Circle] = []
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.legend(loc="lower right", fontsize=7)
    fig.tight_layout()

    def draw(t: float) -> None:
        obstacles = obstacles_at(s, t)
        target = target_at(s, t)
        if target is not None:
            u = potential(grid, np.array(target), Obstacles.of(obstacles), params)
            shade = np.log10(1.0 + u - u.min())
            heat.set_data(shade)
            heat.set_clim(float(shade.min()), float(np.percentile(shade, 99)))
            target_star.set_data([target[0]], [target[1]])
            seen = s.target_t <= t + 1e-9
            target_path.set_data(s.target_xy[seen, 0], s.target_xy[seen, 1])
        for disc in discs:
            disc.remove()
        discs.clear()
        for _id, ox, oy, r in obstacles:
            discs.append(ax.add_patch(Circle((ox, oy), r, fill=False, color="white", lw=1.5)))
        upto = s.odom_t <= t + 1e-9
        px, py = s.x_c[upto], s.y_c[upto]
        robot_path.set_data(px, py)
        robot_dot.set_data(px[-1:], py[-1:])
        state = _planner_at(s, t)
        mode = state.mode if state is not None else ""
        # The total force drawn ARROW_LENGTH long, the others to its scale (capped: the repulsion diverges).
        total = state.total_force if state is not None else None
        norm = math.hypot(total.x, total.y) if total is not None else 0.0
        scale = ARROW_LENGTH / norm if math.isfinite(norm) and norm > 0.0 else 0.0
        for name, arrow in arrows.items():
            f = getattr(state, f"{name}_force") if state is not None else None
            arrow.set_offsets([[px[-1], py[-1]]])
            u, v = (scale * f.x, scale * f.y) if f is not None and math.isfinite(f.x + f.y) else (0.0, 0.0)
            cap = max(1.0, math.hypot(u, v) / (2.0 * ARROW_LENGTH))
            arrow.set_UVC([u / cap], [v / cap])
        ax.set_title(f"{title}: t = {t:5.1f} s  {mode}")

    frames = []
    for t in times:  # one draw per frame (FuncAnimation's save draws each three times)
        draw(t)
        fig.canvas.draw()
        frames.append(np.asarray(fig.canvas.buffer_rgba())[..., :3].copy())
    plt.close(fig)
    return write_movie(frames, out_dir / "animation", fps)


def write_movie(frames: list[np.ndarray], stem: Path, fps: float) -> Path:
    """stem.mp4 through ffmpeg where it is installed, else stem.gif (pillow, 128 colours)."""
    ffmpeg = shutil.which("ffmpeg")
    if ffmpeg:
        path = stem.with_suffix(".mp4")
        h, w = frames[0].shape[:2]
        cmd = [ffmpeg, "-y", "-loglevel", "error", "-f", "rawvideo", "-pix_fmt", "rgb24", "-s", f"{w}x{h}",
               "-r", f"{fps:g}", "-i", "-", "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2", "-pix_fmt", "yuv420p",
               str(path)]
        subprocess.run(cmd, input=b"".join(f.tobytes() for f in frames), check=True)
        return path
    from PIL import Image

    path = stem.with_suffix(".gif")
    images = [Image.fromarray(f).quantize(colors=128, method=Image.Quantize.FASTOCTREE) for f in frames]
    images[0].save(path, save_all=True, append_images=images[1:], duration=round(1000.0 / fps), loop=0,
                   optimize=True)
    return path
