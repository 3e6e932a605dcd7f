"""view_bag: a recorded run in the live viewer's layout, as a .rrd file beside it and, with --serve, in the
browser.

    ros2 run twbr_view view_bag runs/<run>            # writes runs/<run>/view.rrd
    ros2 run twbr_view view_bag runs/<run> --serve    # and serves it: open the URL it prints
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from twbr_view.scene import VIEWED_TOPICS, RunView, blueprint, feed, stamp_of
from twbr_view.server import ViewerServer, prepare


def bag_dir_of(path: Path) -> Path:
    return path / "bag" if (path / "bag").is_dir() else path


def write_rrd(bag_dir: Path, out: Path, grpc_url: str | None = None) -> RunView:
    """Every viewed message of the bag, in recording order, through RunView into `out` (and to a viewer's
    proxy at `grpc_url`, which keeps it for the browsers that connect later)."""
    prepare()
    import rerun as rr

    from twbr_runner.bag_reader import read_messages

    rec = rr.RecordingStream("twbr", recording_id=str(bag_dir.resolve()))
    sinks = [rr.FileSink(str(out))] + ([rr.GrpcSink(grpc_url)] if grpc_url else [])
    rec.set_sinks(*sinks, default_blueprint=blueprint())
    view = RunView(rec.log, lambda t: rec.set_time("sim_time", duration=t))
    messages = read_messages(bag_dir, [f"/{t}" for t in VIEWED_TOPICS])
    merged = sorted((received, topic, i) for topic, rows in messages.items() for i, (received, _m) in enumerate(rows))
    for _received, topic, i in merged:
        msg = messages[topic][i][1]
        if stamp_of(msg) > 0.0 or topic.endswith("odom"):
            feed(view, topic, msg)
    rec.flush()
    rec.disconnect()
    return view


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="view_bag", description=__doc__.split("\n")[0])
    ap.add_argument("run", type=Path, help="a run directory (runs/<run>) or its bag directory")
    ap.add_argument("--out", type=Path, help="the .rrd to write (default: <run>/view.rrd)")
    ap.add_argument("--serve", action="store_true", help="serve it in the web viewer on localhost until Ctrl-C")
    a = ap.parse_args(argv)
    bag = bag_dir_of(a.run)
    if not bag.is_dir():
        print(f"view_bag: no bag at {bag}", file=sys.stderr)
        return 2
    out = a.out or (a.run if a.run != bag else bag.parent) / "view.rrd"
    server = ViewerServer() if a.serve else None
    view = write_rrd(bag, out, server.grpc_url if server else None)
    print(f"view_bag: {sum(view.logged.values())} entities logged from {bag} -> {out}")
    if server is not None:
        print(f"view_bag: open {server.url} (Ctrl-C stops)", flush=True)
        try:
            while server.proc.poll() is None:
                time.sleep(0.5)
        except KeyboardInterrupt:
            pass
        finally:
            server.stop()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
