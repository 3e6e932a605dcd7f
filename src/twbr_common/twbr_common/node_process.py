"""What every node does to its own process once it is built: the CPUs it runs on, its scheduling
priority, and a frozen heap.

cpu_affinity pins the whole process (the Python thread and every DDS thread) to chosen CPUs, as
`taskset -c` does and as ros2_control's `cpu_affinity` does for its control thread: on a robot's
computer, the control loop's processes can then keep CPUs of their own, away from a recorder or a
planner. A parameter rather than a wrapper, so that it travels in the node's parameter file.

realtime_priority puts every thread under SCHED_FIFO (as `chrt -f` does, and ros2_control's
`thread_priority` for its control thread): the node then runs as soon as its message is in, ahead of every
normally scheduled process, instead of waiting for a core a planner or a recorder holds. The kernel's
realtime throttling (95 % of each second by default) still leaves the rest of the machine a share should it
spin.

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
    ParamSpec("realtime_priority", 0, "SCHED_FIFO priority of every thread of this node's process (as `chrt -f`"
              " does), 1-99: it then runs ahead of every normally scheduled process; 0: the normal scheduler."
              " Needs CAP_SYS_NICE (root) or an rtprio limit at least as high (`ulimit -r`)", low=0, high=99),
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


def _each_thread(apply: Callable[[int], Any]) -> None:
    """`apply` to every thread id of this process: the kernel's calls set one thread, and DDS's already run."""
    for tid in os.listdir("/proc/self/task"):
        with contextlib.suppress(ProcessLookupError):  # a thread that ended meanwhile
            apply(int(tid))


def pin_process(cpus: set[int]) -> None:
    """Every thread of this process onto `cpus`."""
    _each_thread(lambda tid: os.sched_setaffinity(tid, cpus))


def prioritise_process(priority: int, name: str = "realtime_priority") -> None:
    """Every thread of this process under SCHED_FIFO at `priority`; threads started later inherit it."""
    param = os.sched_param(priority)
    try:
        _each_thread(lambda tid: os.sched_setscheduler(tid, os.SCHED_FIFO, param))
    except PermissionError:
        raise ConfigError(
            f"invalid parameter '{name}' = {priority} (not permitted: this process has neither CAP_SYS_NICE"
            f" nor an rtprio limit of {priority}, see `ulimit -r`): must be 0 (the normal scheduler) here,"
            " or the process given the right") from None


def settle_process(cfg: Mapping[str, Any], log: Callable[[str], Any]) -> None:
    """Apply the process parameters (PROCESS_SPECS, validated), then freeze the start-up heap."""
    allowed = os.sched_getaffinity(0)
    if cfg["cpu_affinity"] and set(cfg["cpu_affinity"]) != allowed:
        cpus = check_cpus(cfg["cpu_affinity"], allowed)
        pin_process(cpus)
        log(f"pinned to CPU {','.join(_ranges(sorted(cpus)))}")
    if cfg["realtime_priority"] > 0:
        prioritise_process(cfg["realtime_priority"])
        log(f"realtime priority {cfg['realtime_priority']} (SCHED_FIFO)")
    gc.collect()
    gc.freeze()
