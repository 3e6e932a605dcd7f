"""recover_bag: a bag whose recorder was killed (SIGKILL, a power cut) made readable again.

    ros2 run twbr_runner recover_bag runs/<run>/bag          # in place; the cut file is kept as *.mcap.cut
    ros2 run twbr_runner recover_bag runs/<run>/bag -o fixed  # into a new bag directory

A killed recorder leaves an MCAP file without its summary and footer, and no metadata.yaml: every rosbag2
reader refuses it, although every chunk written before the cut is intact. This reads the file as a stream
up to the cut (records that were cut short are dropped), takes the message definitions embedded in its
schemas, and writes a complete rosbag2 (MCAP) bag with metadata.yaml, as the recorder would have.
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

from mcap.exceptions import McapError
from mcap.records import Channel, Chunk, Message, Schema
from mcap.stream_reader import StreamReader, breakup_chunk
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from twbr_runner.bag_writer import BagWriter, qos_profile

EXIT_FAILED = 1
_SEPARATOR = "=" * 80


@dataclass
class Salvage:
    """What a cut MCAP file still holds: its schemas and channels, and its messages in file order."""

    schemas: dict[int, Schema] = field(default_factory=dict)
    channels: dict[int, Channel] = field(default_factory=dict)
    messages: list[Message] = field(default_factory=list)
    cut: str = ""  # why reading stopped before the end, if it did


def salvage(path: Path) -> Salvage:
    out = Salvage()

    def take(record) -> None:
        if isinstance(record, Schema):
            out.schemas[record.id] = record
        elif isinstance(record, Channel):
            out.channels[record.id] = record
        elif isinstance(record, Message) and record.channel_id in out.channels:
            out.messages.append(record)

    with Path(path).open("rb") as f:
        try:
            for record in StreamReader(f, emit_chunks=True).records:
                if isinstance(record, Chunk):
                    try:
                        for inner in breakup_chunk(record, validate_crc=True):
                            take(inner)
                    except (McapError, ValueError, EOFError) as e:  # a chunk cut mid-write
                        out.cut = f"a damaged chunk ({e})"
                        break
                else:
                    take(record)
        except (McapError, ValueError, EOFError, OSError) as e:
            out.cut = f"the file ends mid-record ({type(e).__name__})"
    return out


def definitions(schema: Schema) -> dict:
    """rosbags type definitions from a ros2msg schema: the message, then each dependency after a separator."""
    text = schema.data.decode()
    types = {}
    parts = text.split(_SEPARATOR)
    types.update(get_types_from_msg(parts[0], schema.name))
    for part in parts[1:]:
        header, _, body = part.strip("\n").partition("\n")
        if header.startswith("MSG: "):
            name = header[5:].strip()
            if "/msg/" not in name:
                package, _, short = name.partition("/")
                name = f"{package}/msg/{short}"
            types.update(get_types_from_msg(body, name))
    return types


def recover(bag_dir: Path, output: Path | None = None) -> tuple[Path, Counter, str]:
    """Rewrite the bag in `bag_dir` (or into `output`); returns (bag directory, messages by topic, cut)."""
    bag_dir = Path(bag_dir)
    files = sorted(bag_dir.glob("*.mcap"))
    if not files:
        raise FileNotFoundError(f"{bag_dir}: no .mcap file to recover")
    if output is None and (bag_dir / "metadata.yaml").exists():
        raise FileExistsError(f"{bag_dir}: has a metadata.yaml already (a closed bag); pass -o to rewrite it")
    found = [salvage(f) for f in files]
    store = get_typestore(Stores.ROS2_JAZZY)
    for part in found:
        for schema in part.schemas.values():
            if schema.encoding == "ros2msg" and schema.name not in store.types:
                store.register({k: v for k, v in definitions(schema).items() if k not in store.types})
    target = output or bag_dir.with_name(bag_dir.name + ".recovering")
    writer = BagWriter(target, store)
    counts: Counter = Counter()
    for part in found:
        for message in part.messages:
            channel = part.channels[message.channel_id]
            schema = part.schemas.get(channel.schema_id)
            if schema is None:
                continue
            writer.add_topic(channel.topic, schema.name, qos_profile())
            writer.write(channel.topic, message.log_time, message.data)
            counts[channel.topic] += 1
    writer.close()
    if output is None:  # in place: the cut files are kept beside the recovered bag, renamed
        for f in files:
            f.rename(f.with_name(f.name + ".cut"))
        for f in target.iterdir():
            f.rename(bag_dir / f.name)
        target.rmdir()
        target = bag_dir
    return target, counts, "; ".join(p.cut for p in found if p.cut)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="recover_bag", description=__doc__.split("\n")[0])
    ap.add_argument("bag", type=Path, help="the bag directory (runs/<run>/bag)")
    ap.add_argument("-o", "--output", type=Path, help="write the recovered bag here instead of in place")
    a = ap.parse_args(argv)
    if a.output is not None and a.output.exists():
        print(f"recover_bag: {a.output} exists: choose a new directory", file=sys.stderr)
        return EXIT_FAILED
    try:
        target, counts, cut = recover(a.bag, a.output)
    except (FileNotFoundError, FileExistsError) as e:
        print(f"recover_bag: {e}", file=sys.stderr)
        return EXIT_FAILED
    total = sum(counts.values())
    print(f"recover_bag: {total} messages on {len(counts)} topics written to {target}"
          + (f" (reading stopped at {cut})" if cut else ""))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
