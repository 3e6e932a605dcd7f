"""The process parameters every node takes: cpu_affinity (checked, applied to every thread) and the
frozen start-up heap."""

from __future__ import annotations

import gc
import os
import subprocess
import sys

import pytest
import rclpy

from twbr_common.node_process import PROCESS_SPECS, check_cpus, process_specs, settle_process
from twbr_common.params import ConfigError
from twbr_common.ros_params import declare

CPUS = sorted(os.sched_getaffinity(0))


def test_cpus_this_process_may_use_are_taken():
    assert check_cpus([CPUS[-1]], set(CPUS)) == {CPUS[-1]}


def test_a_cpu_outside_the_allowed_set_is_refused_naming_the_parameter_and_the_choice():
    with pytest.raises(ConfigError, match=r"invalid parameter 'cpu_affinity' = \[1, 7\] \(CPU 7 is not available\): must"
                                          r" be CPUs this process may use, from 0-1,3"):
        check_cpus([1, 7], {0, 1, 3})


def test_a_negative_cpu_is_refused_by_the_spec():
    (spec,) = PROCESS_SPECS
    with pytest.raises(ConfigError, match=r"'cpu_affinity' = \[-1\]: must be a list of integers in \[0, inf\)"):
        spec.validate([-1])
    with pytest.raises(ConfigError, match="not an integer"):
        spec.validate([0.5])


def test_pinning_moves_every_thread_including_those_started_before():
    # In a child process: pinning the test process would slow the rest of the suite.
    code = (
        "import os, threading, time\n"
        "from twbr_common.node_process import pin_process\n"
        "stop = threading.Event()\n"
        "t = threading.Thread(target=stop.wait); t.start()\n"
        f"pin_process({{{CPUS[-1]}}})\n"
        "print(sorted({tuple(sorted(os.sched_getaffinity(int(tid)))) for tid in os.listdir('/proc/self/task')}))\n"
        "print(len(os.listdir('/proc/self/task')))\n"
        "stop.set(); t.join()\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out[0] == f"[({CPUS[-1]},)]"
    assert int(out[1]) >= 2  # the main thread and the one started before pinning


@pytest.fixture
def node():
    context = rclpy.Context()
    rclpy.init(context=context, args=["--ros-args", "-p", f"cpu_affinity:=[{CPUS[-1]}]"])
    n = rclpy.create_node("process_test", context=context)
    yield n
    n.destroy_node()
    rclpy.try_shutdown(context=context)


def test_cpu_affinity_declares_every_allowed_cpu_by_default_and_takes_an_override(node):
    assert declare(node, process_specs())["cpu_affinity"] == [CPUS[-1]]
    assert declare(node, process_specs(), prefix="other.")["cpu_affinity"] == CPUS  # not set: the default
    # Every parameter has a typed value: GetParameters (`ros2 param dump`) fails for a whole request
    # when one of them has none, as an empty list declared by its type had.
    for name in ("cpu_affinity", "other.cpu_affinity"):
        assert node.get_parameter(name).type_ == rclpy.Parameter.Type.INTEGER_ARRAY
    with pytest.raises(ValueError, match="empty list"):
        declare(node, PROCESS_SPECS, prefix="third.")


def test_settling_freezes_the_start_up_heap():
    gc.unfreeze()
    try:
        settle_process({"cpu_affinity": []}, lambda _text: None)
        assert gc.get_freeze_count() > 1000
    finally:
        gc.unfreeze()
