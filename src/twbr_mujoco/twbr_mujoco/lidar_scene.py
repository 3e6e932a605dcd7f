"""mujoco_driver's LiDAR: the scan cast by MuJoCo's own ray tracer (mj_ray) against a scene of the floor and
the world's obstacles, from the chassis' full 3D orientation (roll too), instead of twbr_sim.lidar's
closed-form cylinder hits.

The scene is a separate small model (a floor plane and one mocap cylinder per obstacle, 4 m tall so every
beam that reaches one meets its side), so casting never touches the physics' data. As the device turns,
beam i is taken `i * time_increment` into the scan: the obstacles are moved along their velocities to that
instant, and the scanner along the unicycle arc the robot drives (the one rule, twbr_sim.lidar.scanner_at)
with the body's yaw advanced by the yaw rate. Range limits, REP 117's infinities and the device's noise
are the simulator's (lidar.scan_noise, its own generator stream). test_mujoco_scan compares the two
casts on the same state.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from twbr_sim.lidar import (
    LD_ANGLE_INCREMENT,
    LD_ANGLE_MIN,
    LD_BEAMS,
    LD_HEIGHT,
    LD_RANGE_MAX,
    LD_RANGE_MIN,
    LD_TIME_INCREMENT,
    scanner_at,
)

OBSTACLE_HALF_HEIGHT = 2.0  # [m] taller than any scanner


def scene_mjcf(radii: np.ndarray) -> str:
    """The ray tracer's scene: the floor, and a mocap cylinder of each radius [m]."""
    bodies = "".join(
        f'\n    <body name="obstacle{k}" mocap="true"><geom type="cylinder" size="{r:.9g} {OBSTACLE_HALF_HEIGHT}"'
        f' pos="0 0 {OBSTACLE_HALF_HEIGHT}" contype="0" conaffinity="0"/></body>' for k, r in enumerate(radii))
    return f"""<mujoco model="twbr_lidar_scene">
  <worldbody>
    <geom name="floor" type="plane" size="0 0 0.05"/>{bodies}
  </worldbody>
</mujoco>
"""


class LidarScene:
    def __init__(self) -> None:
        self._radii: np.ndarray | None = None
        self.model: mujoco.MjModel | None = None
        self.data: mujoco.MjData | None = None
        self._geomid = np.zeros(1, dtype=np.int32)

    def _scene(self, radii: np.ndarray) -> None:
        if self._radii is None or not np.array_equal(radii, self._radii):
            self._radii = radii.copy()
            self.model = mujoco.MjModel.from_xml_string(scene_mjcf(radii))
            self.data = mujoco.MjData(self.model)

    def cast(self, s: np.ndarray, axle: np.ndarray, body: np.ndarray, speed: float, yaw_rate: float,
             positions: np.ndarray, velocities: np.ndarray, radii: np.ndarray, ranges: np.ndarray) -> None:
        """Noise-free ranges [m] (REP 117's -inf / +inf outside the device's range) of one scan begun with the
        axle at `axle` (x, y, z) [m], the chassis' rotation `body` (3 x 3, body to world), driving at `speed`
        [m/s] and `yaw_rate` [rad/s], among discs at `positions` [m] moving at `velocities` [m/s]."""
        self._scene(np.asarray(radii, dtype=float))
        m, d = self.model, self.data
        yaw = math.atan2(body[1, 0], body[0, 0])
        up = body @ np.array([0.0, 0.0, s[LD_HEIGHT]])  # the scanner above the axle, along the body's axis
        moving = bool(np.any(velocities != 0.0))
        point = np.zeros(3)
        direction = np.zeros(3)
        for i in range(int(s[LD_BEAMS])):
            dt = i * s[LD_TIME_INCREMENT]
            if i == 0 or moving:
                d.mocap_pos[:, :2] = positions + velocities * dt
                mujoco.mj_kinematics(m, d)
            ax, ay, heading = scanner_at(axle[0], axle[1], yaw, speed, yaw_rate, dt, 0.0)
            turn = heading - yaw
            c, sn = math.cos(turn), math.sin(turn)
            point[0] = ax + c * up[0] - sn * up[1]
            point[1] = ay + sn * up[0] + c * up[1]
            point[2] = axle[2] + up[2]
            bearing = s[LD_ANGLE_MIN] + i * s[LD_ANGLE_INCREMENT]
            beam = body @ np.array([math.cos(bearing), math.sin(bearing), 0.0])
            direction[0] = c * beam[0] - sn * beam[1]
            direction[1] = sn * beam[0] + c * beam[1]
            direction[2] = beam[2]
            hit = mujoco.mj_ray(m, d, point, direction, None, 1, -1, self._geomid)
            if hit < 0.0 or hit > s[LD_RANGE_MAX]:
                ranges[i] = math.inf
            elif hit < s[LD_RANGE_MIN]:
                ranges[i] = -math.inf
            else:
                ranges[i] = hit
