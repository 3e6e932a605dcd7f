"""The docs say what the code does: generated tables equal the specs, links lead somewhere."""

from __future__ import annotations

import json
import re
import sys
from pathlib import Path

from twbr_runner.parameter_docs import render

ROOT = Path(__file__).resolve().parent.parent
DOCS = [ROOT / "README.md", ROOT / "benchmarks" / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


def test_parameters_md_is_what_the_specs_render():
    written = (ROOT / "docs" / "parameters.md").read_text()
    assert written == render(), (
        "docs/parameters.md differs from the parameter specs: run"
        " `tools/run.sh python -m twbr_runner.parameter_docs docs/parameters.md`"
    )


def test_every_parameter_a_node_declares_has_a_row():
    # What each node declares is NODE_PARAMETERS (test_e2e_parameters checks it against the running nodes).
    from twbr_runner.parameter_docs import NODE_PARAMETERS

    text = (ROOT / "docs" / "parameters.md").read_text()
    for node, specs in NODE_PARAMETERS.items():
        for spec in specs:
            assert f"| `{spec.name}` |" in text, (node, spec.name)


def test_readme_is_a_front_door():
    assert len((ROOT / "README.md").read_bytes()) <= 12 * 1024


def test_relative_links_lead_to_files():
    link = re.compile(r"\]\(([^)#\s]+)(?:#[^)]*)?\)")
    for doc in DOCS:
        for target in link.findall(doc.read_text()):
            if "://" in target:
                continue
            assert (doc.parent / target).exists(), f"{doc.relative_to(ROOT)} links to missing {target}"


def test_the_paper_runs_the_docs_show_are_the_measured_ones():
    """README.md's and docs/scenarios.md's table of the paper's three runs cites benchmarks/results/
    paper_runs.json (benchmarks/study_paper_runs.py); a row that the file does not back fails here."""
    import json

    results = json.loads((ROOT / "benchmarks" / "results" / "paper_runs.json").read_text())
    row = re.compile(r"^\| `(static|dynamic_target|dynamic_obstacles)`[^|]*\| ([0-9.]+) s \| ([0-9.]+) m \| "
                     r"±([0-9.]+) rad \|$", re.M)
    for doc in (ROOT / "README.md", ROOT / "docs" / "scenarios.md"):
        rows = row.findall(doc.read_text())
        assert len(rows) == 3, doc.name
        for name, reached, clearance, pitch in rows:
            measured = results["scenarios"][name]
            assert float(reached) == round(measured["reached_at_s"], 1), (doc.name, name, "reached at")
            assert float(clearance) == round(measured["min_clearance_m"], 2), (doc.name, name, "clearance")
            assert float(pitch) == round(measured["pitch_abs_max_rad"], 4), (doc.name, name, "pitch")


def _figures_module():
    import importlib.util

    spec = importlib.util.spec_from_file_location("figures", ROOT / "benchmarks" / "figures.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclass looks its module up there
    spec.loader.exec_module(module)
    return module


def test_the_benchmarks_table_is_the_one_the_results_give():
    """benchmarks/README.md's table is rendered from benchmarks/results (benchmarks/figures.py): a figure
    typed by hand there, or a result measured again without the table re-rendered, fails here."""
    figures = _figures_module()
    readme = (ROOT / "benchmarks" / "README.md").read_text()
    block = figures.current_block(readme)
    assert block, "benchmarks/README.md lost its generated table's markers"
    assert block == figures.render(), "run: tools/run.sh python benchmarks/figures.py --write"


def test_every_result_says_when_and_at_which_commit_it_was_measured():
    for path in sorted((ROOT / "benchmarks" / "results").glob("*.json")):
        data = json.loads(path.read_text())
        assert re.fullmatch(r"\d{4}-\d\d-\d\d", str(data.get("date"))), f"{path.name} has no date"
        assert re.fullmatch(r"[0-9a-f]{7,40}\+?", str(data.get("commit"))), f"{path.name} has no commit"


def test_speed_figures_in_the_docs_are_the_table_s():
    """A batch-engine rate or a real-time factor in README.md or docs/ must be one the current table shows
    (they cite it); the history of how they moved is benchmarks/HISTORY.md's."""
    table = _figures_module().render()
    shown = set(re.findall(r"(\d+(?:\.\d+)?) M\b", table)) | set(re.findall(r"real-time factor (\d+(?:\.\d+)?)", table))
    pattern = re.compile(r"(\d+(?:\.\d+)?)(?:[–-]\d+(?:\.\d+)?)? M robot-steps/s|real-time factor (\d+(?:\.\d+)?)")
    for doc in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        for match in pattern.finditer(doc.read_text()):
            value = match.group(1) or match.group(2)
            assert value in shown, f"{doc.name}: {match.group(0)!r} is not in benchmarks/README.md's table"


def _result(name: str) -> dict:
    return json.loads((ROOT / "benchmarks" / "results" / name).read_text())


def test_the_readme_s_control_and_success_figures_are_the_studies():
    """README.md's step response, realistic-sensor settling and 1000-seed success rates are the ones
    benchmarks/results holds (study_robustness.py, bench_torque.py, study_paper_runs.py)."""
    text = " ".join((ROOT / "README.md").read_text().split())
    cells = {(r["controller"], r["sensors"], r["perturbation"]): r for r in _result("robustness.json")["rows"]}
    nominal, realistic = cells[("pid", "ideal", 0.0)], cells[("pid", "realistic", 0.0)]
    shipped = _result("bench_torque.json")["rows"]["shipped"]
    step = re.search(r"settles within 5 % in ([0-9.]+) s, overshoot ([0-9.]+) %, rolls back ([0-9]+) %", text)
    assert step, "README.md lost its step-response sentence"
    assert float(step[1]) == round(nominal["settle_median_s"], 2)
    assert float(step[2]) == round(shipped["step_overshoot_pct"], 1)
    assert int(step[3]) == round(nominal["rollback_max_pct"])
    noisy = re.search(r"([0-9]+) % of noise seeds settle within 1.5 s \(median ([0-9.]+) s\)", text)
    assert noisy and int(noisy[1]) == round(realistic["step_met_pct"])
    assert float(noisy[2]) == round(realistic["settle_median_s"], 2)
    success = re.search(r"static ([0-9.]+) %, dynamic target ([0-9.]+) %, dynamic obstacles ([0-9.]+) %; with "
                        r"masses, inertias and motor constant ±20 % and realistic sensors: ([0-9.]+) / ([0-9.]+) / "
                        r"([0-9.]+) %", text)
    assert success, "README.md lost its 1000-seed success sentence"
    runs = _result("paper_runs.json")["scenarios"]
    for k, name in enumerate(("static", "dynamic_target", "dynamic_obstacles")):
        assert float(success[1 + k]) == round(runs[name]["success_pct"]["nominal"], 1), name
        assert float(success[4 + k]) == round(runs[name]["success_pct"]["perturbed_realistic"], 1), name


def test_the_engine_comparison_docs_dynamics_shows_is_the_measured_one():
    """docs/dynamics.md's sim_node / mujoco_driver table of the paper's runs and the step is
    benchmarks/results/engines.json (benchmarks/compare_engines.py)."""
    graph = _result("engines.json")["graph"]
    text = (ROOT / "docs" / "dynamics.md").read_text()
    rows = re.findall(r"^\| (static|dynamic_target|dynamic_obstacles)[^|]*\| ([0-9.]+) s, ([0-9.]+) m \| "
                      r"([0-9.]+) s, ([0-9.]+) m \|$", text, re.M)
    assert [r[0] for r in rows] == ["static", "dynamic_target", "dynamic_obstacles"]
    for name, *cells in rows:
        for engine, (reached, clearance) in zip(("sim", "mujoco"), (cells[:2], cells[2:]), strict=True):
            run = graph[name][engine]
            assert float(reached) == round(run["time_to_reach_s"], 2), (name, engine)
            assert float(clearance) == round(run["min_clearance_m"], 3), (name, engine)
    step = re.search(r"^\| 0.1 m/s step: settling, overshoot[^|]*\| ([0-9.]+) s, ([0-9.]+) % \| ([0-9.]+) s, "
                     r"([0-9.]+) % \|$", text, re.M)
    assert step, "docs/dynamics.md lost its step row"
    for k, engine in enumerate(("sim", "mujoco")):
        assert float(step[1 + 2 * k]) == round(graph["step"][engine]["settle_time_s"], 3)
        assert float(step[2 + 2 * k]) == round(graph["step"][engine]["overshoot_pct"], 2)


def test_the_readme_s_people_figures_are_the_study_s():
    """README.md's success rates among people are benchmarks/results/people.json's (study_suite.py --people)."""
    text = " ".join((ROOT / "README.md").read_text().split())
    people = _result("people.json")
    found = re.search(r"Among people \(issue 35's layouts, ([0-9]+) seeds[^)]*\) it is not there yet: (.*?), where "
                      r"the dynamic window peer reaches ([0-9.]+) % on clutter_movers and ([0-9.]+) % on reactive_crowd",
                      text)
    assert found, "README.md lost its sentence on the people layouts"
    assert int(found[1]) == people["runs_per_cell"]
    pairs = re.findall(r"([a-z_]+) ([0-9.]+) %", found[2])
    assert len(pairs) >= 4
    for layout, rate in pairs:
        assert float(rate) == round(100 * people["layouts"][layout]["robust"]["success_rate"], 1), layout
    assert float(found[3]) == round(100 * people["layouts"]["clutter_movers"]["dwa"]["success_rate"], 1)
    assert float(found[4]) == round(100 * people["layouts"]["reactive_crowd"]["dwa"]["success_rate"], 1)
    sooner = re.search(r"arrives sooner \(people_flow ([0-9.]+) s against ([0-9.]+)", text)
    assert sooner, "README.md lost the time to reach beside the people figures"
    flow = people["layouts"]["people_flow"]
    assert float(sooner[1]) == round(flow["dwa"]["time_to_reach_median_s"], 1)
    assert float(sooner[2]) == round(flow["robust"]["time_to_reach_median_s"], 1)


def test_the_suite_and_ablation_tables_docs_planner_shows_are_the_study_s():
    figures = _figures_module()
    blocks = [b for b in figures.BLOCKS if b[0] == figures.PLANNER_DOC]
    assert len(blocks) == 2
    for doc, begin, end, render_block in blocks:
        block = figures.current_block(doc.read_text(), begin, end)
        assert block, f"docs/planner.md lost the markers {begin!r}"
        assert block == render_block(), "run: tools/run.sh python benchmarks/figures.py --write"
