"""TWBR_JIT=off (the deployable nodes' default) runs the same kernels as plain Python: the same numbers,
and no numba in the process."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from twbr_batch.closed_loop import PlannerReference, run_closed_loop
from twbr_sim.scenario import load_scenario
from twbr_sim.scenario_files import find_scenario

RUN = """
import json, sys
from twbr_batch.closed_loop import PlannerReference, run_closed_loop
from twbr_sim.scenario import load_scenario
from twbr_sim.scenario_files import find_scenario
trace = run_closed_loop(5.0, PlannerReference(), scenario=load_scenario(find_scenario("dynamic_obstacles")), seed=7)
print(json.dumps({"x": float(trace.x_c[-1]), "y": float(trace.y_c[-1]), "pitch": float(trace["pitch"][-1]),
                  "numba_loaded": "numba" in sys.modules or "llvmlite" in sys.modules}))
"""


def test_the_closed_loop_interpreted_matches_the_compiled_one():
    """Planner, controller, simulator and sensors interpreted: 5 s among moving obstacles end where the
    compiled kernels end, to rounding (the compiled ones may fuse a multiply-add)."""
    done = subprocess.run([sys.executable, "-c", RUN], env={**os.environ, "TWBR_JIT": "off"}, capture_output=True,
                          text=True, timeout=300, check=True)
    interpreted = json.loads(done.stdout)
    assert not interpreted["numba_loaded"]
    assert "Warning" not in done.stderr, done.stderr
    trace = run_closed_loop(5.0, PlannerReference(), scenario=load_scenario(find_scenario("dynamic_obstacles")),
                            seed=7)
    assert interpreted["x"] == pytest.approx(float(trace.x_c[-1]), abs=1e-9)
    assert interpreted["y"] == pytest.approx(float(trace.y_c[-1]), abs=1e-9)
    assert interpreted["pitch"] == pytest.approx(float(trace["pitch"][-1]), abs=1e-9)
    assert abs(float(trace.x_c[-1])) > 0.1  # the robot did move: the comparison means something


def test_an_unknown_jit_mode_is_refused_by_name():
    done = subprocess.run([sys.executable, "-c", "import twbr_common.jit"], env={**os.environ, "TWBR_JIT": "maybe"},
                          capture_output=True, text=True, timeout=60)
    assert done.returncode != 0 and "TWBR_JIT" in done.stderr and "on, off" in done.stderr


STATUS = """
from rclpy.serialization import serialize_message
from twbr_msgs.msg import SimStatus
from twbr_sim.robot_params import robot_params
from twbr_common.params import defaults, validate_all
from twbr_sim.simulator import SIM_SPECS, Simulator
sim = Simulator(robot_params(), validate_all(SIM_SPECS, {**defaults(SIM_SPECS), "traction.friction": 0.8}), None, 0)
sim.offer_command(0.0, 0.5, -0.5)
sim.advance(5)
sample = sim.sense()
msg = SimStatus(fallen=sim.fallen, torque_saturated=sim.torque_saturated, command_stale=sim.command_stale,
                wheel_lifted=sim.traction.lifted, wheel_slipping=sim.traction.slipping)
print(len(serialize_message(msg)), type(sample.wheel_lifted).__name__)
"""


def test_the_interpreted_simulator_fills_a_status_message():
    """Before: interpreted, the traction flags were numpy bools, and building sim_status aborted sim_node
    (`PyBool_Check(field)` failed) at its first status."""
    done = subprocess.run([sys.executable, "-c", STATUS], env={**os.environ, "TWBR_JIT": "off"}, capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.split()[1] == "bool"
