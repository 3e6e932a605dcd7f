"""Wheel encoders and the odometry a driver builds from them: exact by default, or quantised like hardware.

With `encoder.counts_per_rev` set, each wheel's angle is known only to a whole count; its speed is the
counts gained over `encoder.velocity_window` divided by that window (what a motor driver computes), and the
odometry is dead reckoning from the counts (forward travel r·(dL+dR)/2, heading change r·(dR-dL)/d), so it
carries the quantisation and its drift. `encoder_sample` is the one implementation for the simulator and the
batch engine: one call per published state.
"""

from __future__ import annotations

import math

import numpy as np

from twbr_common.jit import kernel
from twbr_common.layout import Layout
from twbr_common.params import ParamSpec
from twbr_sim.dynamics import S_GL, S_GR, S_PSI, S_PSID, S_XC, S_XD, S_YC, wheel_rates
from twbr_sim.robot_params import P_D, P_R

ENCODER_SPECS: tuple[ParamSpec, ...] = (
    ParamSpec("encoder.counts_per_rev", 0, "wheel encoder counts per wheel revolution (after the gear): joint"
              " angles are whole counts and odometry is built from them; 0: exact angles, rates and pose", "",
              0, 10**7),
    ParamSpec("encoder.velocity_window", 0.02, "with counts: wheel speed = counts gained over this window / its"
              " length, in whole publish periods (longer: finer steps, more lag)", "s", 0.0, 1.0, low_open=True),
)

SETTINGS_LAYOUT = Layout(("resolution", "window", "period"))
EN_RESOLUTION = SETTINGS_LAYOUT["resolution"]  # [rad per count]; 0: exact
EN_WINDOW = SETTINGS_LAYOUT["window"]  # [publish periods]
EN_PERIOD = SETTINGS_LAYOUT["period"]  # [s]
N_SETTINGS = len(SETTINGS_LAYOUT)
# Output: joint angles [rad] and rates [rad/s], then odometry: pose (x, y [m], yaw [rad]) and twist (v [m/s],
# yaw rate [rad/s]).
OUTPUT_LAYOUT = Layout(("angle_left", "angle_right", "rate_left", "rate_right", "x", "y", "yaw", "velocity",
                        "yaw_rate"))
J_ANGLE_LEFT = OUTPUT_LAYOUT["angle_left"]
J_ANGLE_RIGHT = OUTPUT_LAYOUT["angle_right"]
J_RATE_LEFT = OUTPUT_LAYOUT["rate_left"]
J_RATE_RIGHT = OUTPUT_LAYOUT["rate_right"]
J_X = OUTPUT_LAYOUT["x"]
J_Y = OUTPUT_LAYOUT["y"]
J_YAW = OUTPUT_LAYOUT["yaw"]
J_VELOCITY = OUTPUT_LAYOUT["velocity"]
J_YAW_RATE = OUTPUT_LAYOUT["yaw_rate"]
N_OUTPUTS = len(OUTPUT_LAYOUT)
# Memory: samples taken, the dead-reckoned pose, then a ring of the last window+1 counts (left, right).
MEMORY_LAYOUT = Layout(("samples", "x", "y", "yaw"))
EM_SAMPLES = MEMORY_LAYOUT["samples"]
EM_X = MEMORY_LAYOUT["x"]
EM_Y = MEMORY_LAYOUT["y"]
EM_YAW = MEMORY_LAYOUT["yaw"]
N_RING = len(MEMORY_LAYOUT)


def settings_vector(settings: dict, publish_rate: float) -> np.ndarray:
    counts = settings["encoder.counts_per_rev"]
    return SETTINGS_LAYOUT.pack({
        "resolution": 2.0 * math.pi / counts if counts > 0 else 0.0,
        "window": max(1, round(settings["encoder.velocity_window"] * publish_rate)), "period": 1.0 / publish_rate,
    })


def new_memory(c: np.ndarray) -> np.ndarray:
    return np.zeros(N_RING + 2 * (int(c[EN_WINDOW]) + 1))


@kernel
def encoder_sample(p, c, m, s, out):
    """Joint angles, rates and odometry published with state `s` (one call per published state), into `out`."""
    resolution = c[EN_RESOLUTION]
    if resolution == 0.0:
        out[J_ANGLE_LEFT] = s[S_GL]
        out[J_ANGLE_RIGHT] = s[S_GR]
        out[J_RATE_LEFT], out[J_RATE_RIGHT] = wheel_rates(p, s[S_XD], s[S_PSID])
        out[J_X] = s[S_XC]
        out[J_Y] = s[S_YC]
        out[J_YAW] = s[S_PSI]
        out[J_VELOCITY] = s[S_XD]
        out[J_YAW_RATE] = s[S_PSID]
        return
    window = int(c[EN_WINDOW])
    n = int(m[EM_SAMPLES])
    size = window + 1
    slot = N_RING + 2 * (n % size)
    count_l = math.floor(s[S_GL] / resolution)
    count_r = math.floor(s[S_GR] / resolution)
    radius = p[P_R]
    if n == 0:  # the driver starts its odometry where the robot stands
        m[EM_X] = s[S_XC]
        m[EM_Y] = s[S_YC]
        m[EM_YAW] = s[S_PSI]
    else:
        last = N_RING + 2 * ((n - 1) % size)
        d_l = (count_l - m[last]) * resolution * radius
        d_r = (count_r - m[last + 1]) * resolution * radius
        d_yaw = (d_r - d_l) / p[P_D]
        heading = m[EM_YAW] + 0.5 * d_yaw
        m[EM_X] += 0.5 * (d_l + d_r) * math.cos(heading)
        m[EM_Y] += 0.5 * (d_l + d_r) * math.sin(heading)
        m[EM_YAW] += d_yaw
    m[slot] = count_l
    m[slot + 1] = count_r
    back = min(n, window)  # the window, once that many samples exist
    rate_l = 0.0
    rate_r = 0.0
    if back > 0:
        old = N_RING + 2 * ((n - back) % size)
        span = back * c[EN_PERIOD]
        rate_l = (count_l - m[old]) * resolution / span
        rate_r = (count_r - m[old + 1]) * resolution / span
    m[EM_SAMPLES] = n + 1
    out[J_ANGLE_LEFT] = count_l * resolution
    out[J_ANGLE_RIGHT] = count_r * resolution
    out[J_RATE_LEFT] = rate_l
    out[J_RATE_RIGHT] = rate_r
    out[J_X] = m[EM_X]
    out[J_Y] = m[EM_Y]
    out[J_YAW] = m[EM_YAW]
    out[J_VELOCITY] = 0.5 * radius * (rate_l + rate_r)
    out[J_YAW_RATE] = radius * (rate_r - rate_l) / p[P_D]
