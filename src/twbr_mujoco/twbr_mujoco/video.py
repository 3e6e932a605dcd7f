"""An offscreen recording of a MuJoCo run, with the world's target and obstacles drawn in: a GIF for the
README or a bug report. Optional: without an OpenGL backend it says so once and records nothing."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from twbr_mujoco.model import CHASSIS

WIDTH, HEIGHT = 320, 240
OBSTACLE_HEIGHT = 0.5  # [m], only for the picture
TARGET_RGBA = np.array([0.1, 0.8, 0.2, 0.8], dtype=np.float32)
OBSTACLE_RGBA = np.array([0.8, 0.2, 0.2, 0.8], dtype=np.float32)


class Recording:
    def __init__(self, sim: Any, path: str, rate: float, speed: float, logger: Any) -> None:
        self.sim = sim
        self.path = Path(path)
        self.period = 1.0 / rate
        self.frame_ms = round(1000.0 * self.period / speed)
        self.next_frame = 0.0
        self.frames: list[np.ndarray] = []
        self.logger = logger
        try:
            self.renderer = mujoco.Renderer(sim.model, HEIGHT, WIDTH)
        except Exception as e:  # no display and no EGL/OSMesa: the run goes on without a video
            self.renderer = None
            logger.warning(f"mujoco.video: no OpenGL backend ({e}); set MUJOCO_GL=egl or osmesa. No video.")
            return
        self.camera = mujoco.MjvCamera()
        self.camera.type = mujoco.mjtCamera.mjCAMERA_TRACKING
        self.camera.trackbodyid = sim.model.body(CHASSIS).id
        self.camera.distance = 6.0
        self.camera.elevation = -45.0
        self.camera.azimuth = 135.0

    def capture(self) -> None:
        if self.renderer is None or self.sim.time + 1e-9 < self.next_frame:
            return
        self.next_frame += self.period
        self.renderer.update_scene(self.sim.data, self.camera)
        world = self.sim.world
        if world is not None:
            scene = self.renderer.scene
            target = world.target()
            marks = [(o.x, o.y, o.radius, OBSTACLE_RGBA) for o in world.obstacles()]
            if target is not None:
                marks.append((target.x, target.y, world.capture_radius, TARGET_RGBA))
            for x, y, radius, rgba in marks:
                if scene.ngeom >= scene.maxgeom:
                    break
                mujoco.mjv_initGeom(scene.geoms[scene.ngeom], mujoco.mjtGeom.mjGEOM_CYLINDER,
                                    np.array([radius, 0.5 * OBSTACLE_HEIGHT, 0.0]),
                                    np.array([x, y, 0.5 * OBSTACLE_HEIGHT]), np.eye(3).ravel(), rgba)
                scene.ngeom += 1
        self.frames.append(self.renderer.render().copy())

    def close(self) -> None:
        if self.renderer is None:
            return
        self.renderer.close()
        self.renderer = None
        if not self.frames:
            return
        from PIL import Image

        images = [Image.fromarray(f) for f in self.frames]
        self.path.parent.mkdir(parents=True, exist_ok=True)
        images[0].save(self.path, save_all=True, append_images=images[1:], duration=self.frame_ms,
                       loop=0, optimize=True)
        self.logger.info(f"mujoco.video: {len(images)} frames to {self.path}")
