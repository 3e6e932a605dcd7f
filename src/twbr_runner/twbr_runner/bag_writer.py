"""rosbag2 files in MCAP, written with `rosbags` (no rclpy here: the recorder node feeds it CDR bytes).

The bag is a real rosbag2 directory (metadata.yaml version 9 + one .mcap file with the message
definitions embedded), which `ros2 bag info/play`, Foxglove and the mcap tools open. Types that the
Jazzy typestore lacks (ours, and any a user's driver brings) are read from their .msg files in the
packages' share directories, the way rosbag2 finds them.
"""

from __future__ import annotations

import errno
import shutil
from collections.abc import Callable, Iterable
from pathlib import Path

from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

# Where a package's share directory is (ament_index in the node; a dict in tests).
ShareLookup = Callable[[str], Path]


def typestore_with(msgtypes: Iterable[str], find_share: ShareLookup, store: Typestore | None = None) -> Typestore:
    """`store` (default: the Jazzy typestore) plus every package's .msg definitions the given types need."""
    store = store or get_typestore(Stores.ROS2_JAZZY)
    pending = [t for t in msgtypes if t not in store.types]
    done: set[str] = set()
    while pending:
        package = pending.pop().split("/")[0]
        if package in done:
            continue
        done.add(package)
        types = {}
        for msg_file in sorted((find_share(package) / "msg").glob("*.msg")):
            types.update(get_types_from_msg(msg_file.read_text(), f"{package}/msg/{msg_file.stem}"))
        store.register(types)
        # Field types from packages not yet known (a message of one package using another's).
        for fields in types.values():
            for _name, (kind, detail) in fields[1]:
                nested = _nested_type(kind, detail)
                if nested and nested not in store.types:
                    pending.append(nested)
    return store


def _nested_type(kind, detail) -> str | None:
    # rosbags field descriptors: (Nodetype, name) for NAME, nested tuples for arrays/sequences.
    if isinstance(detail, str) and "/" in detail:
        return detail
    if isinstance(detail, tuple) and detail and isinstance(detail[0], tuple):
        return _nested_type(*detail[0])
    return None


def qos_profile(reliable: bool = True, transient_local: bool = False, depth: int = 10) -> Qos:
    zero = QosTime(0, 0)
    return Qos(
        QosHistory.KEEP_LAST, depth,
        QosReliability.RELIABLE if reliable else QosReliability.BEST_EFFORT,
        QosDurability.TRANSIENT_LOCAL if transient_local else QosDurability.VOLATILE,
        zero, zero, QosLiveliness.AUTOMATIC, zero, False,
    )


class BagWriter:
    """One rosbag2 (MCAP) directory; topics may be added while recording."""

    def __init__(self, path: Path, typestore: Typestore) -> None:
        self.path = Path(path)
        self.typestore = typestore
        self._writer = Writer(self.path, version=9, storage_plugin=StoragePlugin.MCAP)
        self._writer.open()
        self._connections: dict[str, object] = {}
        self.counts: dict[str, int] = {}
        self.types: dict[str, str] = {}  # the type each topic is recorded as

    def add_topic(self, topic: str, msgtype: str, offered: Qos | None = None) -> None:
        if topic in self._connections:
            return
        self._connections[topic] = self._writer.add_connection(
            topic, msgtype, typestore=self.typestore, offered_qos_profiles=[offered or qos_profile()],
        )
        self.counts[topic] = 0
        self.types[topic] = msgtype

    def write(self, topic: str, timestamp_ns: int, data: bytes) -> None:
        self._writer.write(self._connections[topic], timestamp_ns, data)
        self.counts[topic] += 1

    def close(self) -> None:
        self._writer.close()

    @property
    def total(self) -> int:
        return sum(self.counts.values())


# Write errors that mean "the disk cannot take more", not a bug: reported in one line, never a traceback.
DISK_ERRNOS = (errno.ENOSPC, errno.EDQUOT, errno.EFBIG)


def is_disk_full(error: BaseException) -> bool:
    return isinstance(error, OSError) and error.errno in DISK_ERRNOS


def disk_full_text(path: Path, error: OSError) -> str:
    """One line: what could not be written, why, and how much room its filesystem has."""
    where = Path(path)
    while not where.exists() and where != where.parent:
        where = where.parent
    try:
        usage = shutil.disk_usage(where)
        room = f" ({usage.free / 1e6:.1f} MB free of {usage.total / 1e6:.1f} MB on its filesystem)"
    except OSError:
        room = ""
    return f"cannot write {path}: {error.strerror or error}{room}"
