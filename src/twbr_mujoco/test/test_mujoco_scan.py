"""mujoco_driver's scan, cast by MuJoCo's ray tracer, against the simulator's closed-form cast on the same
state: a leaning robot that drives and turns among people who walk, every beam the same within the axle's
settling (MuJoCo's soft contact lowers it by a fraction of a millimetre) and to the same REP 117 value."""

from __future__ import annotations

import math
from dataclasses import replace

import mujoco
import numpy as np
import pytest

from twbr_common.params import defaults
from twbr_mujoco.model import MUJOCO_SPECS
from twbr_mujoco.physics import MujocoSimulator
from twbr_sim import dynamics as dyn
from twbr_sim.robot_params import ROBOT_SPECS, robot_params
from twbr_sim.scenario import load_scenario
from twbr_sim.scenario_files import find_scenario
from twbr_sim.simulator import SIM_SPECS, Simulator

ROBOT = defaults(ROBOT_SPECS)
NOISE_FREE = {**defaults(SIM_SPECS), **defaults(MUJOCO_SPECS), "lidar.range_noise_std": 0.0, "lidar.dropout": 0.0}


def driving(mj: MujocoSimulator, ideal: Simulator, speed: float, yaw_rate: float) -> None:
    """Both engines at speed [m/s] and yaw rate [rad/s] (the free joint's body-frame rates for MuJoCo)."""
    pitch, yaw = ideal.state[dyn.S_TH], ideal.state[dyn.S_PSI]
    mj.data.qvel[0:2] = speed * math.cos(yaw), speed * math.sin(yaw)
    mj.data.qvel[3], mj.data.qvel[5] = -yaw_rate * math.sin(pitch), yaw_rate * math.cos(pitch)
    mujoco.mj_forward(mj.model, mj.data)
    mj._read_state()
    ideal.state[dyn.S_XD], ideal.state[dyn.S_PSID] = speed, yaw_rate


@pytest.mark.parametrize(("pitch", "speed", "yaw_rate"), [(0.0, 0.0, 0.0), (0.08, 0.5, 0.8), (-0.05, -0.3, -1.0)])
def test_mujocos_rays_see_what_the_closed_form_cast_sees(pitch, speed, yaw_rate):
    scenario = replace(load_scenario(find_scenario("suite/crowd_crossing")), start_pitch=pitch)
    mj = MujocoSimulator(ROBOT, dict(NOISE_FREE), scenario, 3)
    ideal = Simulator(robot_params(ROBOT), dict(NOISE_FREE), scenario, 3)
    driving(mj, ideal, speed, yaw_rate)
    for sim in (mj, ideal):  # the people 2 s into their walks
        sim.world.advance_to(2.0, (sim.state[dyn.S_XC], sim.state[dyn.S_YC]))
    assert sum(math.hypot(o.vx, o.vy) > 0.2 for o in ideal.world.obstacles()) >= 8
    assert mj.state[dyn.S_PSID] == pytest.approx(yaw_rate) and mj.state[dyn.S_TH] == pytest.approx(pitch)
    a, b = mj.scan(), ideal.scan()
    assert np.array_equal(np.isfinite(a), np.isfinite(b)) and np.array_equal(np.sign(a), np.sign(b))
    hits = np.isfinite(a)
    assert hits.sum() >= 20  # people in view (and the floor, when it leans)
    floor = np.zeros_like(hits)
    if pitch != 0.0:  # beams tipped down meet the floor: there the axle's settling shows, over the lean
        down = np.cos(-math.pi + math.radians(1.0) * np.arange(len(a))) * math.sin(pitch) > 0.0
        floor = down & (np.abs(b - (ROBOT["wheel_radius"] + 0.25 * math.cos(pitch)) / np.where(down, np.cos(
            -math.pi + math.radians(1.0) * np.arange(len(a))) * math.sin(pitch), 1.0)) < 1e-6)
        assert floor.any()
        assert np.max(np.abs(a[floor] - b[floor])) < 0.01
    assert np.max(np.abs(a[hits & ~floor] - b[hits & ~floor])) < 1e-3  # the people's sides
