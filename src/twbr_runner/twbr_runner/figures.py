"""The paper's response figures (Figures 6, 8, 10, 12) from a run's series, as PNG files."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from twbr_runner.metrics import RunSeries


def _velocity(ax, s: RunSeries) -> None:
    ax.plot(s.control_t, s.control["velocity_ref"], "--", label="v_ref")
    ax.plot(s.control_t, s.control["velocity"], label="v")
    ax.set_ylabel("forward speed [m/s]")


def _yaw_rate(ax, s: RunSeries) -> None:
    ax.plot(s.control_t, s.control["yaw_rate_ref"], "--", label="ω_ref")
    ax.plot(s.control_t, s.control["yaw_rate"], label="ω")
    ax.set_ylabel("yaw rate [rad/s]")


def _pitch(ax, s: RunSeries) -> None:
    ax.plot(s.control_t, s.control["pitch_ref"], "--", label="θ_ref (velocity loop)")
    ax.plot(s.odom_t, s.pitch, label="θ")
    ax.set_ylabel("pitch [rad]")


def _torques(ax, s: RunSeries) -> None:
    ax.plot(s.control_t, s.control["left_torque"], label="left, commanded")
    ax.plot(s.control_t, s.control["right_torque"], label="right, commanded")
    if len(s.wheel_effort):
        ax.plot(s.joints_t, s.wheel_effort[:, 0], ":", label="left, motor")
        ax.plot(s.joints_t, s.wheel_effort[:, 1], ":", label="right, motor")
    ax.set_ylabel("wheel torque [N·m]")


PANELS = {"velocity": _velocity, "yaw_rate": _yaw_rate, "pitch": _pitch, "wheel_torques": _torques}


def response_figures(s: RunSeries, out_dir: Path, title: str) -> list[Path]:
    """response.png (all four panels) and one PNG per panel; returns the paths written."""
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    fig, axes = plt.subplots(len(PANELS), 1, sharex=True, figsize=(8, 10))
    for ax, draw in zip(axes, PANELS.values(), strict=True):
        draw(ax, s)
        ax.grid(True, alpha=0.3)
        ax.legend(loc="best", fontsize=8)
    axes[-1].set_xlabel("sim time [s]")
    fig.suptitle(title)
    fig.tight_layout()
    path = out_dir / "response.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    written.append(path)
    for name, draw in PANELS.items():
        fig, ax = plt.subplots(figsize=(8, 3.2))
        draw(ax, s)
        ax.grid(True, alpha=0.3)
        ax.legend(loc="best", fontsize=8)
        ax.set_xlabel("sim time [s]")
        ax.set_title(f"{title}: {name.replace('_', ' ')}")
        fig.tight_layout()
        path = out_dir / f"{name}.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        written.append(path)
    return written


def obstacles_at(s: RunSeries, t: float) -> list[tuple[int, float, float, float]]:
    """(id, x, y, radius) of each obstacle at `t`: the last snapshot before it, moved along its velocity."""
    if not s.obstacles:
        return []
    k = max(0, int(np.searchsorted([o[0] for o in s.obstacles], t, side="right")) - 1)
    stamp, rows = s.obstacles[k]
    age = max(0.0, t - stamp)
    return [(int(r[0]), float(r[1] + r[3] * age), float(r[2] + r[4] * age), float(r[5])) for r in rows]


def target_at(s: RunSeries, t: float) -> tuple[float, float] | None:
    if len(s.target_t) == 0:
        return None
    k = max(0, int(np.searchsorted(s.target_t, t, side="right")) - 1)
    return float(s.target_xy[k, 0]), float(s.target_xy[k, 1])


def _field_panel(ax, s: RunSeries, t: float, params: dict, extent: tuple[float, float, float, float]) -> object:
    from matplotlib.patches import Circle

    from twbr_planner.apf import Obstacles, potential

    x0, x1, y0, y1 = extent
    xs, ys = np.linspace(x0, x1, 220), np.linspace(y0, y1, 220)
    grid = np.stack(np.meshgrid(xs, ys), axis=-1)
    obstacles = obstacles_at(s, t)
    target = target_at(s, t)
    u = potential(grid, np.array(target), Obstacles.of(obstacles), params)
    # The repulsion diverges at the surfaces: a log scale keeps the attractive bowl and the obstacles readable.
    filled = ax.contourf(xs, ys, np.log10(1.0 + u - u.min()), levels=40, cmap="viridis")
    for _id, ox, oy, r in obstacles:
        ax.add_patch(Circle((ox, oy), r, fill=False, color="white", lw=1.5))
    upto = s.odom_t <= t + 1e-9
    ax.plot(s.x_c[upto], s.y_c[upto], color="red", lw=2, label="robot")
    ax.plot(s.x_c[upto][-1:], s.y_c[upto][-1:], "o", color="red", ms=8)
    tt = s.target_t <= t + 1e-9
    if tt.any():
        ax.plot(s.target_xy[tt, 0], s.target_xy[tt, 1], color="lime", lw=1.5, ls="--", label="target")
    ax.plot([target[0]], [target[1]], "*", color="lime", ms=16, mec="black")
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(f"t = {t:.1f} s")
    return filled


def planner_gains(s: RunSeries) -> dict:
    """The field's parameters as the planner reported them last (planner_state)."""
    last = s.planner[-1]
    return {name: getattr(last, name) for name in ("k_p", "k_v", "k_o", "rho_o", "robot_radius", "min_distance")}


def field_extent(s: RunSeries) -> tuple[float, float, float, float]:
    """(x0, x1, y0, y1) holding both paths and the obstacles at the start and the end, with a margin."""
    ends = [rows for _, rows in s.obstacles[:1] + s.obstacles[-1:]]
    xs = [*s.x_c, *s.target_xy[:, 0]] + [o[1] + sign * o[5] for obs in ends for o in obs for sign in (-1, 1)]
    ys = [*s.y_c, *s.target_xy[:, 1]] + [o[2] + sign * o[5] for obs in ends for o in obs for sign in (-1, 1)]
    return min(xs) - 1.5, max(xs) + 1.5, min(ys) - 1.5, max(ys) + 1.5


def potential_figures(s: RunSeries, out_dir: Path, title: str) -> list[Path]:
    """The potential field U (eq. 24) with the robot's and the target's paths and the obstacles, as in the
    paper's Figures 7, 9 and 11: one panel for a static world, four instants when anything moves."""
    params = planner_gains(s)
    extent = field_extent(s)
    moving = (len(s.target_xy) > 1 and np.ptp(s.target_xy, axis=0).max() > 1e-6) or (
        len(s.obstacles) > 1 and not np.array_equal(s.obstacles[0][1][:, 1:3], s.obstacles[-1][1][:, 1:3]))
    end = float(s.odom_t[-1])
    instants = [end * k / 3 for k in range(1, 4)] if moving else [end]
    if moving:
        instants = [min(end, 2.0), *instants]
    cols = 2 if moving else 1
    rows = (len(instants) + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(7 * cols, 6.5 * rows), squeeze=False)
    filled = None
    for ax, t in zip(axes.flat, instants, strict=False):
        filled = _field_panel(ax, s, t, params, extent)
    axes.flat[0].legend(loc="lower right", fontsize=8)
    fig.colorbar(filled, ax=axes, shrink=0.8, label="log10(1 + U - min U)")
    fig.suptitle(f"{title}: potential field, robot and target paths")
    path = out_dir / "potential_field.png"
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return [path]
