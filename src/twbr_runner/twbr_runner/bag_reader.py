"""Reads a rosbag2 MCAP directory with the `mcap` libraries: not the library that wrote it.

Messages are decoded with the definitions embedded in the file itself, so reading needs no ROS install
and proves the bag is self-describing; metadata.yaml is checked the way `ros2 bag info` reads it.
"""

from __future__ import annotations

import struct
from collections import Counter, defaultdict
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

import yaml
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory


class BagError(RuntimeError):
    pass


def bag_info(bag_dir: Path) -> dict[str, Any]:
    """metadata.yaml's rosbag2_bagfile_information, checked against the MCAP file it names."""
    meta_path = Path(bag_dir) / "metadata.yaml"
    if not meta_path.exists():
        raise BagError(f"{bag_dir}: no metadata.yaml (the recorder did not close the bag)")
    info = yaml.safe_load(meta_path.read_text())["rosbag2_bagfile_information"]
    if info["storage_identifier"] != "mcap":
        raise BagError(f"{bag_dir}: storage {info['storage_identifier']!r}, expected 'mcap'")
    for rel in info["relative_file_paths"]:
        if not (Path(bag_dir) / rel).exists():
            raise BagError(f"{bag_dir}: {rel} listed in metadata.yaml is missing")
    return info


def mcap_files(bag_dir: Path) -> list[Path]:
    return [Path(bag_dir) / rel for rel in bag_info(bag_dir)["relative_file_paths"]]


def read_messages(bag_dir: Path, topics: Iterable[str] | None = None,
                  undecodable: Counter | None = None) -> dict[str, list[tuple[int, Any]]]:
    """{topic: [(receive time ns, decoded message), ...]} in receive order: the whole selection in memory
    (iter_messages streams it)."""
    out: dict[str, list[tuple[int, Any]]] = defaultdict(list)
    for topic, received, msg in iter_messages(bag_dir, topics, undecodable):
        out[topic].append((received, msg))
    return dict(out)


def iter_messages(bag_dir: Path, topics: Iterable[str] | None = None, undecodable: Counter | None = None,
                  raw: Iterable[str] = ()) -> Iterator[tuple[str, int, Any]]:
    """(topic, receive time ns, message) in receive order, one at a time. Topics in `raw` come as their
    CDR bytes (the caller reads what it needs from them: a large array decoded field by field is slow and
    large).

    A recorder keeps the bytes it received, as they came: a message that does not decode as its topic's
    type (malformed bytes from a neighbour on the network) is left out and counted per topic in
    `undecodable`, instead of making the whole bag unreadable."""
    wanted = None if topics is None else list(topics)
    raw = set(raw)
    factory = DecoderFactory()
    for path in mcap_files(bag_dir):
        with path.open("rb") as f:
            decoders: dict[int, Any] = {}
            for schema, channel, message in make_reader(f).iter_messages(topics=wanted, log_time_order=True):
                if channel.topic in raw:
                    yield channel.topic, message.log_time, message.data
                    continue
                decode = decoders.get(channel.id)
                if decode is None:
                    decode = factory.decoder_for(channel.message_encoding, schema)
                    if decode is None:  # what mcap's own decoding loop refuses as well
                        raise BagError(f"{path}: no decoder for {channel.topic}'s message encoding"
                                       f" {channel.message_encoding!r} (schema {schema.name if schema else None})")
                    decoders[channel.id] = decode
                try:
                    decoded = decode(message.data)
                except (ValueError, IndexError, KeyError, EOFError, UnicodeDecodeError, struct.error):
                    if undecodable is not None:
                        undecodable[channel.topic] += 1
                    continue
                yield channel.topic, message.log_time, decoded
