"""The suite command: every run in runs.csv with its outcome, one table, one figure per scenario."""

import csv
import json

import pytest

from twbr_batch import suite
from twbr_batch.avoidability import OUTCOMES


def test_the_suite_classifies_every_run_and_writes_its_table_and_figures(tmp_path):
    out = tmp_path / "suite"
    assert suite.main(["-n", "3", "--scenarios", "trap_small,overtaken_fast", "--methods", "paper,robust", "--out",
                       str(out)]) == 0
    rows = list(csv.DictReader((out / "runs.csv").open()))
    assert len(rows) == 2 * 2 * 3
    assert {r["outcome"] for r in rows} <= set(OUTCOMES)
    by = {(r["scenario"], r["variant"], r["seed"]): r for r in rows}
    # The paper's field is caught in the trap and run over from behind; the robust one is neither.
    assert all(by[("trap_small", "paper", s)]["outcome"] == "trapped" for s in "123")
    assert all(by[("trap_small", "robust", s)]["outcome"] == "success" for s in "123")
    assert all(by[("overtaken_fast", "paper", s)]["outcome"].startswith("collision") for s in "123")
    summary = json.loads((out / "summary.json").read_text())
    assert summary["trap_small"]["robust"]["success_rate"] == 1.0
    assert summary["trap_small"]["paper"]["trapped"] == 3
    table = (out / "table.md").read_text()
    assert "| trap_small | robust | 100.0 % |" in table
    # the motors' largest jolt per run (issue 35's <= 0.03 N·m), per run and as the cell's worst
    jolts = [float(r["torque_step_max_nm"]) for r in rows]
    assert all(0.0 < j < 1.0 for j in jolts)
    assert summary["trap_small"]["robust"]["torque_step_max_nm"] == pytest.approx(max(
        float(r["torque_step_max_nm"]) for r in rows if r["scenario"] == "trap_small" and r["variant"] == "robust"),
        abs=1e-6)  # runs.csv keeps 6 digits
    assert "largest torque step [N·m]" in table
    assert (out / "figures" / "trap_small.png").stat().st_size > 10_000


def test_bad_arguments_are_refused_by_name(capsys):
    assert suite.main(["--methods", "paper,clever"]) == 2
    assert "invalid --methods 'paper,clever'" in capsys.readouterr().err
    assert suite.main(["--scenarios", "nowhere"]) == 2
    assert "invalid --scenarios entry 'nowhere': not a suite name" in capsys.readouterr().err
    assert suite.main(["--scenarios", "step"]) == 2
    assert "scenario step has no target" in capsys.readouterr().err
    assert suite.main(["-n", "0"]) == 2
    assert suite.main(["--perception", "truth,sonar"]) == 2
    assert "invalid --perception 'truth,sonar': must be truth, lidar or truth,lidar" in capsys.readouterr().err


def test_each_scenario_is_seen_as_it_says_and_truth_and_lidar_run_side_by_side(tmp_path):
    out = tmp_path / "own"
    assert suite.main(["-n", "2", "--scenarios", "dynamic_obstacles,head_on", "--methods", "robust", "--out",
                       str(out), "--no-figures"]) == 0
    rows = list(csv.DictReader((out / "runs.csv").open()))
    # the paper's scenario pins the truth (it reproduces the paper); every other runs on the LiDAR
    assert {(r["scenario"], r["perception"]) for r in rows} == {("dynamic_obstacles", "truth"), ("head_on", "lidar")}
    out = tmp_path / "both"
    assert suite.main(["-n", "2", "--scenarios", "head_on", "--methods", "robust", "--perception", "truth,lidar",
                       "--out", str(out), "--no-figures"]) == 0
    rows = list(csv.DictReader((out / "runs.csv").open()))
    assert {(r["variant"], r["perception"]) for r in rows} == {("robust", "truth"), ("robust lidar", "lidar")}
    assert all(r["outcome"] == "success" for r in rows)
    table = (out / "table.md").read_text()
    assert "| head_on | robust lidar | 100.0 % |" in table
    # the tracker judged on the LiDAR's runs only: runs.csv's track_* cells, summary.json, a second table
    judged = {r["perception"]: float(r["track_judged"] or 0) for r in rows}
    assert judged["lidar"] > 50 and judged["truth"] == 0
    tracking = json.loads((out / "summary.json").read_text())["head_on"]
    assert tracking["robust"]["tracking"] is None
    lidar = tracking["robust lidar"]["tracking"]
    assert lidar["position_rmse_m"] < 0.1 and lidar["missed_pct"] < 10.0, lidar
    assert "| scenario | planner | position RMSE [m] |" in table and "| head_on | robust lidar | 0.0" in table


def test_the_suite_holds_the_papers_scenarios_and_at_least_ten_of_its_own():
    names = [p.stem for p in suite.suite_scenarios()]
    assert names[:3] == ["static", "dynamic_target", "dynamic_obstacles"]
    assert len(names) - 3 >= 10
    for path in suite.suite_scenarios()[3:]:
        assert path.read_text().startswith("# "), f"{path.name} says what it tests"


def test_a_users_own_scenario_file_runs_beside_a_suite_name_for_every_method(tmp_path, capsys):
    lab = tmp_path / "my_lab.yaml"
    lab.write_text(
        "# a doorway between two desks, a colleague walking through it\n"
        "name: my_lab\nduration: 60.0\nend_on_target: true\n"
        "target: {position: [8.0, 0.0]}\n"
        "obstacles:\n"
        "  - {id: 1, position: [4.0, 1.2], radius: 0.6}\n"
        "  - {id: 2, position: [4.0, -1.2], radius: 0.6}\n"
        "  - {id: 3, position: [6.0, 3.0], radius: 0.3, motion: waypoints, speed: 0.4,"
        " waypoints: [[6.0, -3.0], [6.0, 3.0]]}\n")
    out = tmp_path / "suite"
    assert suite.main(["-n", "2", "--scenarios", f"{lab},head_on", "--out", str(out), "--no-figures"]) == 0
    rows = list(csv.DictReader((out / "runs.csv").open()))
    assert {(r["scenario"], r["variant"]) for r in rows} == {
        (name, method) for name in ("my_lab", "head_on") for method in ("paper", "robust", "dwa", "vo")}
    assert {r["outcome"] for r in rows} <= set(OUTCOMES)
    table = (out / "table.md").read_text()
    assert all(f"| my_lab | {method} |" in table for method in ("paper", "robust", "dwa", "vo"))
    broken = tmp_path / "broken.yaml"
    broken.write_text("target: {position: [8.0, 0.0]}\nobstacles: [{position: [1.0, 1.0], radius: -1}]\n")
    capsys.readouterr()
    assert suite.main(["--scenarios", str(broken)]) == 2
    assert "obstacles[0].radius" in capsys.readouterr().err
