"""The viewer out of the graph's way: every thread of this process at the CPU's idle priority.

On Linux, SCHED_IDLE threads run only when a core has nothing else to run, and a waking thread of the
graph preempts them at once: the lockstep nodes get the CPU as if the viewer were not there, and the viewer
gets what they leave (its depth-1 best-effort subscriptions then drop what it has no time to draw). The
policy is per thread: the DDS and executor threads rclpy has already started are moved too; threads and
child processes started later (Rerun's, its server) inherit it.
"""

from __future__ import annotations

import os


def run_at_idle_priority() -> str:
    """Move every thread of this process to SCHED_IDLE (else the lowest nice level); says which it got."""
    policy = getattr(os, "SCHED_IDLE", None)
    if policy is not None:
        try:
            for tid in os.listdir("/proc/self/task"):
                os.sched_setscheduler(int(tid), policy, os.sched_param(0))
            return "SCHED_IDLE"
        except (OSError, ValueError):
            pass
    try:
        os.nice(19 - os.nice(0))
    except OSError:
        return "normal"
    return "nice 19"
