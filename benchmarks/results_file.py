"""One way every benchmark and study writes its figures: JSON under benchmarks/results with the date and
the commit they were measured at, so README.md and docs/ cite (and test_docs checks) a dated source."""

from __future__ import annotations

import datetime
import json
import subprocess
from pathlib import Path
from typing import Any

RESULTS = Path(__file__).resolve().parent / "results"


def commit() -> str:
    """The checkout's commit, with '+' when its tracked files differ from it."""
    root = Path(__file__).resolve().parents[1]
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=root, capture_output=True, text=True,
                              check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=root,
                               capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return head + ("+" if dirty else "")


def write_results(path: Path | str, figures: dict[str, Any]) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    stamped = {"date": datetime.date.today().isoformat(), "commit": commit(), **figures}
    path.write_text(json.dumps(stamped, indent=1) + "\n")
    return path
