"""Node processes started the way a user starts them in separate terminals (`ros2 run` paths).

Used by the demo, the benchmarks and the end-to-end tests: each process gets its own session, its
output goes to files, and stop() ends the whole process group (SIGINT first, then SIGKILL). Each dies
with the process that started it (SIGTERM from the kernel, PR_SET_PDEATHSIG): a runner killed with
SIGKILL leaves no recorder holding a bag open and no controller commanding a robot.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import signal
import subprocess
from pathlib import Path

from twbr_common.paths import config_dir


def node_executable(package: str, name: str) -> Path:
    """The file `ros2 run <package> <name>` would run: <prefix>/lib/<package>/<name>."""
    from ament_index_python.packages import get_package_prefix

    path = Path(get_package_prefix(package)) / "lib" / package / name
    if not path.exists():
        raise FileNotFoundError(f"{path} not found: build the workspace first (make setup)")
    return path


# Fast DDS's shared-memory transport stalled a publisher for up to ~1 s when a slow subscriber (a
# recorder on a loaded 2-core machine) let its port fill up: the planner's cmd_vel went stale mid-run.
# UDP on loopback never blocks the writer (reliable readers get resends) and stays on this machine.
LOOPBACK_TRANSPORT = "UDPv4"


def fast_discovery_profile() -> Path | None:
    """config/fastdds.xml (announce every 0.5 s instead of 3 s: a graph's processes find each other at once)."""
    try:
        path = config_dir() / "fastdds.xml"
    except LookupError:  # no checkout config and twbr_sim not installed
        return None
    return path if path.is_file() else None


def loopback_env(domain_id: int, base: dict[str, str] | None = None) -> dict[str, str]:
    """An environment whose DDS traffic stays on this machine, on its own domain."""
    env = dict(os.environ if base is None else base)
    env["ROS_DOMAIN_ID"] = str(domain_id)
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    env.pop("ROS_STATIC_PEERS", None)
    env.setdefault("FASTDDS_BUILTIN_TRANSPORTS", LOOPBACK_TRANSPORT)
    profile = fast_discovery_profile()
    if profile is not None:
        env.setdefault("FASTRTPS_DEFAULT_PROFILES_FILE", str(profile))
    env["PYTHONUNBUFFERED"] = "1"
    env["RCUTILS_LOGGING_BUFFERED_STREAM"] = "0"
    return env


_PR_SET_PDEATHSIG = 1


def _child_setup(parent: int, niceness: int):
    """What a started node does before it runs: die with its parent, and yield the CPU if asked."""
    libc = ctypes.CDLL(None, use_errno=True)

    def setup() -> None:
        libc.prctl(_PR_SET_PDEATHSIG, signal.SIGTERM)
        if os.getppid() != parent:  # the parent died before prctl took effect
            os._exit(1)
        if niceness:
            os.nice(niceness)

    return setup


class NodeProcess:
    def __init__(self, argv: list[str], env: dict[str, str], log_dir: Path, name: str, niceness: int = 0) -> None:
        self.name = name
        self._interrupted = False
        log_dir.mkdir(parents=True, exist_ok=True)
        self.stdout_path = log_dir / f"{name}.out"
        self.stderr_path = log_dir / f"{name}.err"
        self._out = self.stdout_path.open("w")
        self._err = self.stderr_path.open("w")
        self.proc = subprocess.Popen(argv, env=env, stdout=self._out, stderr=self._err, start_new_session=True,
                                     preexec_fn=_child_setup(os.getpid(), niceness))

    def wait(self, timeout: float) -> int:
        return self.proc.wait(timeout=timeout)

    @property
    def running(self) -> bool:
        return self.proc.poll() is None

    def _flush(self) -> None:
        for f in (self._out, self._err):
            if not f.closed:
                f.flush()

    @property
    def stderr(self) -> str:
        self._flush()
        return self.stderr_path.read_text()

    @property
    def output(self) -> str:
        self._flush()
        return self.stdout_path.read_text() + self.stderr_path.read_text()

    def interrupt(self) -> None:
        """SIGINT to the process group once, without waiting (stop() then waits): a second one would land
        in the node's teardown."""
        if self.proc.poll() is None and not self._interrupted:
            self._interrupted = True
            with contextlib.suppress(ProcessLookupError):
                os.killpg(self.proc.pid, signal.SIGINT)

    def stop(self, timeout: float = 5.0) -> int | None:
        self.interrupt()
        with contextlib.suppress(subprocess.TimeoutExpired):
            self.proc.wait(timeout=timeout)
        if self.proc.poll() is None:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(self.proc.pid, signal.SIGKILL)
            self.proc.wait(timeout=timeout)
        self._out.close()
        self._err.close()
        return self.proc.returncode


def start_node(
    package: str, name: str, ros_args: list[str], env: dict[str, str], log_dir: Path, label: str | None = None,
    args: list[str] | None = None, niceness: int = 0,
) -> NodeProcess:
    """`ros2 run <package> <name> [args] --ros-args <ros_args>` as its own process group (niceness > 0:
    it yields the CPU to the others, as a recorder beside a control loop should)."""
    argv = [str(node_executable(package, name)), *(args or []), "--ros-args", *ros_args]
    return NodeProcess(argv, env, log_dir, label or name, niceness)
