"""The roofline's flop counter (benchmarks/flop_count.py) counts what a kernel executes."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ARITHMETIC = ("mul", "add", "sub", "div")
BENCHMARKS = Path(__file__).parent.parent / "benchmarks"

COUNT = """
import json, sys
sys.path.insert(0, {here!r})
import flop_count as fc
from twbr_common.trig import sincos
from twbr_sim import dynamics as dyn
from twbr_sim.robot_params import robot_params
p = fc.counted_array(robot_params())
with fc.counting() as tally:
    sincos(fc.Counted(0.05))
    pair = dict(tally)
    tally.clear()
    dyn.mechanical_accelerations(p, fc.Counted(0.3), fc.Counted(0.05), fc.Counted(-0.2), fc.Counted(0.4),
                                 fc.Counted(0.5), fc.Counted(-0.1))
    one = dict(tally)
    tally.clear()
    s, work = fc.counted_array(dyn.initial_state(pitch=0.05)), fc.counted_array(dyn.new_work())
    dyn.rk4_step(p, s, fc.Counted(0.5), fc.Counted(-0.1), 1e-3, work)
    step = dict(tally)
print(json.dumps({{"sincos": pair, "accelerations": one, "rk4_step": step}}))
"""


def _count() -> dict:
    done = subprocess.run([sys.executable, "-c", COUNT.format(here=str(BENCHMARKS))],
                          env={**os.environ, "TWBR_JIT": "off"}, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout)


def test_the_counter_counts_the_equations_of_motion_as_written():
    counts = _count()
    # sincos (Cephes, twbr_common.trig), counted by hand: multiplies 1 (n) + 1 (y) + 3 (r) + 1 (z) + 7 (sin)
    # + 8 (cos) + 2 (quadrant) = 23; adds 1 + 6 + 6 + 1 = 14; subtracts 1 + 3 + 1 + 2 = 7; comparisons
    # choose the quadrant.
    pair = counts["sincos"]
    assert {k: pair.get(k, 0) for k in ARITHMETIC} == {"mul": 23, "add": 14, "sub": 7, "div": 0}
    assert pair["compare"] > 0
    # mechanical_accelerations (dynamics.md's 3-DOF model), counted by hand: multiplies 1 (b) + 1 (slip)
    # + 6 (rhs_x) + 7 (rhs_th) + 2 (det) + 3 + 3 (x'', pitch'') + 2 (yaw inertia) + 8 (yaw'') = 33; adds
    # 5, subtracts 11, divides 2, and one sincos of the pitch; a negation is a sign flip, not a flop.
    one = counts["accelerations"]
    assert {k: one.get(k, 0) for k in ARITHMETIC} == {"mul": 33 + 23, "add": 5 + 14, "sub": 11 + 7, "div": 2}
    assert not {"sin", "cos"} & one.keys()  # no libm call left in the equations of motion
    step = counts["rk4_step"]
    # An RK4 step evaluates the model four times (a sincos for the pitch and one for the heading each
    # time), and its flops are four evaluations' and the stages' sums.
    flops = step["mul"] + step["add"] + step["sub"] + step["div"]
    assert 4 * (49 + 2 * 44) < flops < 900, step
    assert not {"sin", "cos"} & step.keys()
