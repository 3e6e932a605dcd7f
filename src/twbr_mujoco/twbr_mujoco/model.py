"""The TWBR as a MuJoCo multibody model, written from the same robot parameters as the ideal model.

A chassis on a free joint (6 DOF: it can roll, hop and fall), its frame at the axle centre and its centre
of mass l above it; two wheels on hinge joints about the axle with the wheel-body friction c_alpha as joint
damping; each wheel touches the floor through a sphere of the wheel's radius, which gives the ideal model's
point contact under the axle (a cylinder would add two rim contacts and a scrub torque the ideal model does
not have). Contact is soft (MuJoCo's solref/solimp) with an elliptic friction cone; no rolling or
torsional friction. The motors are not MuJoCo actuators' dynamics: `motor` integrates twbr's DC motor and
current-loop driver and applies N k i to each hinge through a plain torque actuator.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from twbr_common.params import ParamSpec

MUJOCO_SPECS: tuple[ParamSpec, ...] = (
    ParamSpec("robot_file", "", "robot.yaml whose sim_node section the multibody model is built from; empty:"
              " the installed config/robot.yaml"),
    ParamSpec("mujoco.contact_time_constant", 0.004, "stiffness of the wheel-ground contact as MuJoCo's solref"
              " time constant (critically damped); at least twice the physics step", "s", 1e-4, 0.1),
    ParamSpec("mujoco.impratio", 10.0, "ratio of frictional to normal constraint impedance (higher: less creep"
              " of a rolling wheel under soft contact)", "", 1.0, 1000.0),
    ParamSpec("mujoco.integrator", "implicitfast", "MuJoCo's integrator",
              choices=("Euler", "implicit", "implicitfast", "RK4")),
    ParamSpec("mujoco.slip_speed", 0.05, "a wheel whose contact point slides faster than this over the floor is"
              " reported slipping", "m/s", 0.0, 10.0, low_open=True),
    ParamSpec("mujoco.video", "", "render the run offscreen into this GIF when the node stops (needs an OpenGL"
              " backend: MUJOCO_GL=egl or osmesa); empty: no video"),
    ParamSpec("mujoco.video_rate", 4.0, "frames per second of sim time in the video", "Hz", 0.1, 120.0),
    ParamSpec("mujoco.video_speed", 8.0, "playback speed of the video: sim seconds per second shown", "", 0.1,
              100.0),
)

LEFT_WHEEL, RIGHT_WHEEL = "left_wheel", "right_wheel"
LEFT_JOINT, RIGHT_JOINT = "left_wheel_joint", "right_wheel_joint"
LEFT_TYRE, RIGHT_TYRE = "left_tyre", "right_tyre"
CHASSIS = "chassis"
FLOOR = "floor"


def mjcf(robot: Mapping[str, Any], settings: Mapping[str, Any], timestep: float) -> str:
    """The MJCF document of the robot on a floor (chassis at the origin, upright: `place` sets the pose)."""
    r = robot["wheel_radius"]
    d = robot["wheel_separation"]
    l_com = robot["com_height"]
    mu = settings["traction.friction"]  # the one friction coefficient of both engines
    # Body geometry only for the picture and for the ground contact of a fallen robot: the inertia is given.
    half_width = max(0.5 * d - 0.06, 0.02)
    half_height = max(l_com, 0.05)
    wheel_width = min(0.04, 0.5 * d)
    solref = f"{settings['mujoco.contact_time_constant']:.9g} 1"
    wheels = []
    for name, joint, tyre, side in ((LEFT_WHEEL, LEFT_JOINT, LEFT_TYRE, 1.0), (RIGHT_WHEEL, RIGHT_JOINT, RIGHT_TYRE, -1.0)):
        wheels.append(f"""
      <body name="{name}" pos="0 {side * 0.5 * d:.9g} 0">
        <joint name="{joint}" type="hinge" axis="0 1 0" damping="{robot['wheel_friction']:.9g}"/>
        <inertial pos="0 0 0" mass="{robot['wheel_mass']:.9g}"
                  diaginertia="{robot['wheel_yaw_inertia']:.9g} {robot['wheel_inertia']:.9g} {robot['wheel_yaw_inertia']:.9g}"/>
        <geom name="{tyre}" type="sphere" size="{r:.9g}" condim="3" friction="{mu:.9g} 0 0" solref="{solref}"
              rgba="0 0 0 0" group="3"/>
        <geom type="cylinder" size="{r:.9g} {0.5 * wheel_width:.9g}" zaxis="0 1 0" contype="0" conaffinity="0"
              rgba="0.15 0.15 0.15 1"/>
        <geom type="box" size="{0.8 * r:.9g} {0.5 * wheel_width + 0.002:.9g} {0.08 * r:.9g}" contype="0"
              conaffinity="0" rgba="0.9 0.6 0.1 1"/>
      </body>""")
    return f"""<mujoco model="twbr">
  <compiler angle="radian" autolimits="true"/>
  <option timestep="{timestep:.9g}" gravity="0 0 {-robot['gravity']:.9g}" integrator="{settings['mujoco.integrator']}"
          cone="elliptic" impratio="{settings['mujoco.impratio']:.9g}"/>
  <visual><global offwidth="640" offheight="480"/></visual>
  <asset>
    <texture name="grid" type="2d" builtin="checker" width="512" height="512" rgb1="0.85 0.85 0.85"
             rgb2="0.7 0.7 0.7"/>
    <material name="grid" texture="grid" texrepeat="1 1" texuniform="true"/>
  </asset>
  <worldbody>
    <light pos="0 0 4" dir="0 0 -1" directional="true"/>
    <geom name="{FLOOR}" type="plane" size="0 0 0.05" material="grid" friction="{mu:.9g} 0 0" solref="{solref}"/>
    <body name="{CHASSIS}" pos="0 0 {r:.9g}">
      <freejoint name="root"/>
      <inertial pos="0 0 {l_com:.9g}" mass="{robot['body_mass']:.9g}"
                diaginertia="{robot['body_inertia_roll']:.9g} {robot['body_inertia_pitch']:.9g} {robot['body_inertia_yaw']:.9g}"/>
      <geom name="body" type="box" pos="0 0 {half_height:.9g}" size="0.05 {half_width:.9g} {half_height:.9g}"
            rgba="0.2 0.4 0.8 1"/>
      <site name="imu" pos="0 0 0"/>{''.join(wheels)}
    </body>
  </worldbody>
  <actuator>
    <motor name="left_motor" joint="{LEFT_JOINT}"/>
    <motor name="right_motor" joint="{RIGHT_JOINT}"/>
  </actuator>
  <sensor>
    <gyro name="gyro" site="imu"/>
    <accelerometer name="accelerometer" site="imu"/>
  </sensor>
</mujoco>
"""
