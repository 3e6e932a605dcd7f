"""Declare a spec table on an rclpy node, with descriptors, and refuse bad values at start-up."""

from __future__ import annotations

import contextlib
import faulthandler
import signal
import sys
import threading
from collections.abc import Callable, Iterable, Iterator
from typing import Any

import rclpy
from rcl_interfaces.msg import (
    FloatingPointRange,
    IntegerRange,
    ParameterDescriptor,
    ParameterType,
    SetParametersResult,
)
from rclpy.clock import JumpThreshold
from rclpy.duration import Duration
from rclpy.exceptions import (
    InvalidParameterTypeException,
    InvalidParameterValueException,
    ParameterException,
)
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions

from twbr_common.executor import StopSignals, spin_until_shutdown
from twbr_common.guard import SIM_FUTURE_TOLERANCE, future_tolerance, input_specs
from twbr_common.node_process import process_specs, settle_process
from twbr_common.param_files import check_overrides, preflight
from twbr_common.params import ConfigError, ParamSpec
from twbr_common.ros_io import flush_publishers
from twbr_common.streams import InputStreams

EXIT_CONFIG_ERROR = 2
# The longest a node's teardown may take before the process is ended anyway (the viewer's last flush
# included). Fast DDS 2.14 can hang for good in rcl_node_fini, spinning a core in
# DomainParticipant::set_listener while a discovery callback waits on a lock (seen on this machine when
# nodes of a graph stop together; eProsima/Fast-DDS#6513): a Ctrl-C must still end the process.
SHUTDOWN_GRACE_S = 10.0
FLUSH_S = 2.0  # [s] at most, on the way out: a lagging recorder's acknowledgements
STOP_POLL_S = 0.1  # [s] a spun node looks for a stop signal at least this often

_TYPES = {
    bool: ParameterType.PARAMETER_BOOL,
    int: ParameterType.PARAMETER_INTEGER,
    float: ParameterType.PARAMETER_DOUBLE,
    str: ParameterType.PARAMETER_STRING,
    list: ParameterType.PARAMETER_DOUBLE_ARRAY,
}


def _type(spec: ParamSpec) -> int:
    if spec.kind is list and spec.item is int:
        return ParameterType.PARAMETER_INTEGER_ARRAY
    return _TYPES[spec.kind]


def descriptor(spec: ParamSpec) -> ParameterDescriptor:
    d = ParameterDescriptor(
        name=spec.name,
        type=_type(spec),
        description=spec.describe(),
        read_only=not spec.tunable,
    )
    # rclpy enforces inclusive ranges only; open bounds are checked by spec.validate afterwards.
    if spec.kind is float and spec.low is not None and spec.high is not None:
        d.floating_point_range = [FloatingPointRange(from_value=float(spec.low), to_value=float(spec.high))]
    elif spec.kind is int and spec.low is not None and spec.high is not None:
        d.integer_range = [IntegerRange(from_value=int(spec.low), to_value=int(spec.high), step=1)]
    return d


def declare(node: Node, specs: Iterable[ParamSpec], prefix: str = "") -> dict[str, Any]:
    """Declare every spec (as `prefix + name`) and return the validated values by spec name."""
    values: dict[str, Any] = {}
    for spec in specs:
        name = prefix + spec.name
        shown = ParamSpec(**{**spec.__dict__, "name": name})
        default = list(spec.default) if spec.kind is list else spec.default
        if default == []:
            # rclpy types an empty list as a byte array, and a parameter declared without a value makes
            # GetParameters (`ros2 param dump`) fail for the whole request: give lists a non-empty default.
            raise ValueError(f"parameter '{name}': an empty list default cannot be declared with its type")
        try:
            param = node.declare_parameter(name, default, descriptor(shown))
        except (InvalidParameterTypeException, InvalidParameterValueException, ParameterException) as e:
            value = given_value(node, name)
            raise ConfigError(
                f"invalid parameter '{name}' = {value!r}: must be {shown.range_text()}"
                f" ({type(e).__name__})"
            ) from None
        values[spec.name] = shown.validate(spec.default if param.value is None else param.value)
    return values


def given_value(node: Node, name: str) -> Any:
    """The value a params file or `-p` gave a parameter whose declaration refused it (for the error line).

    Declared again with dynamic typing and no range, the override is taken as it is and read back
    through the public API.
    """
    try:
        return node.declare_parameter(name, None, ParameterDescriptor(dynamic_typing=True)).value
    except (ParameterException, InvalidParameterTypeException, InvalidParameterValueException):
        return "?"


def run_node(name: str, make_node: Callable[[], Node], argv: list[str] | None = None) -> int:
    """Init, spin until shutdown, and turn a configuration error into one FATAL line and exit code 2.

    A node with a `run()` method drives its own loop (the lockstep simulator); others are spun. Every
    node also takes the process parameters of twbr_common.node_process (cpu_affinity,
    realtime_priority).
    """
    argv = argv if argv is not None else sys.argv
    try:
        preflight(argv)  # a missing or unreadable params file: one line, before rcl's traceback
    except ConfigError as e:
        print(f"[FATAL] [{name}]: refusing to start: {e}", file=sys.stderr, flush=True)
        return EXIT_CONFIG_ERROR
    # A spun node stops on a signal with its context up, and waits (FLUSH_S at most) until reliable
    # subscribers have what it published: a recorder that lags on a loaded host then still gets a run's
    # last planner_state (a CI bag lost its last 3 s when the planner exited on the runner's SIGINT). A node
    # with its own loop (the simulator) ends its runs itself and flushes then.
    spun = not hasattr(make_node, "run")
    rclpy.init(args=argv, signal_handler_options=SignalHandlerOptions.NO if spun else SignalHandlerOptions.ALL)
    stop = StopSignals() if spun else None
    node = None
    code = 0
    try:
        node = make_node()
        settle_process(declare(node, process_specs()), node.get_logger().info)
        declared = node.list_parameters([], 0).names
        check_overrides(argv, node.get_name(), node.get_namespace(), declared)
        if hasattr(node, "run"):
            node.run()
        else:
            spin_until_shutdown(node, STOP_POLL_S, stop)
    except ConfigError as e:
        rclpy.logging.get_logger(name).fatal(f"refusing to start: {e}")
        code = EXIT_CONFIG_ERROR
    except (InvalidParameterTypeException, InvalidParameterValueException) as e:
        # rclpy refusing one of its own parameters that preflight does not know of: still one line.
        rclpy.logging.get_logger(name).fatal(f"refusing to start: invalid parameter: {e}")
        code = EXIT_CONFIG_ERROR
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        with signals_ignored(), exit_deadline(SHUTDOWN_GRACE_S):
            if node is not None:
                if stop is not None and node.context.ok():
                    with contextlib.suppress(Exception):  # best effort: the teardown goes on regardless
                        flush_publishers(node, FLUSH_S)
                node.destroy_node()
            if rclpy.ok():
                rclpy.try_shutdown()
    return code


@contextlib.contextmanager
def signals_ignored() -> Iterator[None]:
    """SIGINT and SIGTERM ignored for the block: a second Ctrl-C, or a supervisor's stop right after its
    interrupt, must not tear a teardown that writes the node's last words (a viewer's summary, a bag's
    index). exit_deadline bounds the block instead."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = {s: signal.signal(s, signal.SIG_IGN) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        yield
    finally:
        for s, handler in previous.items():
            signal.signal(s, handler if handler is not None else signal.SIG_DFL)


@contextlib.contextmanager
def exit_deadline(seconds: float) -> Iterator[None]:
    """End the process (exit code 1, the stuck thread's traceback on stderr after "Timeout") if the block
    has not finished within `seconds`. faulthandler's watchdog is a C thread: it fires even when the stuck
    call holds the GIL, as rcl_node_fini does."""
    stderr = sys.__stderr__
    try:
        faulthandler.dump_traceback_later(seconds, exit=True, file=stderr)
    except (AttributeError, OSError, RuntimeError, ValueError):  # no stderr file descriptor: nothing to write the reason to
        yield
        return
    try:
        yield
    finally:
        faulthandler.cancel_dump_traceback_later()


def input_streams(node: Node, sim_tolerance: float = SIM_FUTURE_TOLERANCE) -> InputStreams:
    """The node's guarded inputs, with its future_tolerance (by default `sim_tolerance` [s] on sim time),
    restarted when its clock jumps back.

    rclpy's jump callback restarts them the moment /clock goes back, before any message of the new run is
    judged against the old run's stamps; `InputStreams.observe` catches the same on wall time.
    """
    cfg = declare(node, input_specs(sim_tolerance))
    sim_time = bool(node.get_parameter("use_sim_time").value)
    streams = InputStreams(node.get_logger().warning,
                           future_tolerance(cfg["future_tolerance"], sim_time, sim_tolerance))
    threshold = JumpThreshold(min_forward=None, min_backward=Duration(nanoseconds=-1), on_clock_change=False)
    # The handle must live as long as the node: dropping it unregisters the callback.
    streams.jump_handle = node.get_clock().create_jump_callback(threshold, post_callback=lambda _jump: streams.restart())
    return streams


def accept_changes(node: Node, specs: Iterable[ParamSpec], cfg: dict[str, Any], check: Callable[[dict], dict],
                   apply: Callable[[dict], None]) -> None:
    """Let SetParameters (`ros2 param set`, rqt_reconfigure) change the tunable specs while the node runs.

    A request is validated whole, by the same specs and the same consistency check as at start-up, and
    either refused with the reason or applied at once by `apply(new cfg)`: the callback runs in the node's
    executor, between two of its callbacks, so a control step never sees half of a set. Read-only
    parameters are refused by rclpy itself (their descriptors). Register after declaring: rclpy calls this
    callback for each declaration too.
    """
    by_name = {s.name: s for s in specs}
    log = node.get_logger()

    def on_set(parameters: list) -> SetParametersResult:
        changes: dict[str, Any] = {}
        for parameter in parameters:
            spec = by_name.get(parameter.name)
            if spec is None:
                continue  # not this table's (use_sim_time, another table's)
            if not spec.tunable:
                return SetParametersResult(successful=False, reason=f"'{spec.name}' is read-only at runtime:"
                                                                    f" {spec.fixed_because}")
            try:
                changes[spec.name] = spec.validate(parameter.value)
            except ConfigError as e:
                return SetParametersResult(successful=False, reason=str(e))
        if not changes:
            return SetParametersResult(successful=True)
        try:
            new = check({**cfg, **changes})
        except ConfigError as e:
            return SetParametersResult(successful=False, reason=str(e))
        apply(new)
        told = ", ".join(f"{k} {cfg[k]!r} -> {v!r}" for k, v in changes.items())
        cfg.update(new)
        log.info(f"parameters changed at runtime: {told}")
        return SetParametersResult(successful=True)

    node.add_on_set_parameters_callback(on_set)
