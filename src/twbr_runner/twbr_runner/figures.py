"""The paper's response figures (Figures 6, 8, 10, 12) from a run's series, as PNG files."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

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
