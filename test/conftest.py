"""End-to-end harness: real node processes on an isolated DDS domain, discovery on loopback only.

Every test gets its own ROS_DOMAIN_ID, so a process that outlives a test cannot talk to the next one,
and every process a test starts is stopped (SIGINT, then SIGKILL of its process group) even when the
test fails.
"""

from __future__ import annotations

import contextlib
import itertools
import os
import signal
import subprocess
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
INSTALL = ROOT / "install"
CONFIG = ROOT / "config"
_domains = itertools.count()


def executable(package: str, name: str) -> Path:
    """Where `ros2 run <package> <name>` would find it."""
    path = INSTALL / package / "lib" / package / name
    if not path.exists():
        pytest.fail(f"{path} is not built: run `make setup` first")
    return path


class NodeProcess:
    def __init__(self, argv: list[str], env: dict[str, str], log_dir: Path, name: str) -> None:
        self.name = name
        self.stdout_path = log_dir / f"{name}.out"
        self.stderr_path = log_dir / f"{name}.err"
        self._out = self.stdout_path.open("w")
        self._err = self.stderr_path.open("w")
        self.proc = subprocess.Popen(argv, env=env, stdout=self._out, stderr=self._err, start_new_session=True)

    def wait(self, timeout: float) -> int:
        return self.proc.wait(timeout=timeout)

    @property
    def stderr(self) -> str:
        self._err.flush()
        return self.stderr_path.read_text()

    @property
    def output(self) -> str:
        self._out.flush()
        self._err.flush()
        return self.stdout_path.read_text() + self.stderr_path.read_text()

    def stop(self, timeout: float = 5.0) -> int | None:
        if self.proc.poll() is None:
            try:
                os.killpg(self.proc.pid, signal.SIGINT)
                self.proc.wait(timeout=timeout)
            except (subprocess.TimeoutExpired, ProcessLookupError):
                pass
        if self.proc.poll() is None:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(self.proc.pid, signal.SIGKILL)
            self.proc.wait(timeout=timeout)
        self._out.close()
        self._err.close()
        return self.proc.returncode


@pytest.fixture
def ros_domain() -> int:
    # Distinct per test and per pytest process; 0..232 are valid Fast DDS domains.
    return 120 + (os.getpid() * 7 + next(_domains)) % 100


@pytest.fixture
def ros_env(ros_domain: int) -> dict[str, str]:
    env = dict(os.environ)
    env["ROS_DOMAIN_ID"] = str(ros_domain)
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    env.pop("ROS_STATIC_PEERS", None)
    env["PYTHONUNBUFFERED"] = "1"
    env["RCUTILS_LOGGING_BUFFERED_STREAM"] = "0"
    return env


@pytest.fixture
def launch(ros_env: dict[str, str], tmp_path: Path) -> Iterator[Callable[..., NodeProcess]]:
    """Start `package executable` with ROS arguments as a separate process; all are stopped afterwards."""
    started: list[NodeProcess] = []

    def start(package: str, name: str, *ros_args: str, params: tuple[str, ...] = ()) -> NodeProcess:
        argv = [str(executable(package, name)), "--ros-args"]
        for p in params:
            argv += ["--params-file", str(CONFIG / p)]
        argv += list(ros_args)
        proc = NodeProcess(argv, ros_env, tmp_path, f"{name}-{len(started)}")
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
