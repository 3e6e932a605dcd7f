"""make demo / montecarlo / suite refuse a bad argument before anything is set up or built."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def check(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(ROOT / "tools" / "check_args.py"), *args], capture_output=True,
                          text=True)


def test_known_scenarios_files_and_numbers_pass(tmp_path):
    mine = tmp_path / "my_lab.yaml"
    mine.write_text("duration: 10\n")
    assert check("--scenario", "dynamic_obstacles", "--runs", "1000", "--perturb", "0.2").returncode == 0
    assert check("--scenario", "crowd_crossing", "--perception", "lidar").returncode == 0
    assert check("--scenario", "static", "--perception", "").returncode == 0  # make's unset PERCEPTION
    assert check("--scenarios", f"suite/gap_1m,clutter,{mine}", "--runs", "5").returncode == 0


def test_each_bad_argument_is_named():
    out = check("--scenario", "dynamic_obstacle", "--runs", "0", "--perturb", "1.5", "--perception", "camera")
    assert out.returncode == 2
    assert "'dynamic_obstacle'" in out.stderr and "N='0'" in out.stderr and "PERTURB='1.5'" in out.stderr
    assert "PERCEPTION='camera'" in out.stderr
    assert check("--scenarios", "clutter,nowhere", "--runs", "ten").stderr.count("\n") == 2


def test_make_refuses_before_building():
    started = time.monotonic()
    out = subprocess.run(["make", "-s", "montecarlo", "SCENARIO=no_such_layout"], cwd=ROOT, capture_output=True,
                         text=True)
    assert out.returncode != 0 and "'no_such_layout'" in out.stderr
    assert "bootstrap" not in out.stdout + out.stderr and "colcon" not in out.stdout + out.stderr
    assert time.monotonic() - started < 30.0  # patience only: the check itself takes ~0.1 s
