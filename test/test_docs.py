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


def test_every_declared_parameter_is_documented():
    # A spec added to a node but left out of parameter_docs.SECTIONS would pass the test above.
    from twbr_runner.parameter_docs import SECTIONS

    documented = {s.name for _, specs, _ in SECTIONS for s in specs}
    text = (ROOT / "docs" / "parameters.md").read_text()
    for name in ("pitch.kp", "rho_o", "physics_rate", "wheel_radius", "future_tolerance", "cpu_affinity", "profile"):
        assert name in documented and f"| `{name}` |" in text


def test_readme_is_a_front_door():
    assert len((ROOT / "README.md").read_bytes()) <= 12 * 1024


def test_relative_links_lead_to_files():
    link = re.compile(r"\]\(([^)#\s]+)(?:#[^)]*)?\)")
    for doc in DOCS:
        for target in link.findall(doc.read_text()):
            if "://" in target:
                continue
            assert (doc.parent / target).exists(), f"{doc.relative_to(ROOT)} links to missing {target}"
