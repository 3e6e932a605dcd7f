"""What every node does to its own process once it is built: the CPUs it runs on, and a frozen heap.

cpu_affinity pins the whole process (the Python thread and every DDS thread) to chosen CPUs, as
`taskset -c` does and as ros2_control's `cpu_affinity` does for its control thread: on a robot's
computer, the control loop's processes can then keep CPUs of their own, away from a recorder or a
planner. A parameter rather than a wrapper, so that it travels in the node's parameter file.

The heap is frozen after start-up (gc.freeze): the objects of imports and compiled kernels are never
scanned again, so a full collection in the loop walks only what the loop made, instead of stalling a
realtime loop for tens of milliseconds (benchmarks/README.md).
"""

from __future__ import annotations

import contextlib
import gc
import os
from collections.abc import Callable, Mapping
from dataclasses import replace
from typing import Any

from twbr_common.params import ConfigError, ParamSpec

PROCESS_SPECS: tuple[ParamSpec, ...] = (
    ParamSpec("cpu_affinity", [], "CPUs this node's process runs on, every thread included (as `taskset -c`"
              " does), e.g. [1] or [0, 2]; by default every CPU the process may use", low=0, item=int),
)


def process_specs() -> tuple[ParamSpec, ...]:
    """PROCESS_SPECS with the CPUs this process may use as cpu_affinity's default: rclpy cannot type an empty
    list (it declares a byte array, or a parameter without a value that `ros2 param dump` fails on)."""
    return tuple(replace(s, default=sorted(os.sched_getaffinity(0))) if s.name == "cpu_affinity" else s
                 for s in PROCESS_SPECS)


def check_cpus(cpus: list[int], allowed: set[int], name: str = "cpu_affinity") -> set[int]:
    """The CPUs asked for, each one this process may run on (a container or taskset may allow fewer)."""
    outside = sorted(set(cpus) - allowed)
    if outside:
        raise ConfigError(f"invalid parameter '{name}' = {cpus} (CPU {outside[0]} is not available): must be"
                          f" CPUs this process may use, from {','.join(_ranges(sorted(allowed)))}")
    return set(cpus)


def _ranges(cpus: list[int]) -> list[str]:
    """Sorted CPUs as taskset writes them: [0, 1, 3] -> ['0-1', '3']."""
    runs: list[list[int]] = []
    for cpu in cpus:
        if runs and cpu == runs[-1][1] + 1:
            runs[-1][1] = cpu
        else:
            runs.append([cpu, cpu])
    return [str(first) if first == last else f"{first}-{last}" for first, last in runs]


def pin_process(cpus: set[int]) -> None:
    """Every thread of this process onto `cpus` (sched_setaffinity pins one thread; DDS's already run)."""
    for tid in os.listdir("/proc/self/task"):
        with contextlib.suppress(ProcessLookupError):  # a thread that ended meanwhile
            os.sched_setaffinity(int(tid), cpus)


def settle_process(cfg: Mapping[str, Any], log: Callable[[str], Any]) -> None:
    """Apply the process parameters (PROCESS_SPECS, validated), then freeze the start-up heap."""
    allowed = os.sched_getaffinity(0)
    if cfg["cpu_affinity"] and set(cfg["cpu_affinity"]) != allowed:
        cpus = check_cpus(cfg["cpu_affinity"], allowed)
        pin_process(cpus)
        log(f"pinned to CPU {','.join(_ranges(sorted(cpus)))}")
    gc.collect()
    gc.freeze()
