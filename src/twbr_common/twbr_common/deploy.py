"""The executable of the node a robot's own computer runs at 200 Hz (controller_node): its cores interpreted
unless TWBR_JIT says otherwise.

At 200 Hz the interpreter is fast enough (the controller's step takes ~30 µs against ~9 µs compiled), and
without numba's LLVM the node is about 75 MiB instead of 195 and starts in about half the time. The same
kernels run either way (twbr_common.jit). TWBR_JIT=on compiles them, as the simulator always does.
planner_node compiles by default (twbr_planner.planner_main: its robust step among people is tens of ms
interpreted, benchmarks/results/planner_interpreted.json).
"""

from __future__ import annotations

import importlib
import os

JIT_ENV = "TWBR_JIT"  # read by twbr_common.jit when the first kernel module is imported


def run_interpreted(module: str, args: list[str] | None = None) -> int:
    """`module.main(args)` with TWBR_JIT defaulting to off (it must be set before the cores are imported)."""
    os.environ.setdefault(JIT_ENV, "off")
    return importlib.import_module(module).main(args)
