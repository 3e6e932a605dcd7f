"""twbr's DC motor and current-loop driver (dynamics.md), stepped beside MuJoCo's mechanics.

The same kernels as the ideal model (`driver_voltage`, `current_rate`); only the coupling differs: over one
physics step the wheel's speed relative to the body is held at MuJoCo's value at the step's start, the
armature current is integrated with RK4 (sub-stepped like the ideal model for the electrical pole), and
the wheel gets the step's mean motor torque N k i.
"""

from __future__ import annotations

from twbr_common.jit import kernel
from twbr_sim.dynamics import current_rate, driver_voltage, substeps
from twbr_sim.robot_params import D_NK


@kernel
def _di(p, command, current, relative_speed):
    return current_rate(p, driver_voltage(p, command, current, relative_speed), current, relative_speed)


@kernel
def advance_current(p, command, current, relative_speed, h):
    """(current after h seconds [A], mean wheel torque over them [N*m]) for a held torque command."""
    n = substeps(p, h)
    dt = h / n
    charge = 0.0
    i = current
    for _ in range(n):
        k1 = _di(p, command, i, relative_speed)
        k2 = _di(p, command, i + 0.5 * dt * k1, relative_speed)
        k3 = _di(p, command, i + 0.5 * dt * k2, relative_speed)
        k4 = _di(p, command, i + dt * k3, relative_speed)
        i_next = i + dt / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
        charge += 0.5 * (i + i_next) * dt
        i = i_next
    return i, p[D_NK] * charge / h
