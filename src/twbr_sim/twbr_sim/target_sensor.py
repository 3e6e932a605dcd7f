"""What a target detector on the robot measures (a camera reading a tag, a UWB beacon's angle of arrival):
the target's range and bearing from the sensor, with noise, only within a field of view and a range, only
with a line of sight, and not every time.

The sensor sits on the body above the axle (as the LiDAR, `target_sensor.height` along its axis); its
bearing is counted from the body's heading. A measurement is made when the target's centre is within
`max_range` and `field_of_view` / 2 of the heading, no world obstacle's disc crosses the line from the
sensor to it (the scan's own discs occlude it), and a draw passes `dropout`. Range and bearing then get
Gaussian noise of `range_noise_std` and `bearing_noise_std`. Out of view, hidden or dropped: no
measurement (an empty detection list, which tells a tracker the sensor looked and did not see it).

The defaults are those of a tag on the target read by an omnidirectional camera on the robot: a few cm and
about a degree, out to 15 m, the whole way round (tags of fiducial systems such as AprilTag, Olson 2011,
*AprilTag: a robust and flexible visual fiducial system*, ICRA); a forward camera is `field_of_view` 1.57.
"""

from __future__ import annotations

import math

import numpy as np

from twbr_common.jit import kernel
from twbr_common.layout import Layout
from twbr_common.params import ParamSpec
from twbr_sim.lidar import disc_hit
from twbr_sim.noise import normal, uniform

TARGET_SENSOR_SPECS: tuple[ParamSpec, ...] = (
    ParamSpec("target_sensor.rate", 10.0, "measurements per second (0: no target_detections topic)", "Hz", 0.0,
              100.0),
    ParamSpec("target_sensor.field_of_view", 2.0 * math.pi, "full angle it sees, centred on the heading",
              "rad", 0.0, 2.0 * math.pi, low_open=True),
    ParamSpec("target_sensor.max_range", 15.0, "farthest target it measures", "m", 0.0, 100.0, low_open=True),
    ParamSpec("target_sensor.range_noise_std", 0.05, "white noise on the range", "m", 0.0, 10.0),
    ParamSpec("target_sensor.bearing_noise_std", math.radians(1.0), "white noise on the bearing", "rad", 0.0, 1.0),
    ParamSpec("target_sensor.dropout", 0.05, "probability that a target in view is not measured", "", 0.0, 1.0),
    ParamSpec("target_sensor.height", 0.30, "sensor above the axle, along the body's axis", "m", 0.0, 5.0),
    ParamSpec("target_sensor.frame", "target_sensor", "frame of target_detections: target_sensor.height above"
              " base_link, on /tf_static"),
)
TARGET_SENSOR_STREAM = 4  # its generator stream (noise.new_generator)

SETTINGS_LAYOUT = Layout(("field_of_view", "max_range", "range_noise", "bearing_noise", "dropout", "height"))
TD_FIELD_OF_VIEW = SETTINGS_LAYOUT["field_of_view"]
TD_MAX_RANGE = SETTINGS_LAYOUT["max_range"]
TD_RANGE_NOISE = SETTINGS_LAYOUT["range_noise"]
TD_BEARING_NOISE = SETTINGS_LAYOUT["bearing_noise"]
TD_DROPOUT = SETTINGS_LAYOUT["dropout"]
TD_HEIGHT = SETTINGS_LAYOUT["height"]
N_SETTINGS = len(SETTINGS_LAYOUT)


def settings_vector(cfg: dict) -> np.ndarray:
    """The kernel's settings from validated `target_sensor.*` parameters."""
    s = np.zeros(N_SETTINGS)
    for name, key in (("field_of_view", "field_of_view"), ("max_range", "max_range"),
                      ("range_noise", "range_noise_std"), ("bearing_noise", "bearing_noise_std"),
                      ("dropout", "dropout"), ("height", "height")):
        s[SETTINGS_LAYOUT[name]] = cfg[f"target_sensor.{key}"]
    return s


@kernel
def line_of_sight(sx, sy, tx, ty, positions, radii):
    """No disc crosses the segment from the sensor (sx, sy) to the target (tx, ty) [m]."""
    dx = tx - sx
    dy = ty - sy
    dist = math.hypot(dx, dy)
    if dist <= 0.0:
        return True
    ux = dx / dist
    uy = dy / dist
    for o in range(radii.shape[0]):  # noqa: SIM110 (a compiled loop: numba has no all() over a generator)
        if disc_hit(sx, sy, ux, uy, positions[o, 0], positions[o, 1], radii[o]) < dist:
            return False
    return True


@kernel
def measure_target(s, generator, x, y, yaw, pitch, tx, ty, positions, radii, out):
    """One measurement of the target at (tx, ty) [m] from the robot at (x, y, yaw, pitch): out = (range [m],
    bearing [rad] from the heading) and True, or False when it is not seen (out untouched)."""
    lean = s[TD_HEIGHT] * math.sin(pitch)
    sx = x + lean * math.cos(yaw)
    sy = y + lean * math.sin(yaw)
    true_range = math.hypot(tx - sx, ty - sy)
    true_bearing = math.atan2(ty - sy, tx - sx) - yaw
    true_bearing = math.atan2(math.sin(true_bearing), math.cos(true_bearing))
    # one draw per instant whether it is seen or not, so the noise does not depend on what happened before
    keep = uniform(generator)
    noise_range = normal(generator)
    noise_bearing = normal(generator)
    if true_range > s[TD_MAX_RANGE] or abs(true_bearing) > 0.5 * s[TD_FIELD_OF_VIEW]:
        return False
    if not line_of_sight(sx, sy, tx, ty, positions, radii):
        return False
    if keep < s[TD_DROPOUT]:
        return False
    out[0] = max(0.0, true_range + s[TD_RANGE_NOISE] * noise_range)
    out[1] = true_bearing + s[TD_BEARING_NOISE] * noise_bearing
    return True
