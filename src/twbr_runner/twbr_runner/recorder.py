"""recorder: `ros2 bag record` for machines without rosbag2 — topics to a rosbag2 (MCAP) directory.

    ros2 run twbr_runner recorder -o runs/my_bag -a
    ros2 run twbr_runner recorder -o runs/my_bag odom imu wheel_torque_cmd:twbr_msgs/msg/WheelTorques

Topics named with their type are subscribed at once, before any publisher exists (so nothing published
after discovery is missed); others are subscribed when they appear in the graph (polled every 0.1 s),
with the reliability and durability their publishers offer, as rosbag2 does. Each new publisher match
is logged ("matched N publisher(s) on /topic") and published on ~/status (twbr_msgs/RecorderStatus,
latched), which is what a runner waits for. Messages are stored as the CDR bytes received, stamped with
the wall-clock time the middleware received them. SIGINT/SIGTERM close the bag cleanly. A full disk stops
the recording with one line (the path, the room left) and exit 1; what was written stays for recover_bag.

The recorded subscriptions are drained every `--drain-period` (10 ms) instead of waking the process for
each message: on a 2-core machine the recorder shares the CPUs with the control loop, and waking for each
of ~7,000 messages a second (`make demo`) cost it 27-28 % of a core, 16-17 % drained
(benchmarks/README.md). Messages wait in their subscription's queue (depth 1000) meanwhile and are
written in the order they were received.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import sys
import time
from pathlib import Path

import rclpy
from ament_index_python.packages import get_package_share_directory
from rclpy.callback_groups import CallbackGroup
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions
from rclpy.utilities import remove_ros_args

from twbr_common.executor import StopSignals
from twbr_msgs.msg import RecorderStatus
from twbr_runner.bag_writer import BagWriter, disk_full_text, is_disk_full, qos_profile, typestore_with

# Graph bookkeeping topics rosbag2 skips by default too, and recorders' own status.
SKIPPED = ("/parameter_events", "/rosout")
STATUS_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL)


DRAIN_PERIOD_S = 0.01
EXIT_DISK_FULL = 1
# rmw implementations that do not report the reception time give 0: stamp those on arrival instead.
NO_RECEPTION_TIME = 0


class Drained(CallbackGroup):
    """Subscriptions no executor waits on or calls back: their owner takes their messages itself.
    (rclpy's SingleThreadedExecutor honours can_execute; its EventsExecutor does not.)"""

    def can_execute(self, entity) -> bool:
        return False

    def beginning_execution(self, entity) -> bool:
        return False

    def ending_execution(self, entity) -> None:
        pass


def _share(package: str) -> Path:
    return Path(get_package_share_directory(package))


def message_class(msgtype: str) -> type:
    package, kind, name = msgtype.split("/")
    return getattr(importlib.import_module(f"{package}.{kind}"), name)


class Recorder(Node):
    def __init__(self, output: Path, topics: dict[str, str | None], record_all: bool) -> None:
        super().__init__("recorder")
        known = [t for t in topics.values() if t]
        self.writer = BagWriter(output, typestore_with(known, _share))
        self.wanted = {self.resolve_topic_name(t): kind for t, kind in topics.items()}
        self.record_all = record_all
        self._recorded: dict[str, object] = {}
        self._matched: dict[str, int] = {}
        self._type_conflicts: set[tuple[str, str]] = set()
        self._status = self.create_publisher(RecorderStatus, "~/status", STATUS_QOS)
        self._status_topic = self.resolve_topic_name("~/status")
        self._reported: tuple | None = None
        self._drained = Drained()
        for topic, msgtype in self.wanted.items():
            if msgtype:
                self._subscribe(topic, msgtype, QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE))
        self.create_timer(0.05, self._discover)
        self.get_logger().info(f"recording to {output}: {len(self._recorded)} topics subscribed"
                               f"{', and any others that appear' if record_all else ''}")
        self._publish_status()

    def _subscribe(self, topic: str, msgtype: str, qos: QoSProfile) -> None:
        if msgtype not in self.writer.typestore.types:
            typestore_with([msgtype], _share, self.writer.typestore)
        self.writer.add_topic(topic, msgtype, qos_profile(
            qos.reliability == ReliabilityPolicy.RELIABLE, qos.durability == DurabilityPolicy.TRANSIENT_LOCAL,
        ))
        self._recorded[topic] = self.create_subscription(message_class(msgtype), topic, _never_called, qos,
                                                         callback_group=self._drained, raw=True)

    def drain(self) -> None:
        """Write every message waiting on the recorded subscriptions, in the order received."""
        batch = []
        now = time.time_ns()
        for topic, sub in self._recorded.items():
            if sub is None:
                continue
            with sub.handle:
                while (taken := sub.handle.take_message(sub.msg_type, True)) is not None:
                    data, info = taken
                    received = info.get("received_timestamp", NO_RECEPTION_TIME)
                    batch.append((received if received != NO_RECEPTION_TIME else now, topic, data))
        batch.sort(key=lambda m: m[0])  # stable: one topic's messages keep their order
        for stamp, topic, data in batch:
            self.writer.write(topic, stamp, data)

    def _report_matches(self) -> None:
        """Log each new publisher match: a runner starts the clock only once its sources are matched."""
        for topic, sub in self._recorded.items():
            if sub is None:
                continue
            count = sub.get_publisher_count()
            if count > self._matched.get(topic, 0):
                self.get_logger().info(f"matched {count} publisher(s) on {topic}")
            self._matched[topic] = count
        self._publish_status()

    def _publish_status(self) -> None:
        """~/status, when what is recorded or matched changed since the last report."""
        topics = sorted(t for t, sub in self._recorded.items() if sub is not None)
        counts = [self._matched.get(t, 0) for t in topics]
        if (topics, counts) == self._reported:
            return
        self._reported = (topics, counts)
        msg = RecorderStatus()
        msg.header.stamp = self.get_clock().now().to_msg()
        msg.bag = str(self.writer.path)
        msg.topics = topics
        msg.matched_publishers = counts
        self._status.publish(msg)

    def _report_types(self, topic: str, types: list[str]) -> None:
        """A publisher of another type on a recorded topic: its messages are not in the bag. Say so, once."""
        recorded = self.writer.types.get(topic)
        if recorded is None or all(t == recorded for t in types):
            return
        # Keyed by publisher: a node's name arrives a moment after its endpoint, and is named once known.
        who = ", ".join(sorted(f"{p.node_namespace.rstrip('/')}/{p.node_name} [{p.topic_type}]"
                               for p in self.get_publishers_info_by_topic(topic) if p.topic_type != recorded))
        if (topic, who) not in self._type_conflicts:
            self._type_conflicts.add((topic, who))
            self.get_logger().error(f"{topic} is recorded as {recorded}; not recorded: {who}")

    def _discover(self) -> None:
        self._report_matches()
        for topic, types in self.get_topic_names_and_types():
            self._report_types(topic, types)
            if topic in self._recorded or topic in SKIPPED or topic == self._status_topic:
                continue
            if not (self.record_all or topic in self.wanted):
                continue
            publishers = self.get_publishers_info_by_topic(topic)
            if not publishers:
                continue
            offered = [p.qos_profile for p in publishers]
            reliable = all(q.reliability == ReliabilityPolicy.RELIABLE for q in offered)
            latched = all(q.durability == DurabilityPolicy.TRANSIENT_LOCAL for q in offered)
            qos = QoSProfile(
                depth=1000,
                reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
                durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE,
            )
            try:
                self._subscribe(topic, types[0], qos)
            except (ImportError, AttributeError, FileNotFoundError, LookupError) as e:
                self.get_logger().warn(f"cannot record {topic} [{types[0]}]: {e}", once=True)
                self._recorded[topic] = None
                continue
            self.get_logger().info(f"recording {topic} [{types[0]}]")

    def close(self) -> None:
        try:
            self.drain()  # what arrived since the last drain, SIGINT's included
        finally:
            self.writer.close()  # the bag is closed even if the middleware is gone
        counts = ", ".join(f"{t} {n}" for t, n in sorted(self.writer.counts.items()))
        # The context may be shut down already (an external shutdown): print rather than log to /rosout.
        print(f"[recorder] closed {self.writer.path}: {self.writer.total} messages ({counts})", file=sys.stderr,
              flush=True)

    def abandon(self, error: OSError) -> None:
        """The disk is full: stop, say so in one line, and leave what was written for recover_bag (closing
        the bag would need the room that is missing)."""
        with contextlib.suppress(OSError):
            self.writer.close()
            print(f"[recorder] closed {self.writer.path} with {self.writer.total} messages", file=sys.stderr)
            return
        print(f"[recorder] recording stopped: {disk_full_text(self.writer.path, error)}; the"
              f" {self.writer.total} messages written are kept: `ros2 run twbr_runner recover_bag"
              f" {self.writer.path} -o <a directory with room>` makes them a readable bag", file=sys.stderr,
              flush=True)


def _never_called(_data: bytes) -> None:
    raise AssertionError("a drained subscription was called back")


def record_until_shutdown(node: Recorder, drain_period: float, stop: StopSignals) -> None:
    """Drain the recorded subscriptions every `drain_period`; between drains, serve the node's timers and
    services (parameters), which wake it only when they are due."""
    executor = SingleThreadedExecutor(context=node.context)
    executor.add_node(node)
    try:
        while node.context.ok() and stop.received is None:
            deadline = time.monotonic() + drain_period
            node.drain()
            while stop.received is None and node.context.ok() and (left := deadline - time.monotonic()) > 0.0:
                executor.spin_once(timeout_sec=left)
    finally:
        executor.remove_node(node)
        executor.shutdown()


def parse_args(argv: list[str]) -> argparse.Namespace:
    ap = argparse.ArgumentParser(prog="recorder", description=__doc__.split("\n")[0])
    ap.add_argument("-o", "--output", type=Path, required=True, help="bag directory to create (must not exist)")
    ap.add_argument("-a", "--all", action="store_true", help="record every topic that appears")
    ap.add_argument("--drain-period", type=float, default=DRAIN_PERIOD_S, metavar="S",
                    help=f"seconds between two takes of the waiting messages (default {DRAIN_PERIOD_S:g});"
                         " each subscription keeps up to 1000 meanwhile")
    ap.add_argument("topics", nargs="*", help="topic or topic:package/msg/Type")
    args = ap.parse_args(argv)
    if not 0.0 < args.drain_period <= 60.0:
        ap.error(f"invalid --drain-period {args.drain_period:g}: must be in (0, 60] s")
    if not args.all and not args.topics:
        ap.error("name topics or pass -a")
    if args.output.exists():
        ap.error(f"{args.output} exists: rosbag2 never overwrites a bag")
    return args


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv if argv is None else argv
    args = parse_args(remove_ros_args(argv)[1:])
    topics = {}
    for item in args.topics:
        topic, _, msgtype = item.partition(":")
        topics[topic] = msgtype or None
    rclpy.init(args=argv, signal_handler_options=SignalHandlerOptions.NO)
    stop = StopSignals()
    node = None
    failed: OSError | None = None
    try:
        node = Recorder(args.output, topics, args.all)
        record_until_shutdown(node, args.drain_period, stop)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except OSError as e:
        if not is_disk_full(e):
            raise
        failed = e
    finally:
        if node is not None:
            try:
                if failed is None:
                    node.close()
            except OSError as e:
                if not is_disk_full(e):
                    raise
                failed = e
            if failed is not None:
                node.abandon(failed)
            node.destroy_node()
        elif failed is not None:
            print(f"[recorder] cannot start: {disk_full_text(args.output, failed)}", file=sys.stderr, flush=True)
        rclpy.try_shutdown()
    return EXIT_DISK_FULL if failed is not None else 0


if __name__ == "__main__":
    raise SystemExit(main())
