"""What the live viewer costs in CPU: a recorded run replayed through the viewer's rounds into a served
Rerun viewer, as the live node would have drawn it.

The live viewer (twbr_view.viewer_node) takes, every 1/draw_rate s of wall time, the newest message of each
topic. Here the bag's receive times stand for that wall time: each window of 1/draw_rate s gives one
round of the newest message per topic, fed through the same RunView into a real `rerun --serve-web`
child over gRPC. Prints the CPU per round of this process (Python and Rerun's own threads) and of the
server, and the share of one core that makes at the node's draw rate. Not included: rclpy taking the
messages (the bag's are decoded by mcap's reader), ~0.05 ms per message.

    tools/run.sh python benchmarks/bench_viewer.py [runs/<run>]   # default: records a static run first
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import psutil
from results_file import write_results

from twbr_runner.bag_reader import read_messages
from twbr_runner.spawn import loopback_env
from twbr_view.scene import VIEWED_TOPICS, RunView, blueprint, feed, stamp_of
from twbr_view.server import ViewerServer, prepare


def cpu_seconds(pid: int) -> float:
    times = psutil.Process(pid).cpu_times()
    return times.user + times.system


def record_run(out: Path, domain: int) -> Path:
    subprocess.run([sys.executable, "-m", "twbr_runner.runner", "static", "--no-figures", "--quiet", "--out",
                    str(out), "--domain", str(domain)], env=loopback_env(domain), check=True)
    (run_dir,) = out.iterdir()
    return run_dir


def rounds(bag_dir: Path, draw_rate: float) -> list[list[tuple[str, object]]]:
    """The newest message of each topic per 1/draw_rate s of receive time, in the node's topic order."""
    messages = read_messages(bag_dir, [f"/{t}" for t in VIEWED_TOPICS])
    window_ns = round(1e9 / draw_rate)
    start = min(rows[0][0] for rows in messages.values())
    windows: dict[int, dict[str, object]] = {}
    for topic, rows in messages.items():
        for received, msg in rows:
            if stamp_of(msg) > 0.0 or topic.endswith("odom"):
                windows.setdefault((received - start) // window_ns, {})[topic.lstrip("/")] = msg
    return [[(t, w[t]) for t in VIEWED_TOPICS if t in w] for _k, w in sorted(windows.items())]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("run", type=Path, nargs="?", help="a run directory with its bag (default: record one)")
    ap.add_argument("--draw-rate", type=float, default=30.0, help="the node's draw_rate [Hz]")
    ap.add_argument("--domain", type=int, default=87)
    ap.add_argument("--json", type=Path, help="also write the figures here")
    a = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        run_dir = a.run or record_run(Path(tmp) / "runs", a.domain)
        batches = rounds(run_dir / "bag", a.draw_rate)
    prepare()
    import rerun as rr

    server = ViewerServer()
    try:
        rec = rr.RecordingStream("twbr-bench")
        rec.connect_grpc(server.grpc_url, default_blueprint=blueprint())
        view = RunView(rec.log, lambda t: rec.set_time("sim_time", duration=t))
        server_start, start, wall = cpu_seconds(server.proc.pid), time.process_time(), time.perf_counter()
        for batch in batches:
            for topic, msg in batch:
                feed(view, topic, msg)
        rec.flush()
        rec.disconnect()
        viewer_cpu, wall = time.process_time() - start, time.perf_counter() - wall
        time.sleep(1.0)  # the server has what was flushed; let it finish taking it in
        server_cpu = cpu_seconds(server.proc.pid) - server_start
    finally:
        server.stop()
    n = len(batches)
    figures = {"rounds": n, "messages": sum(len(b) for b in batches), "logged": sum(view.logged.values()),
               "viewer_ms_per_round": 1e3 * viewer_cpu / n, "server_ms_per_round": 1e3 * server_cpu / n,
               "draw_rate_hz": a.draw_rate}
    figures["core_share_at_draw_rate"] = (viewer_cpu + server_cpu) / n * a.draw_rate
    print(f"viewer: {n} rounds ({figures['messages']} messages, {figures['logged']} entities logged) in"
          f" {wall:.2f} s; CPU per round: viewer {figures['viewer_ms_per_round']:.2f} ms, Rerun server"
          f" {figures['server_ms_per_round']:.2f} ms; at {a.draw_rate:g} rounds/s:"
          f" {100 * figures['core_share_at_draw_rate']:.1f} % of one core")
    if a.json:
        a.json.parent.mkdir(parents=True, exist_ok=True)
        write_results(a.json, figures)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
