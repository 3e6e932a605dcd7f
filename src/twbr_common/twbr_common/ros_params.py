"""Declare a spec table on an rclpy node, with descriptors, and refuse bad values at start-up."""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterable
from typing import Any

import rclpy
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, ParameterType
from rclpy.clock import JumpThreshold
from rclpy.duration import Duration
from rclpy.exceptions import (
    InvalidParameterTypeException,
    InvalidParameterValueException,
    ParameterException,
)
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.parameter import Parameter

from twbr_common.executor import spin_until_shutdown
from twbr_common.guard import INPUT_SPECS, future_tolerance
from twbr_common.params import ConfigError, ParamSpec
from twbr_common.process import PROCESS_SPECS, settle_process
from twbr_common.streams import InputStreams

EXIT_CONFIG_ERROR = 2

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
        read_only=True,
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
        if default == []:  # rclpy takes an empty list for a byte array: declare the type, without a value
            default = Parameter.Type(_type(spec))
        try:
            param = node.declare_parameter(name, default, descriptor(shown))
        except (InvalidParameterTypeException, InvalidParameterValueException, ParameterException) as e:
            override = node._parameter_overrides.get(name)
            value = override.value if override is not None else "?"
            raise ConfigError(
                f"invalid parameter '{name}' = {value!r}: must be {shown.range_text()}"
                f" ({type(e).__name__})"
            ) from None
        values[spec.name] = shown.validate(spec.default if param.value is None else param.value)
    return values


def run_node(name: str, make_node: Callable[[], Node], argv: list[str] | None = None) -> int:
    """Init, spin until shutdown, and turn a configuration error into one FATAL line and exit code 2.

    A node with a `run()` method drives its own loop (the lockstep simulator); others are spun. Every
    node also takes the process parameters of twbr_common.process (cpu_affinity).
    """
    rclpy.init(args=argv if argv is not None else sys.argv)
    node = None
    code = 0
    try:
        node = make_node()
        settle_process(declare(node, PROCESS_SPECS), node.get_logger().info)
        if hasattr(node, "run"):
            node.run()
        else:
            spin_until_shutdown(node)
    except ConfigError as e:
        rclpy.logging.get_logger(name).fatal(f"refusing to start: {e}")
        code = EXIT_CONFIG_ERROR
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            node.destroy_node()
        if rclpy.ok():
            rclpy.try_shutdown()
    return code


def input_streams(node: Node) -> InputStreams:
    """The node's guarded inputs, with its future_tolerance, restarted when its clock jumps back.

    rclpy's jump callback restarts them the moment /clock goes back, before any message of the new run is
    judged against the old run's stamps; `InputStreams.observe` catches the same on wall time.
    """
    cfg = declare(node, INPUT_SPECS)
    sim_time = bool(node.get_parameter("use_sim_time").value)
    streams = InputStreams(node.get_logger().warning, future_tolerance(cfg["future_tolerance"], sim_time))
    threshold = JumpThreshold(min_forward=None, min_backward=Duration(nanoseconds=-1), on_clock_change=False)
    # The handle must live as long as the node: dropping it unregisters the callback.
    streams.jump_handle = node.get_clock().create_jump_callback(threshold, post_callback=lambda _jump: streams.restart())
    return streams
