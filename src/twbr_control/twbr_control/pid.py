"""A PID controller with what a real one needs; pure Python, so the node, the tuner and tests share it.

- Derivative on the measurement, not on the error: a set-point step gives no derivative kick.
  The measured rate can be passed in (a gyro) instead of differencing the measurement.
- A first-order low-pass filter (time constant `derivative_filter`, s) on that derivative.
- Set-point weighting b of the proportional term (a 2-DOF PID): b < 1 softens the response to a
  reference step without slowing the rejection of disturbances; the integral acts on the full error.
- Output limit, and anti-windup by conditional integration: the integral does not grow while the
  output is limited and the error pushes further into the limit (or while a downstream stage says
  the actuators are saturated in that direction). The integral is not clipped to the output limit
  itself: with set-point weighting it must hold more than the limit while P pulls the other way.
- The sample time is an argument of every update (taken from message stamps by the caller).
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class PidGains:
    kp: float
    ki: float = 0.0
    kd: float = 0.0
    derivative_filter: float = 0.0  # low-pass time constant on the derivative [s]; 0: unfiltered
    output_limit: float = math.inf  # |output| <= output_limit
    setpoint_weight: float = 1.0  # b: the proportional term acts on b*setpoint - measurement


class Pid:
    def __init__(self, gains: PidGains) -> None:
        if not gains.output_limit > 0.0:
            raise ValueError("output_limit must be > 0")
        self.gains = gains
        self.reset()

    def reset(self) -> None:
        """Forget the integral and the derivative memory (after a fall, a re-enable or a long gap)."""
        self.integral = 0.0  # integral term, in output units
        self._previous: float | None = None
        self._rate = 0.0  # filtered measurement rate
        self.output = 0.0
        self.limited = False

    def restart_derivative(self) -> None:
        """Drop the derivative memory only: the next sample has no previous one to difference."""
        self._previous = None

    def update(
        self,
        setpoint: float,
        measurement: float,
        dt: float,
        measurement_rate: float | None = None,
        hold_integral: int = 0,
    ) -> float:
        """One sample. `hold_integral` = +1/-1 forbids integrating upwards/downwards (cascade windup)."""
        if not dt > 0.0:
            raise ValueError("dt must be > 0")
        g = self.gains
        error = setpoint - measurement
        if measurement_rate is None:
            raw_rate = 0.0 if self._previous is None else (measurement - self._previous) / dt
        else:
            raw_rate = measurement_rate
        if self._previous is None and measurement_rate is None:
            self._rate = 0.0
        elif g.derivative_filter > 0.0:
            self._rate += dt / (g.derivative_filter + dt) * (raw_rate - self._rate)
        else:
            self._rate = raw_rate
        self._previous = measurement

        p_term = g.kp * (g.setpoint_weight * setpoint - measurement)
        d_term = -g.kd * self._rate
        limit = g.output_limit
        candidate = self.integral + g.ki * error * dt
        unlimited = p_term + candidate + d_term
        pushing_up = candidate > self.integral
        blocked = (
            (pushing_up and (unlimited > limit or hold_integral > 0))
            or (not pushing_up and candidate < self.integral and (unlimited < -limit or hold_integral < 0))
        )
        if not blocked:
            self.integral = candidate
        unlimited = p_term + self.integral + d_term
        self.output = min(max(unlimited, -limit), limit)
        self.limited = self.output != unlimited
        return self.output
