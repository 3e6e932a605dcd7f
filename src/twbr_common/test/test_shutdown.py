"""A node whose teardown hangs (as Fast DDS's participant deletion can) still ends its process."""

from __future__ import annotations

import os
import subprocess
import sys
import time

# The child: a node that runs once and whose destroy_node never returns, holding the GIL in C as
# rcl_node_fini does when it hangs (a busy loop of C calls that never releases it for long).
CHILD = """
import sys
import rclpy
from rclpy.node import Node
from twbr_common import ros_params

ros_params.SHUTDOWN_GRACE_S = {grace}

class Stuck(Node):
    def __init__(self):
        super().__init__("stuck_teardown")

    def run(self):
        print("ran", flush=True)

    def destroy_node(self):
        print("tearing down", flush=True)
        if {hang}:
            while True:
                sum(range(100_000))
        super().destroy_node()

sys.exit(ros_params.run_node("stuck_teardown", Stuck, ["stuck_teardown"]))
"""


def run_child(hang: bool, grace: float) -> tuple[subprocess.CompletedProcess, float]:
    env = {**os.environ, "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
           "ROS_DOMAIN_ID": str(150 + os.getpid() % 70)}
    started = time.monotonic()
    done = subprocess.run([sys.executable, "-c", CHILD.format(grace=grace, hang=hang)], env=env,
                          capture_output=True, text=True, timeout=60)
    return done, time.monotonic() - started


def test_a_teardown_that_hangs_ends_the_process_after_the_grace_with_the_stuck_call_named():
    done, wall = run_child(hang=True, grace=1.0)
    assert done.stdout.split() == ["ran", "tearing", "down"]
    assert done.returncode == 1
    assert "Timeout (0:00:01)!" in done.stderr
    assert "destroy_node" in done.stderr  # where it hung, for the bug report
    assert wall < 20.0  # ended by the watchdog, not by the test's own timeout


def test_a_normal_teardown_is_not_cut_short_and_exits_zero():
    done, _ = run_child(hang=False, grace=5.0)
    assert done.returncode == 0, done.stderr
    assert "Timeout" not in done.stderr
