"""The TWBR simulated by MuJoCo, as a driver on the twbr contract."""

import os

# MuJoCo picks its OpenGL backend when first imported: on a machine without a display, offscreen EGL
# (mesa's software renderer will do) rather than GLFW, which needs one. Only the optional video uses it.
if "MUJOCO_GL" not in os.environ and not os.environ.get("DISPLAY"):
    os.environ["MUJOCO_GL"] = "egl"
