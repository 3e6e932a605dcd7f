"""The roofline's flop counter (benchmarks/flop_count.py) counts what a kernel executes."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

BENCHMARKS = Path(__file__).parent.parent / "benchmarks"

COUNT = """
import json, sys
sys.path.insert(0, {here!r})
import flop_count as fc
from twbr_sim import dynamics as dyn
from twbr_sim.robot_params import robot_params
p = fc.counted_array(robot_params())
with fc.counting() as tally:
    dyn.mechanical_accelerations(p, fc.Counted(0.3), fc.Counted(0.05), fc.Counted(-0.2), fc.Counted(0.4),
                                 fc.Counted(0.5), fc.Counted(-0.1))
    one = dict(tally)
    tally.clear()
    s, work = fc.counted_array(dyn.initial_state(pitch=0.05)), fc.counted_array(dyn.new_work())
    dyn.rk4_step(p, s, fc.Counted(0.5), fc.Counted(-0.1), 1e-3, work)
    step = dict(tally)
print(json.dumps({{"accelerations": one, "rk4_step": step}}))
"""


def _count() -> dict:
    done = subprocess.run([sys.executable, "-c", COUNT.format(here=str(BENCHMARKS))],
                          env={**os.environ, "TWBR_JIT": "off"}, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout)


def test_the_counter_counts_the_equations_of_motion_as_written():
    # mechanical_accelerations (dynamics.md's 3-DOF model), counted by hand: multiplies 1 (b) + 1 (slip)
    # + 6 (rhs_x) + 7 (rhs_th) + 2 (det) + 3 + 3 (x'', pitch'') + 2 (yaw inertia) + 8 (yaw'') = 33; adds
    # 5, subtracts 11, divides 2, one sine and one cosine; a negation is a sign flip, not a flop.
    counts = _count()
    assert counts["accelerations"] == {"mul": 33, "add": 5, "sub": 11, "div": 2, "sin": 1, "cos": 1}
    step = counts["rk4_step"]
    # An RK4 step evaluates the model four times (one sin/cos pair for the pitch and one for the heading
    # each time), and its flops are four evaluations' and the stages' sums.
    assert step["sin"] == step["cos"] == 8
    flops = step["mul"] + step["add"] + step["sub"] + step["div"]
    assert 4 * 49 < flops < 700, step
