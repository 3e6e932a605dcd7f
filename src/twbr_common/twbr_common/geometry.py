"""Angles and quaternions (REP-103: x forward, y left, z up; roll-pitch-yaw about x, y, z)."""

from __future__ import annotations

import math

import numpy as np

from twbr_common.jit import kernel

TWO_PI = 2.0 * math.pi


@kernel
def wrap_angle(angle: float) -> float:
    """Wrap to (-pi, pi] (compiled: the planner's kernels call it)."""
    wrapped = np.fmod(angle, TWO_PI)  # exact, in (-2 pi, 2 pi)
    if wrapped > math.pi:
        wrapped -= TWO_PI
    elif wrapped <= -math.pi:
        wrapped += TWO_PI
    return wrapped


def quaternion_from_rpy(roll: float, pitch: float, yaw: float) -> tuple[float, float, float, float]:
    """(x, y, z, w) of R = Rz(yaw) Ry(pitch) Rx(roll)."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return (
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
        cr * cp * cy + sr * sp * sy,
    )


def rpy_from_quaternion(x: float, y: float, z: float, w: float) -> tuple[float, float, float]:
    """Inverse of quaternion_from_rpy (pitch clamped to [-pi/2, pi/2])."""
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return roll, pitch, yaw
