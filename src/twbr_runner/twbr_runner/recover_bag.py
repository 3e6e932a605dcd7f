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
import shutil
import struct
import sys
from collections.abc import Callable
from pathlib import Path

from mcap.exceptions import McapError
from mcap.records import Channel, Chunk, McapRecord, Message, Schema
from mcap.stream_reader import StreamReader, breakup_chunk
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from twbr_runner.bag_writer import BagWriter, disk_full_text, is_disk_full, qos_profile

EXIT_FAILED = 1
_SEPARATOR = "=" * 80


def salvage(path: Path, take: Callable[[McapRecord], None]) -> str:
    """Hand every whole record of an MCAP file to `take`, in file order, up to the cut; returns why reading
    stopped before the end ("" when it did not)."""
    with Path(path).open("rb") as f:
        try:
            for record in StreamReader(f, emit_chunks=True).records:
                if not isinstance(record, Chunk):
                    take(record)
                    continue
                try:
                    inner = breakup_chunk(record, validate_crc=True)
                except (McapError, ValueError, EOFError) as e:  # a chunk cut mid-write
                    return f"a damaged chunk ({e})"
                for item in inner:
                    take(item)
        except (McapError, ValueError, EOFError, OSError, struct.error) as e:  # struct: a record's fields cut
            return f"the file ends mid-record ({type(e).__name__})"
    return ""


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


def recover(bag_dir: Path, output: Path | None = None) -> tuple[Path, dict[str, int], str]:
    """Rewrite the bag in `bag_dir` (or into `output`); returns (bag directory, messages by topic, cut)."""
    bag_dir = Path(bag_dir)
    files = sorted(bag_dir.glob("*.mcap"))
    if not files:
        raise FileNotFoundError(f"{bag_dir}: no .mcap file to recover")
    if output is None and (bag_dir / "metadata.yaml").exists():
        raise FileExistsError(f"{bag_dir}: has a metadata.yaml already (a closed bag); pass -o to rewrite it")
    target = output or bag_dir.with_name(bag_dir.name + ".recovering")
    try:
        return _rewrite(bag_dir, files, target, in_place=output is None)
    except OSError as e:
        if not is_disk_full(e):
            raise
        shutil.rmtree(target, ignore_errors=True)  # half a bag helps nobody, and frees the room it took
        raise DiskFull(f"{disk_full_text(target, e)}; nothing was changed in {bag_dir}: pass -o with a directory"
                       " on a disk with room") from None


class DiskFull(RuntimeError):
    """The recovered bag's disk is full: one line for the user, the source left as it was."""


def _rewrite(bag_dir: Path, files: list[Path], target: Path, in_place: bool) -> tuple[Path, dict[str, int], str]:
    store = get_typestore(Stores.ROS2_JAZZY)
    writer = BagWriter(target, store)
    cuts = []
    for path in files:
        # Written as read: a cut bag can be far larger than memory. MCAP puts each schema and channel before
        # the first message that uses it; ids are per file.
        schemas: dict[int, Schema] = {}
        channels: dict[int, Channel] = {}

        def take(record: McapRecord, schemas=schemas, channels=channels) -> None:
            if isinstance(record, Schema):
                schemas[record.id] = record
                if record.encoding == "ros2msg" and record.name not in store.types:
                    store.register({k: v for k, v in definitions(record).items() if k not in store.types})
            elif isinstance(record, Channel):
                channels[record.id] = record
            elif isinstance(record, Message) and record.channel_id in channels:
                channel = channels[record.channel_id]
                schema = schemas.get(channel.schema_id)
                if schema is not None:
                    writer.add_topic(channel.topic, schema.name, qos_profile())
                    writer.write(channel.topic, record.log_time, record.data)

        cuts.append(salvage(path, take))
    writer.close()
    if in_place:  # the cut files are kept beside the recovered bag, renamed
        for f in files:
            f.rename(f.with_name(f.name + ".cut"))
        for f in target.iterdir():
            f.rename(bag_dir / f.name)
        target.rmdir()
        target = bag_dir
    return target, writer.counts, "; ".join(cut for cut in cuts if cut)


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
    except (FileNotFoundError, FileExistsError, DiskFull) as e:
        print(f"recover_bag: {e}", file=sys.stderr)
        return EXIT_FAILED
    total = sum(counts.values())
    print(f"recover_bag: {total} messages on {len(counts)} topics written to {target}"
          + (f" (reading stopped at {cut})" if cut else ""))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
