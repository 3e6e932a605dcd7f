"""The suite command: every run in runs.csv with its outcome, one table, one figure per scenario."""

import csv
import json

from twbr_batch import suite
from twbr_batch.avoidability import OUTCOMES


def test_the_suite_classifies_every_run_and_writes_its_table_and_figures(tmp_path):
    out = tmp_path / "suite"
    assert suite.main(["-n", "3", "--scenarios", "trap_small,overtaken_fast", "--out", str(out)]) == 0
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
    assert (out / "figures" / "trap_small.png").stat().st_size > 10_000


def test_bad_arguments_are_refused_by_name(capsys):
    assert suite.main(["--methods", "paper,clever"]) == 2
    assert "invalid --methods 'paper,clever'" in capsys.readouterr().err
    assert suite.main(["--scenarios", "nowhere"]) == 2
    assert "nowhere not in the suite" in capsys.readouterr().err
    assert suite.main(["-n", "0"]) == 2


def test_the_suite_holds_the_papers_scenarios_and_at_least_ten_of_its_own():
    names = [p.stem for p in suite.suite_scenarios()]
    assert names[:3] == ["static", "dynamic_target", "dynamic_obstacles"]
    assert len(names) - 3 >= 10
    for path in suite.suite_scenarios()[3:]:
        assert path.read_text().startswith("# "), f"{path.name} says what it tests"
