"""The optional offscreen video: frames of the robot and its world, into a GIF."""

from __future__ import annotations

import logging

import pytest
from PIL import Image

from twbr_common.params import defaults
from twbr_mujoco.model import MUJOCO_SPECS
from twbr_mujoco.physics import MujocoSimulator
from twbr_mujoco.video import Recording
from twbr_sim.robot_params import ROBOT_SPECS
from twbr_sim.scenario import load_scenario
from twbr_sim.simulator import SIM_SPECS


def test_a_run_is_rendered_with_its_obstacles(tmp_path):
    near = tmp_path / "near.yaml"
    near.write_text("name: near\nduration: 5\ntarget: {position: [3.0, 0.0]}\n"
                    "obstacles: [{id: 1, position: [1.5, 1.0], radius: 0.5}]\n")
    scenario = load_scenario(near)
    sim = MujocoSimulator(defaults(ROBOT_SPECS), {**defaults(SIM_SPECS), **defaults(MUJOCO_SPECS)}, scenario, 7)
    gif = tmp_path / "run.gif"
    recording = Recording(sim, str(gif), 10.0, 1.0, logging.getLogger("test"))
    if recording.renderer is None:
        pytest.skip("no offscreen OpenGL here (MUJOCO_GL=egl needs libEGL with mesa; osmesa needs libOSMesa)")
    for _ in range(10):  # unbalanced torque: it drives off and falls onto its body, every frame differs
        recording.capture()
        sim.offer_command(sim.time, 2.0, 1.0)
        sim.advance(100)
    frame = recording.frames[0]
    recording.close()
    assert gif.stat().st_size > 10_000
    assert Image.open(gif).n_frames == 10
    # Red obstacles are drawn into the scene (MuJoCo's model has none of its own).
    red = (frame[..., 0] > 150) & (frame[..., 1] < 90) & (frame[..., 2] < 90)
    green = (frame[..., 1] > 150) & (frame[..., 0] < 90) & (frame[..., 2] < 90)
    assert red.sum() > 500 and green.sum() > 100  # the obstacle, and the target's capture disc
