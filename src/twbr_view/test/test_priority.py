"""The viewer takes only CPU time the graph leaves: every thread of its process, those started before the
call (rclpy's) and after it (Rerun's), and its children, at Linux's idle scheduling policy."""

import os
import subprocess
import sys

import pytest

PROGRAM = """
import os, subprocess, sys, threading, time
from twbr_view.priority import run_at_idle_priority
stop = threading.Event()
threading.Thread(target=stop.wait, daemon=True).start()  # started before, as rclpy's are
print(run_at_idle_priority())
threading.Thread(target=stop.wait, daemon=True).start()  # started after, as Rerun's are
time.sleep(0.1)
print(sorted({os.sched_getscheduler(int(t)) for t in os.listdir('/proc/self/task')}))
child = subprocess.run([sys.executable, '-c', 'import os; print(os.sched_getscheduler(0))'], capture_output=True,
                       text=True, check=True)
print(child.stdout.strip())
"""


@pytest.mark.skipif(not hasattr(os, "SCHED_IDLE"), reason="SCHED_IDLE is Linux's")
def test_every_thread_and_child_runs_at_idle_priority():
    lines = subprocess.run([sys.executable, "-c", PROGRAM], capture_output=True, text=True, check=True,
                           timeout=60).stdout.split("\n")
    assert lines[0] == "SCHED_IDLE"
    assert lines[1] == str([os.SCHED_IDLE])
    assert lines[2] == str(os.SCHED_IDLE)
