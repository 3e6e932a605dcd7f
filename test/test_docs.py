"""The docs say what the code does: generated tables equal the specs, links lead somewhere."""

from __future__ import annotations

import re
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
