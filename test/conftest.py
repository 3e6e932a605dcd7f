"""End-to-end harness: real node processes on an isolated DDS domain, discovery on loopback only.

Every test gets its own ROS_DOMAIN_ID, so a process that outlives a test cannot talk to the next one,
and every process a test starts is stopped (SIGINT, then SIGKILL of its process group) even when the
test fails.
"""

from __future__ import annotations

import contextlib
import fcntl
import itertools
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from twbr_common.ros_io import stamp_seconds
from twbr_runner.spawn import NodeProcess, loopback_env, start_node

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "config"
_domains = itertools.count()
_holding_alone = False  # this process's test holds the machine alone (machine_share)
# The runner as the end-to-end tests start it: the simulator waits up to 5 s of wall time for each command
# (sim.yaml: 0.5 s), so a test that asserts no lockstep timeout judges the graph, not a host stalled by
# other work (make e2e-loaded); a node that dies still shows, as a run that takes 5 s per step.
RUNNER = (sys.executable, "-m", "twbr_runner.runner", "--lockstep-timeout", "5")
PATIENT_LOCKSTEP = ("-p", "lockstep_timeout:=5.0")  # the same for a sim_node the test starts itself


def worker_domains() -> range:
    """This pytest process's share of domains 120..219 (0..232 are valid Fast DDS domains): with
    pytest-xdist (`make test`'s two workers) each worker draws from its own block, so two tests running
    side by side never share a domain; 221..232 are left to the unit tests' own children."""
    count = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
    index = int(os.environ.get("PYTEST_XDIST_WORKER", "gw0").removeprefix("gw"))
    span = 100 // count
    return range(120 + index * span, 120 + (index + 1) * span)


@pytest.fixture
def ros_domain() -> int:
    # Distinct per test and per pytest process.
    block = worker_domains()
    return block[(os.getpid() * 7 + next(_domains)) % len(block)]


@contextlib.contextmanager
def busy_loops() -> Iterator[int]:
    """One busy loop per core while inside (a loaded host); they are killed on the way out, whatever happens.
    Only in a test marked `alone` (machine_share), or beside none (make e2e-loaded runs one process)."""
    assert _holding_alone or "PYTEST_XDIST_WORKER" not in os.environ, "a test with busy_loops must be marked alone"
    hogs = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(os.cpu_count() or 2)]
    try:
        yield len(hogs)
    finally:
        for hog in hogs:
            hog.kill()
            hog.wait()


@pytest.fixture(scope="session", autouse=True)
def busy_loop() -> Iterator[int]:
    """TWBR_TEST_BUSY=1 (`make e2e-loaded`): busy loops beside the whole session, as on a loaded CI host. The
    end-to-end tests must pass that way: they judge in sim time and stamps, never in wall time."""
    if os.environ.get("TWBR_TEST_BUSY", "0") in ("", "0"):
        yield 0
        return
    with busy_loops() as n:
        yield n


@contextlib.contextmanager
def machine_share(alone: bool) -> Iterator[None]:
    """The machine, shared with the end-to-end tests of other pytest workers, or alone. A test that loads every
    core on purpose (busy_loops) runs alone, so it measures its own graph on a loaded host and leaves no
    other test on one: beside another worker's graph, its loops starved that graph's recorder
    (/clock in its bag 1.2 s of wall time late). So does one that balances a robot on the wall clock for
    long (a driver that is not sim_node): another graph beside it is a host that stalls its robot. A waiting
    `alone` test holds the gate, so no new test starts meanwhile (it is not starved by a stream of shared
    ones)."""
    base = Path(tempfile.gettempdir()) / f"twbr-e2e-{os.getuid()}"
    with open(f"{base}.gate", "a") as gate, open(f"{base}.lock", "a") as lock:
        fcntl.flock(gate, fcntl.LOCK_EX)
        try:
            fcntl.flock(lock, fcntl.LOCK_EX if alone else fcntl.LOCK_SH)
        finally:
            fcntl.flock(gate, fcntl.LOCK_UN)
        global _holding_alone
        _holding_alone = alone
        try:
            yield
        finally:
            _holding_alone = False
            fcntl.flock(lock, fcntl.LOCK_UN)


@pytest.fixture(autouse=True)
def machine(request: pytest.FixtureRequest) -> Iterator[None]:
    """Every end-to-end test holds its share of the machine (machine_share); one marked `alone`, all of it."""
    if request.node.get_closest_marker("e2e") is None:
        yield
        return
    with machine_share(request.node.get_closest_marker("alone") is not None):
        yield


@pytest.fixture
def ros_env(ros_domain: int) -> dict[str, str]:
    return loopback_env(ros_domain)


@pytest.fixture(scope="session")
def node_kernels() -> None:
    """The compiled nodes' kernels in the cache before the first node starts: planner_node compiles by
    default, and its first start after a source change would spend ~25 s compiling inside a test's timeouts."""
    warm = ("from twbr_planner.planner import ApfPlanner; from twbr_planner.planner_params import resolve;"
            " ApfPlanner(resolve({})).warm_up()")
    subprocess.run([sys.executable, "-c", warm], check=True, timeout=600)


@pytest.fixture
def launch(ros_env: dict[str, str], tmp_path: Path, node_kernels: None) -> Iterator[Callable[..., NodeProcess]]:
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

        def spin_until_quiet(self, count: Callable[[], int], quiet: float = 1.0, timeout: float = 10.0) -> None:
            """Spin until count() (messages received) has not grown for `quiet` seconds: a node outside the
            lockstep, starved on a loaded host, may still be answering the last inputs when the run ends."""
            last = [count(), time.monotonic()]

            def settled() -> bool:
                if count() != last[0]:
                    last[:] = [count(), time.monotonic()]
                return time.monotonic() - last[1] >= quiet

            self.spin_until(settled, timeout)

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


def stamp_s(msg) -> float:
    """A message's header stamp in seconds."""
    return stamp_seconds(msg.header.stamp)


def contacts_while_driving(world: list, states: list, speed: float = 0.05) -> list[str]:
    """Every collision that began while the robot drove (|v| > speed at its start), as 't = ... s with id N
    at v = ... m/s': a robot stopped by a watchdog or a planner without a world can be walked into by a
    moving obstacle, which is not a planner driving into it."""
    driving = []
    was_in_contact = False
    for w in world:
        if w.collision and not was_in_contact:
            t = stamp_s(w)
            before = [s for s in states if t - 0.2 <= stamp_s(s) <= t]
            v = max((abs(s.velocity) for s in before), default=float("nan"))
            if not v <= speed:
                driving.append(f"t = {t:.2f} s with id {w.collision_obstacle_id} at v = {v:.3f} m/s")
        was_in_contact = w.collision
    return driving


def after_last_restart(msgs: list) -> list:
    """The messages after the last backward jump of their stamps (a simulator started again from t = 0):
    counting messages instead is wrong on a loaded machine, where the old run's last ones arrive late."""
    start = 0
    for i in range(1, len(msgs)):
        if stamp_s(msgs[i]) < stamp_s(msgs[i - 1]) - 1.0:
            start = i
    return msgs[start:]
