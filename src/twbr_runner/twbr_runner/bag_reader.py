"""Reads a rosbag2 MCAP directory with the `mcap` libraries: not the library that wrote it.

Messages are decoded with the definitions embedded in the file itself, so reading needs no ROS install
and proves the bag is self-describing; metadata.yaml is checked the way `ros2 bag info` reads it.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Iterable
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


def read_messages(bag_dir: Path, topics: Iterable[str] | None = None) -> dict[str, list[tuple[int, Any]]]:
    """{topic: [(receive time ns, decoded message), ...]} in receive order."""
    out: dict[str, list[tuple[int, Any]]] = defaultdict(list)
    wanted = None if topics is None else list(topics)
    for path in mcap_files(bag_dir):
        with path.open("rb") as f:
            reader = make_reader(f, decoder_factories=[DecoderFactory()])
            for _schema, channel, message, decoded in reader.iter_decoded_messages(topics=wanted,
                                                                                   log_time_order=True):
                out[channel.topic].append((message.log_time, decoded))
    return dict(out)
