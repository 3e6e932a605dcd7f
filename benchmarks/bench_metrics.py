"""How the runner's metrics step scales with the bag: a recorded run with a flood of large obstacle arrays
added (5,000 obstacles per message, 50 messages a second, 500 m away: what a neighbour on the network can
put into a recording), measured from the bag alone as the runner does (`metrics.series_from_bag`, then
`compute_metrics`) in a child process, for its wall time and peak resident memory.

Prints, per bag size, the MB read per second and the peak memory; the flood's share of the bag grows with
`--flood-seconds`, so a memory that stays flat while the bag grows is the streaming at work.

    tools/run.sh python benchmarks/bench_metrics.py [runs/<run>] [--json out.json]   # default: records one
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
from results_file import write_results

from twbr_runner.bag_writer import BagWriter, qos_profile
from twbr_runner.spawn import loopback_env

HERE = Path(__file__).resolve().parent
COURSE = HERE.parent / "test" / "scenarios" / "fault_course.yaml"


def record_run(out: Path, domain: int) -> Path:
    subprocess.run([sys.executable, "-m", "twbr_runner.runner", str(COURSE), "--no-figures", "--quiet", "--out",
                    str(out), "--domain", str(domain)], env=loopback_env(domain), check=True)
    (run_dir,) = out.iterdir()
    return run_dir / "bag"


def flood_message(count: int, seed: int = 1) -> bytes:
    """A serialized ObstacleArray of `count` obstacles 500 m away (random, so it does not compress away)."""
    from rclpy.serialization import serialize_message

    from twbr_msgs.msg import Obstacle, ObstacleArray

    rng = np.random.default_rng(seed)
    msg = ObstacleArray()
    msg.header.frame_id = "odom"
    for i, (x, y) in enumerate(500.0 + rng.uniform(-50.0, 50.0, (count, 2))):
        o = Obstacle(id=1000 + i, radius=0.3)
        o.position.x, o.position.y = float(x), float(y)
        msg.obstacles.append(o)
    return bytes(serialize_message(msg))


def with_flood(source: Path, target: Path, obstacles: int, rate: float, seconds: float) -> float:
    """Copy the bag at `source` into `target`, adding the flood on /obstacles for `seconds` of its clock;
    returns the new bag's size [MB]."""
    from mcap.reader import make_reader
    from rosbags.typesys import Stores, get_typestore

    from twbr_runner.bag_reader import mcap_files
    from twbr_runner.bag_writer import typestore_with
    from twbr_runner.recorder import _share

    store = typestore_with(["twbr_msgs/msg/ObstacleArray"], _share, get_typestore(Stores.ROS2_JAZZY))
    writer = BagWriter(target, store)
    writer.add_topic("/obstacles", "twbr_msgs/msg/ObstacleArray", qos_profile())
    flood = bytearray(flood_message(obstacles))
    period_ns = round(1e9 / rate)
    clock_ns = next_flood = None
    for path in mcap_files(source):
        with path.open("rb") as f:
            for schema, channel, message in make_reader(f).iter_messages(log_time_order=True):
                writer.add_topic(channel.topic, schema.name, qos_profile())
                if channel.topic == "/clock":  # builtin_interfaces/Time after the 4-byte CDR header
                    sec, nanosec = np.frombuffer(message.data[4:12], dtype="<i4,<u4")[0]
                    clock_ns = int(sec) * 1_000_000_000 + int(nanosec)
                if clock_ns is not None and clock_ns <= seconds * 1e9:
                    next_flood = message.log_time if next_flood is None else next_flood
                    while next_flood <= message.log_time:
                        flood[4:8] = np.int32(clock_ns // 1_000_000_000).tobytes()
                        flood[8:12] = np.uint32(clock_ns % 1_000_000_000).tobytes()
                        writer.write("/obstacles", next_flood, bytes(flood))
                        next_flood += period_ns
                writer.write(channel.topic, message.log_time, message.data)
    writer.close()
    return sum(p.stat().st_size for p in target.iterdir()) / 1e6


MEASURE = """
import json, sys, time, resource
from pathlib import Path
from twbr_runner.metrics import compute_metrics, series_from_bag
started = time.perf_counter()
series = series_from_bag(Path(sys.argv[1]))
m = compute_metrics(series, "flood", 0, 1.0, step_responses=False).as_json()
print(json.dumps({"seconds": time.perf_counter() - started, "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                  "reached": m["reached"], "obstacle_snapshots": len(series.obstacles)}))
"""


def measure(bag: Path) -> dict:
    done = subprocess.run([sys.executable, "-c", MEASURE, str(bag)], capture_output=True, text=True, check=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("run", nargs="?", type=Path, help="a run directory (default: the fault course, recorded now)")
    ap.add_argument("--obstacles", type=int, default=5000)
    ap.add_argument("--rate", type=float, default=50.0)
    ap.add_argument("--flood-seconds", type=float, nargs="+", default=[0.0, 4.0, 8.0, 16.0])
    ap.add_argument("--json", type=Path)
    a = ap.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        source = a.run / "bag" if a.run else record_run(Path(tmp) / "run", 150 + os.getpid() % 50)
        for seconds in a.flood_seconds:
            bag = Path(tmp) / f"flood{seconds:g}"
            size = with_flood(source, bag, a.obstacles, a.rate, seconds)
            got = measure(bag)
            rows.append({"flood_s": seconds, "bag_mb": size, **got, "mb_per_s": size / got["seconds"]})
            print(f"flood {seconds:5.1f} s: bag {size:7.1f} MB, metrics in {got['seconds']:6.2f} s"
                  f" ({size / got['seconds']:6.1f} MB/s), peak {got['peak_mb']:6.0f} MB,"
                  f" {got['obstacle_snapshots']} obstacle snapshots, reached {got['reached']}", flush=True)
    if a.json:
        write_results(a.json, {"obstacles": a.obstacles, "rate_hz": a.rate, "maxrss_unit": "MB", "rows": rows,
                               "python_rusage": resource.RUSAGE_SELF})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
