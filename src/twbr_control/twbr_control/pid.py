"""A PID controller with what a real one needs, as a compiled kernel and a small class around it.

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

`pid_update` is the one implementation: `Pid` (the nodes, the tuner, tests) and the batch engine both
call it, on a gains vector (G_*) and a memory vector (M_*) per loop.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from twbr_common.jit import inline_kernel, kernel
from twbr_common.layout import Layout

# One loop's gains (the fields of PidGains, in order) and its memory.
GAINS_LAYOUT = Layout(("kp", "ki", "kd", "derivative_filter", "output_limit", "setpoint_weight"))
G_KP = GAINS_LAYOUT["kp"]
G_KI = GAINS_LAYOUT["ki"]
G_KD = GAINS_LAYOUT["kd"]
G_FILTER = GAINS_LAYOUT["derivative_filter"]
G_LIMIT = GAINS_LAYOUT["output_limit"]
G_WEIGHT = GAINS_LAYOUT["setpoint_weight"]
N_GAINS = len(GAINS_LAYOUT)
MEMORY_LAYOUT = Layout(("integral", "previous", "has_previous", "rate", "output", "limited"))
M_INTEGRAL = MEMORY_LAYOUT["integral"]
M_PREVIOUS = MEMORY_LAYOUT["previous"]
M_HAS_PREVIOUS = MEMORY_LAYOUT["has_previous"]
M_RATE = MEMORY_LAYOUT["rate"]
M_OUTPUT = MEMORY_LAYOUT["output"]
M_LIMITED = MEMORY_LAYOUT["limited"]
N_MEMORY = len(MEMORY_LAYOUT)


@dataclass(frozen=True)
class PidGains:
    kp: float
    ki: float = 0.0
    kd: float = 0.0
    derivative_filter: float = 0.0  # low-pass time constant on the derivative [s]; 0: unfiltered
    output_limit: float = math.inf  # |output| <= output_limit
    setpoint_weight: float = 1.0  # b: the proportional term acts on b*setpoint - measurement

    def vector(self) -> np.ndarray:
        """The gains in the kernel's layout (GAINS_LAYOUT, by field name)."""
        return GAINS_LAYOUT.pack(asdict(self))


@kernel
def pid_reset(m):
    """Forget the integral and the derivative memory (after a fall, a re-enable or a long gap)."""
    m[:] = 0.0


@inline_kernel
def pid_update(g, m, setpoint, measurement, dt, measurement_rate, has_rate, hold_integral):
    """One sample; `has_rate` says whether `measurement_rate` [unit/s] is given (else it is differenced).
    `hold_integral` = +1/-1 forbids integrating upwards/downwards (cascade windup). Returns the output."""
    if not dt > 0.0:
        raise ValueError("dt must be > 0")
    error = setpoint - measurement
    has_previous = m[M_HAS_PREVIOUS] != 0.0
    if has_rate:
        raw_rate = measurement_rate
    elif has_previous:
        raw_rate = (measurement - m[M_PREVIOUS]) / dt
    else:
        raw_rate = 0.0
    if not has_previous and not has_rate:
        m[M_RATE] = 0.0
    elif g[G_FILTER] > 0.0:
        m[M_RATE] += dt / (g[G_FILTER] + dt) * (raw_rate - m[M_RATE])
    else:
        m[M_RATE] = raw_rate
    m[M_PREVIOUS] = measurement
    m[M_HAS_PREVIOUS] = 1.0

    p_term = g[G_KP] * (g[G_WEIGHT] * setpoint - measurement)
    d_term = -g[G_KD] * m[M_RATE]
    limit = g[G_LIMIT]
    integral = m[M_INTEGRAL]
    candidate = integral + g[G_KI] * error * dt
    unlimited = p_term + candidate + d_term
    pushing_up = candidate > integral
    blocked = (pushing_up and (unlimited > limit or hold_integral > 0)) or (
        not pushing_up and candidate < integral and (unlimited < -limit or hold_integral < 0)
    )
    if not blocked:
        m[M_INTEGRAL] = candidate
    unlimited = p_term + m[M_INTEGRAL] + d_term
    output = min(max(unlimited, -limit), limit)
    m[M_OUTPUT] = output
    m[M_LIMITED] = 1.0 if output != unlimited else 0.0
    return output


class Pid:
    """One loop: its gains and its memory (a view into a caller's array, or its own)."""

    def __init__(self, gains: PidGains, memory: np.ndarray | None = None) -> None:
        if not gains.output_limit > 0.0:
            raise ValueError("output_limit must be > 0")
        self.gains = gains
        self.g = gains.vector()
        self.m = np.zeros(N_MEMORY) if memory is None else memory
        self.reset()

    def reset(self) -> None:
        pid_reset(self.m)

    def restart_derivative(self) -> None:
        """Drop the derivative memory only: the next sample has no previous one to difference."""
        self.m[M_HAS_PREVIOUS] = 0.0

    @property
    def integral(self) -> float:
        """The integral term, in output units."""
        return float(self.m[M_INTEGRAL])

    @property
    def output(self) -> float:
        return float(self.m[M_OUTPUT])

    @property
    def limited(self) -> bool:
        return bool(self.m[M_LIMITED])

    def update(
        self,
        setpoint: float,
        measurement: float,
        dt: float,
        measurement_rate: float | None = None,
        hold_integral: int = 0,
    ) -> float:
        has_rate = measurement_rate is not None
        return pid_update(self.g, self.m, float(setpoint), float(measurement), float(dt),
                          float(measurement_rate) if has_rate else 0.0, has_rate, int(hold_integral))
