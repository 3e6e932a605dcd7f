"""The Monte Carlo study: rows per seed, the same on the batch engine, the scalar cores in one process or
two, and a Dask cluster; bad input refused; an interrupted study keeps what finished."""

import csv
import json

import pytest

from twbr_batch import montecarlo as mc
from twbr_common.params import ConfigError

COURSE = """name: mc_course
duration: 60.0
seed: 3
end_on_target: true
robot: {x: 0.0, y: 0.0, yaw: 0.0}
target: {position: [2.0, 0.5], heading: 1.0, speed: 0.03, max_yaw_rate: 1.0, turn_interval: 1.0, capture_radius: 0.5}
obstacles:
  - {id: 1, position: [1.5, -1.5], radius: 0.3, speed: 0.15, heading: pi/2}
"""


@pytest.fixture
def course(tmp_path):
    path = tmp_path / "mc_course.yaml"
    path.write_text(COURSE)
    return path


@pytest.mark.parametrize("perception", [None, "truth"], ids=["lidar", "truth"])
def test_rows_are_the_same_on_every_engine(course, tmp_path, perception):
    # A user's scenario runs on the LiDAR unless told: the scan, tracker and target filter in both engines
    study = mc.Study(course, runs=3, perturbation=0.2, first_seed=2, perception=perception)
    assert study.perceived == (perception or "lidar")
    one = mc.run_study(study, tmp_path / "one", "scalar", workers=1, progress=False)
    two = mc.run_study(study, tmp_path / "two", "scalar", workers=2, progress=False)
    batch = mc.run_study(study, tmp_path / "batch", "batch", chunk=2, progress=False)
    assert one == two == batch  # every field of every row, exactly
    assert [r.seed for r in one] == [2, 3, 4]
    assert all(r.reached and not r.fallen and r.collisions == 0 for r in one)
    assert len({r.time_to_reach_s for r in one}) > 1  # seeds move the target and the robot differently
    with (tmp_path / "one" / "runs.csv").open() as f:
        rows = list(csv.DictReader(f))
    assert [int(r["seed"]) for r in rows] == [2, 3, 4] and set(rows[0]) == set(mc.COLUMNS)


def test_perturbation_factors_stay_in_range_and_follow_the_seed():
    assert set(mc.perturbation_factors(4, 0.0).values()) == {1.0}
    a, b = mc.perturbation_factors(4, 0.2), mc.perturbation_factors(4, 0.2)
    assert a == b and a != mc.perturbation_factors(5, 0.2)
    assert all(0.8 <= f <= 1.2 for f in a.values()) and set(a) == set(mc.PERTURBED)


def test_a_perturbed_robot_is_really_another_robot(course):
    nominal = mc.run_one(str(course), 5, 0.0)
    perturbed = mc.run_one(str(course), 5, 0.3)
    assert perturbed.factors["body_mass"] != 1.0
    assert perturbed.pitch_max_rad != nominal.pitch_max_rad


@pytest.mark.parametrize(("args", "message"), [
    (["-n", "0"], "invalid number of runs 0: must be at least 1"),
    (["-n", "-3"], "invalid number of runs -3"),
    (["--perturb", "1.0"], "invalid perturbation 1: must be in [0, 1)"),
    (["--perturb", "-0.1"], "invalid perturbation -0.1"),
    (["--workers", "0"], "invalid --workers 0"),
    (["--chunk", "0"], "invalid --chunk 0"),
    (["--engine", "scalar", "--scheduler", "tcp://127.0.0.1:8786"], "--scheduler runs the batch engine"),
])
def test_bad_input_is_refused_with_a_clear_message(course, tmp_path, capsys, args, message):
    assert mc.main([str(course), "--out", str(tmp_path / "out"), *args]) == mc.EXIT_BAD_INPUT
    assert message in capsys.readouterr().err
    assert not (tmp_path / "out").exists()  # nothing started, nothing written


def test_an_unknown_scenario_is_refused_naming_the_known_ones(tmp_path, capsys):
    assert mc.main(["nowhere", "--out", str(tmp_path)]) == mc.EXIT_BAD_INPUT
    assert "'nowhere'" in capsys.readouterr().err
    with pytest.raises(ConfigError):
        mc.Study(tmp_path / "x.yaml", runs=0)


def test_an_interrupted_study_keeps_the_finished_rows(course, tmp_path, monkeypatch, capsys):
    real = mc.run_chunk

    def run_chunk(path, seeds, *args, **kwargs):
        if 3 in seeds:
            raise KeyboardInterrupt  # Ctrl-C during the second batch
        return real(path, seeds, *args, **kwargs)

    monkeypatch.setattr(mc, "run_chunk", run_chunk)
    assert mc.main([str(course), "-n", "5", "--chunk", "2", "--out", str(tmp_path / "out")]) == mc.EXIT_INTERRUPTED
    (out,) = (tmp_path / "out").iterdir()
    with (out / "runs.csv").open() as f:
        assert [int(r["seed"]) for r in csv.DictReader(f)] == [1, 2]
    assert "2 finished runs kept" in capsys.readouterr().err


def test_a_study_writes_its_table_summary_and_figure(course, tmp_path, capsys):
    assert mc.main([str(course), "-n", "2", "--out", str(tmp_path / "out")]) == 0
    # The kernels are loaded (or compiled, and said so) before the study's clock and progress bar start.
    said = capsys.readouterr().out
    from twbr_common import jit

    if jit.COMPILED:
        assert said.index("montecarlo: loading the batch engine's compiled kernels") < said.index("2 runs in")
    (out,) = (tmp_path / "out").iterdir()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["runs"] == 2 and summary["success_rate"] == 1.0 and summary["cores"] >= 1
    assert summary["time_to_reach_s"]["min"] <= summary["time_to_reach_s"]["max"]
    assert (out / "summary.png").stat().st_size > 10_000


def test_a_dask_cluster_on_loopback_gives_the_single_process_rows(course, tmp_path):
    distributed = pytest.importorskip("distributed")
    study = mc.Study(course, runs=5, perturbation=0.2, first_seed=1)
    here = mc.run_study(study, tmp_path / "here", "batch", chunk=2, progress=False)
    with distributed.LocalCluster(host="127.0.0.1", n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster:
        assert cluster.scheduler_address.startswith("tcp://127.0.0.1:")
        there = mc.run_study(study, tmp_path / "there", scheduler=cluster.scheduler_address, chunk=2,
                             progress=False)
    assert there == here
    with (tmp_path / "there" / "runs.csv").open() as f:
        assert [int(r["seed"]) for r in csv.DictReader(f)] == [1, 2, 3, 4, 5]


def test_progress_in_a_log_is_a_line_per_tenth_and_on_a_terminal_one_bar(capsys):
    for done in range(1, 1001):
        mc._progress(done, done, 1000, 0.01 * done, tty=False)
    lines = capsys.readouterr().err.splitlines()
    assert [line.split("]")[1].split(",")[0].strip() for line in lines] == [f"{k}/1000 runs" for k in range(100, 1001, 100)]
    assert "\r" not in "".join(lines)
    assert "1000 succeeded" in lines[-1]
    for done in range(1, 11):
        mc._progress(done, done, 10, 0.1 * done, tty=True)
    err = capsys.readouterr().err
    assert err.count("\r") == 10 and "\n" not in err


def test_a_scenario_without_target_and_an_unwritable_out_are_refused_in_one_line(course, tmp_path, capsys):
    # Before: a study of a scripted scenario ran and reported 0 % success; an unwritable --out was a traceback.
    assert mc.main(["step", "--out", str(tmp_path / "out")]) == mc.EXIT_BAD_INPUT
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "has no target" in err[0]
    (tmp_path / "a_file").write_text("")
    assert mc.main([str(course), "--out", str(tmp_path / "a_file" / "out")]) == mc.EXIT_BAD_INPUT
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "cannot write to --out" in err[0], err


def test_sigterm_ends_a_study_as_the_runner_does_exit_143_rows_kept(course, tmp_path):
    import signal
    import subprocess
    import sys
    import time

    proc = subprocess.Popen([sys.executable, "-m", "twbr_batch.montecarlo", str(course), "-n", "4000", "--chunk",
                             "40", "--out", str(tmp_path / "out"), "--no-figure"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    csv_path = None
    while time.monotonic() < deadline and proc.poll() is None:
        found = list((tmp_path / "out").glob("*/runs.csv"))
        if found and len(found[0].read_text().splitlines()) > 40:
            csv_path = found[0]
            break
        time.sleep(0.2)
    assert csv_path is not None, proc.communicate()
    proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=60)
    assert proc.returncode == 143, (out, err)
    kept = len(csv_path.read_text().splitlines()) - 1
    assert 40 <= kept < 4000 and f"{kept} finished runs kept" in err
