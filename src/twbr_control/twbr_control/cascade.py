"""The paper's cascaded controller (its Figure 3) as a plain-Python core.

velocity PID: v_ref - v -> pitch_ref (limited) ; pitch PID: pitch_ref - pitch -> common wheel torque ;
yaw-rate PI: omega_ref - omega -> differential torque. Left = common - differential, right = common +
differential, each limited to the motor torque, balance first: the differential part gets only the
headroom the common part leaves. Signs: a forward lean (pitch > 0) is caught by driving the wheels forward,
so the common torque is minus the pitch PID's output; to speed up, the robot must lean forward, so the
velocity loop's output is the pitch reference itself (and the robot first rolls back: non-minimum phase).

The sample time comes from the stamps of the states; the node, the headless closed loop and the tuner
all call `compute` the same way.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from twbr_control.pid import Pid, PidGains


@dataclass(frozen=True)
class ControlOutput:
    stamp: float
    velocity_ref: float
    velocity: float
    yaw_rate_ref: float
    yaw_rate: float
    pitch_ref: float
    pitch: float
    pitch_rate: float
    common_torque: float
    differential_torque: float
    left_torque: float
    right_torque: float
    dt: float
    pitch_ref_limited: bool
    torque_saturated: bool
    cmd_vel_stale: bool
    fallen: bool
    enabled: bool


def _clip(value: float, limit: float) -> float:
    return min(max(value, -limit), limit)


class CascadeController:
    """Velocity -> pitch cascade plus yaw-rate PI, with fall cut-off, enable and reset."""

    def __init__(self, settings: Mapping[str, Any], enabled: bool = True) -> None:
        s = settings
        self.period = 1.0 / s["rate"]
        self.max_velocity_ref = s["max_velocity_ref"]
        self.max_yaw_rate_ref = s["max_yaw_rate_ref"]
        self.pitch_offset = s["pitch_offset"]
        self.max_torque = s["max_wheel_torque"]
        self.fall_pitch = s["fall_pitch"]
        self.max_sample_gap = s["max_sample_gap"]
        self.velocity_pid = Pid(PidGains(
            s["velocity.kp"], s["velocity.ki"], s["velocity.kd"], s["velocity.derivative_filter"],
            s["max_pitch_ref"], s["velocity.setpoint_weight"],
        ))
        self.pitch_pid = Pid(PidGains(
            s["pitch.kp"], s["pitch.ki"], s["pitch.kd"], s["pitch.derivative_filter"], self.max_torque,
        ))
        self.yaw_rate_pid = Pid(PidGains(s["yaw_rate.kp"], s["yaw_rate.ki"], 0.0, 0.0, self.max_torque))
        self.enabled = enabled
        self.fallen = False
        self._last_stamp: float | None = None
        self._common_saturation = 0  # sign of the common torque's saturation at the last sample
        self._differential_saturation = 0  # same for the differential torque (limited by the headroom)

    def reset(self) -> None:
        """Forget all loop memory: after a fall, a re-enable, or a jump back in time."""
        for pid in (self.velocity_pid, self.pitch_pid, self.yaw_rate_pid):
            pid.reset()
        self._last_stamp = None
        self._common_saturation = 0
        self._differential_saturation = 0

    def set_enabled(self, enabled: bool) -> None:
        """Enabling clears a fall (the user stood the robot up); either way the loops restart from zero."""
        self.enabled = enabled
        if enabled:
            self.fallen = False
        self.reset()

    def _sample_time(self, stamp: float) -> float:
        if self._last_stamp is None or stamp <= self._last_stamp:
            if self._last_stamp is not None:
                self.reset()  # time went backwards (a restarted simulator): start afresh
            return self.period
        dt = stamp - self._last_stamp
        if dt > self.max_sample_gap:
            for pid in (self.velocity_pid, self.pitch_pid, self.yaw_rate_pid):
                pid.restart_derivative()
            return self.period
        return dt

    def compute(
        self,
        stamp: float,
        velocity_ref: float,
        yaw_rate_ref: float,
        velocity: float,
        yaw_rate: float,
        pitch: float,
        pitch_rate: float,
        cmd_vel_stale: bool = False,
    ) -> ControlOutput:
        """Wheel torques for the state stamped `stamp` [s]; stale cmd_vel means zero references."""
        dt = self._sample_time(stamp)
        self._last_stamp = stamp
        if cmd_vel_stale:
            velocity_ref = yaw_rate_ref = 0.0
        velocity_ref = _clip(velocity_ref, self.max_velocity_ref)
        yaw_rate_ref = _clip(yaw_rate_ref, self.max_yaw_rate_ref)
        if abs(pitch - self.pitch_offset) > self.fall_pitch and not self.fallen:
            self.fallen = True
            self.reset()
            self._last_stamp = stamp

        active = self.enabled and not self.fallen
        pitch_ref = common = differential = 0.0
        pitch_ref_limited = torque_saturated = False
        if active:
            # The velocity loop must not wind up while the torque it asks for through the pitch loop is
            # saturated: a positive pitch_ref asks for a negative common torque first.
            pitch_ref = self.pitch_offset + self.velocity_pid.update(
                velocity_ref, velocity, dt, hold_integral=-self._common_saturation,
            )
            pitch_ref_limited = self.velocity_pid.limited
            common = -self.pitch_pid.update(pitch_ref, pitch, dt, measurement_rate=pitch_rate)
            self._common_saturation = int(math.copysign(1, common)) if self.pitch_pid.limited else 0
            headroom = self.max_torque - abs(common)
            requested = self.yaw_rate_pid.update(
                yaw_rate_ref, yaw_rate, dt, hold_integral=self._differential_saturation,
            )
            differential = _clip(requested, headroom)
            self._differential_saturation = int(math.copysign(1, requested)) if differential != requested else 0
            torque_saturated = self.pitch_pid.limited or differential != requested
        left = _clip(common - differential, self.max_torque)
        right = _clip(common + differential, self.max_torque)
        return ControlOutput(
            stamp=stamp, velocity_ref=velocity_ref, velocity=velocity, yaw_rate_ref=yaw_rate_ref,
            yaw_rate=yaw_rate, pitch_ref=pitch_ref, pitch=pitch, pitch_rate=pitch_rate, common_torque=common,
            differential_torque=differential, left_torque=left, right_torque=right, dt=dt,
            pitch_ref_limited=pitch_ref_limited, torque_saturated=torque_saturated,
            cmd_vel_stale=cmd_vel_stale, fallen=self.fallen, enabled=self.enabled,
        )
