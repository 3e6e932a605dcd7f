"""The live viewer beside a real graph (the runner's --view), and the same run replayed from its bag."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import time
import urllib.request

import numpy as np
import pytest
from browser import chromium, screenshot
from PIL import Image

pytest.importorskip("rerun", reason="rerun-sdk is not installed (the viewer is optional)")

pytestmark = pytest.mark.e2e


def test_the_runner_serves_the_run_live_and_view_bag_replays_it(tmp_path, ros_domain):
    env = {**os.environ, "ROS_DOMAIN_ID": str(ros_domain), "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST",
           "TWBR_RERUN_CONFIG": str(tmp_path / "rerun-config")}
    runner = subprocess.Popen([sys.executable, "-m", "twbr_runner.runner", "static", "--view", "0", "--out",
                               str(tmp_path / "runs"), "--domain", str(ros_domain), "--no-figures"],
                              env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    lines = []
    page = ""
    for line in runner.stdout:
        lines.append(line)
        if "viewer: http://127.0.0.1:" in line and not page:
            url = line.split("viewer: ", 1)[1].strip()
            page = urllib.request.urlopen(url.split("?")[0], timeout=10).read().decode()
    assert runner.wait(300) == 0, "".join(lines)
    assert "Rerun" in page and "re_viewer" in page  # the web viewer's page, served on loopback
    (run_dir,) = (tmp_path / "runs").iterdir()
    log = (run_dir / "logs" / "viewer.err").read_text()
    counts = dict(re.findall(r"([\w/]+) (\d+)", log.split("entities on", 1)[1]))
    rounds, taken = (int(n) for n in re.search(r"drew (\d+) rounds \((\d+) messages taken\)", log).groups())
    wall = json.loads((run_dir / "metrics.json").read_text())["wall_time_s"]
    # Live: the map and the plots were drawn through the whole run, in rounds of at most one message per
    # topic, at most 30 rounds a second of wall time (the viewer lives a few seconds longer than the run).
    assert 5 * wall < rounds < 30 * (wall + 15) and taken <= 6 * rounds
    assert int(counts["map/robot"]) > 3 * wall and int(counts["map/field"]) >= 20
    assert int(counts["plots/speed"]) > 3 * wall
    done = subprocess.run([sys.executable, "-m", "twbr_view.view_bag", str(run_dir)], env=env, capture_output=True,
                          text=True, timeout=300)
    assert done.returncode == 0, done.stdout + done.stderr
    assert (run_dir / "view.rrd").stat().st_size > 1_000_000
    logged = int(re.search(r"(\d+) entities logged", done.stdout).group(1))
    assert logged > sum(int(n) for n in counts.values())  # the bag has every message; the live view drops


@pytest.mark.long  # 38 s; the served page's content is checked by the test above in `make test`
@pytest.mark.skipif(chromium() is None, reason="no chromium: the set-up installs Debian's `chromium` with apt as"
                    " root; on this machine it could not")
def test_the_served_page_draws_the_map_in_a_browser(launch, tmp_path, monkeypatch):
    """Headless Chromium (software WebGL) opens the live viewer while the static scenario runs: the map panel
    shows the potential field's colours, not a blank canvas."""
    monkeypatch.setenv("TWBR_RERUN_CONFIG", str(tmp_path / "rerun-config"))
    viewer = launch("twbr_view", "viewer", "-p", "web_port:=0", "-p", "grpc_port:=0")
    deadline = time.monotonic() + 30.0
    while "open http" not in viewer.output:
        assert time.monotonic() < deadline and viewer.running, viewer.output
        time.sleep(0.2)
    url = viewer.output.split("open ", 1)[1].split(" ", 1)[0]
    launch("twbr_control", "controller_node", params=("controller.yaml",))
    launch("twbr_planner", "planner_node", "-p", "method:=paper", params=("planner.yaml",))
    launch("twbr_sim", "sim_node", "-p", "scenario:=static", "-p", "wait_for_subscribers:=3",
           "-p", "lockstep_planner_rate:=20.0", params=("robot.yaml", "sim.yaml"))
    # Patience, not a budget: it ends at the first shot that shows the map (busy loops beside: 60 s+ seen).
    path = screenshot(url, tmp_path / "viewer.png", wait_s=20.0, accept=map_drawn, patience_s=120.0)
    path_share, field_share = map_colours(path)
    assert map_drawn(path), f"the map panel shows {100 * path_share:.2f} % path, {100 * field_share:.2f} % field"


def map_colours(path) -> tuple[float, float]:
    """The shares of the map panel (the blueprint's left column) drawn in the robot path's red and in the
    other colours (the field's viridis, the target, the arrows); a blank canvas is grey: 0 and 0."""
    shot = np.asarray(Image.open(path).convert("RGB")).astype(int)
    height, width, _ = shot.shape
    panel = shot[int(0.1 * height):int(0.65 * height), : int(0.6 * width)]
    coloured = (panel.max(axis=2) - panel.min(axis=2)) > 60
    red = (panel[..., 0] > 150) & (panel[..., 1] < 90) & (panel[..., 2] < 90)
    return float(red.mean()), float((coloured & ~red).mean())


def map_drawn(path) -> bool:
    # Measured on drawn maps: path 0.25-0.30 %, field 1.7-4.8 % (the camera's framing varies); blank: 0, 0.
    path_share, field_share = map_colours(path)
    return path_share > 0.001 and field_share > 0.005
