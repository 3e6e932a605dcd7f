"""The process parameters every node takes: cpu_affinity and realtime_priority (checked, applied to every
thread) and the frozen start-up heap."""

from __future__ import annotations

import gc
import os
import resource
import subprocess
import sys

import pytest
import rclpy

from twbr_common import node_process
from twbr_common.node_process import PROCESS_SPECS, check_cpus, prioritise_process, process_specs, settle_process
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
    spec = next(s for s in PROCESS_SPECS if s.name == "cpu_affinity")
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


def test_a_realtime_priority_outside_0_to_99_is_refused_by_the_spec():
    spec = next(s for s in PROCESS_SPECS if s.name == "realtime_priority")
    assert spec.default == 0  # the normal scheduler unless asked
    for bad in (100, -1):
        with pytest.raises(ConfigError, match=rf"'realtime_priority' = {bad}: must be \[0, 99\]"):
            spec.validate(bad)


def may_use_fifo() -> bool:
    return os.geteuid() == 0 or resource.getrlimit(resource.RLIMIT_RTPRIO)[0] >= 1


@pytest.mark.skipif(not may_use_fifo(), reason="SCHED_FIFO needs root or an rtprio limit (ulimit -r) here")
def test_realtime_priority_puts_every_thread_under_fifo_including_those_started_before():
    # In a child process: a FIFO test process would starve the rest of the suite.
    code = (
        "import os, threading\n"
        "from twbr_common.node_process import prioritise_process\n"
        "stop = threading.Event()\n"
        "t = threading.Thread(target=stop.wait); t.start()\n"
        "prioritise_process(3)\n"
        "late = threading.Thread(target=stop.wait); late.start()  # started after: inherits it\n"
        "tids = [int(tid) for tid in os.listdir('/proc/self/task')]\n"
        "print(len(tids), sorted({(os.sched_getscheduler(t), os.sched_getparam(t).sched_priority) for t in tids}))\n"
        "stop.set(); t.join(); late.join()\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    count, policies = out.split(" ", 1)
    assert int(count) >= 3
    assert policies.strip() == f"[({os.SCHED_FIFO}, 3)]"


def test_a_realtime_priority_the_process_may_not_take_is_refused_naming_the_parameter(monkeypatch):
    def refuse(*_args):
        raise PermissionError(1, "Operation not permitted")

    monkeypatch.setattr(node_process.os, "sched_setscheduler", refuse)
    with pytest.raises(ConfigError, match=r"invalid parameter 'realtime_priority' = 50 \(not permitted: .*CAP_SYS_NICE"
                                          r".*ulimit -r.*\): must be 0 \(the normal scheduler\)"):
        prioritise_process(50)


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
        settle_process({"cpu_affinity": [], "realtime_priority": 0}, lambda _text: None)
        assert gc.get_freeze_count() > 1000
    finally:
        gc.unfreeze()
