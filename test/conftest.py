"""End-to-end harness: real node processes on an isolated DDS domain, discovery on loopback only.

Every test gets its own ROS_DOMAIN_ID, so a process that outlives a test cannot talk to the next one,
and every process a test starts is stopped (SIGINT, then SIGKILL of its process group) even when the
test fails.
"""

from __future__ import annotations

import itertools
import os
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from twbr_runner.spawn import NodeProcess, loopback_env, start_node

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "config"
_domains = itertools.count()


@pytest.fixture
def ros_domain() -> int:
    # Distinct per test and per pytest process; 0..232 are valid Fast DDS domains.
    return 120 + (os.getpid() * 7 + next(_domains)) % 100


@pytest.fixture
def ros_env(ros_domain: int) -> dict[str, str]:
    return loopback_env(ros_domain)


@pytest.fixture
def launch(ros_env: dict[str, str], tmp_path: Path) -> Iterator[Callable[..., NodeProcess]]:
    """Start `package executable` with ROS arguments as a separate process; all are stopped afterwards."""
    started: list[NodeProcess] = []

    def start(package: str, name: str, *ros_args: str, params: tuple[str, ...] = ()) -> NodeProcess:
        args = [a for p in params for a in ("--params-file", str(CONFIG / p))] + list(ros_args)
        proc = start_node(package, name, args, ros_env, tmp_path, f"{name}-{len(started)}")
        started.append(proc)
        return proc

    yield start
    for proc in started:
        proc.stop()


@pytest.fixture
def ros(ros_domain: int):
    """An rclpy context on the test's domain with one node and an executor, for the test's side of the graph."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=ros_domain)
    node = rclpy.create_node("e2e_test", context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)

    class Ros:
        def __init__(self) -> None:
            self.node = node
            self.executor = executor

        def spin_until(self, condition: Callable[[], bool], timeout: float) -> bool:
            deadline = time.monotonic() + timeout
            while time.monotonic() < deadline:
                if condition():
                    return True
                executor.spin_once(timeout_sec=0.02)
            return condition()

        def spin_for(self, seconds: float) -> None:
            self.spin_until(lambda: False, seconds)

    yield Ros()
    executor.shutdown()
    node.destroy_node()
    rclpy.shutdown(context=context)


def assert_refused_at_start(proc: NodeProcess, *expected: str) -> None:
    """The node exited with code 2 and one FATAL line that says every expected piece (name, range)."""
    assert proc.wait(timeout=30) == 2
    fatal = [line for line in proc.stderr.splitlines() if "FATAL" in line]
    assert len(fatal) == 1, proc.stderr
    for piece in expected:
        assert piece in fatal[0], (piece, fatal[0])
    assert "Traceback" not in proc.output


def recorded_file(where: Path, pattern: str, over_bytes: int, timeout: float,
                  running: Callable[[], bool] = lambda: True) -> Path | None:
    """The first bag file under `where` matching `pattern` with more than `over_bytes` on disk: the recorder
    flushes its chunks as the run goes, so the run is driving, not just started (a loaded machine may take
    seconds to bring a graph up: a fixed sleep is not enough). None after `timeout` s or once not running()."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and running():
        for f in where.glob(pattern):
            if f.stat().st_size > over_bytes:
                return f
        time.sleep(0.1)
    return None


@pytest.fixture
def small_disk(tmp_path: Path) -> Iterator[Callable[[int], Path]]:
    """A filesystem of a few MB (a tmpfs mounted for the test, unmounted after), to fill to the last byte.
    Mounting needs root (CI and the set-up run as root here); elsewhere the test says why it skips."""
    import shutil
    import subprocess

    mounted: list[Path] = []

    def mount(megabytes: int) -> Path:
        where = tmp_path / f"disk{len(mounted)}"
        where.mkdir()
        if os.geteuid() != 0 or shutil.which("mount") is None:
            pytest.skip("a full disk needs a small filesystem: mounting a tmpfs needs root")
        done = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={megabytes}m", "tmpfs", str(where)],
                              capture_output=True, text=True)
        if done.returncode != 0:
            pytest.skip(f"cannot mount a {megabytes} MB tmpfs here: {done.stderr.strip()}")
        mounted.append(where)
        return where

    yield mount
    for where in mounted:
        subprocess.run(["umount", "-l", str(where)], capture_output=True)
