"""The make targets' arguments, checked before anything is set up or built (the standard library only, so
it runs before .venv exists): a mistyped scenario or a bad count is refused in well under a second instead
of after a colcon build. The programs check everything again, with the full rules (choices, ranges).

    python3 tools/check_args.py --scenario dynamic_obstacles --runs 1000 --perturb 0.2 --perception lidar
    python3 tools/check_args.py --scenarios suite/gap_1m,my_lab.yaml --runs 100
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

SCENARIOS = Path(__file__).resolve().parents[1] / "config" / "scenarios"


def scenario_known(name: str) -> bool:
    """A scenario file, or a name under config/scenarios (suite/<name>, or a suite layout's bare name)."""
    if Path(name).is_file():
        return True
    return any((SCENARIOS / f"{candidate}.yaml").is_file() for candidate in (name, f"suite/{name}"))


def problems(args: argparse.Namespace) -> list[str]:
    found = []
    names = ([args.scenario] if args.scenario is not None else []) + \
        ([n for n in args.scenarios.split(",") if n] if args.scenarios else [])
    for name in names:
        if not scenario_known(name):
            found.append(f"scenario {name!r}: neither a file nor a name under {SCENARIOS} (or its suite/)")
    if args.runs is not None and not (args.runs.isdigit() and int(args.runs) > 0):
        found.append(f"N={args.runs!r}: the number of runs must be a positive integer")
    if args.perturb is not None:
        try:
            ok = 0.0 <= float(args.perturb) < 1.0
        except ValueError:
            ok = False
        if not ok:
            found.append(f"PERTURB={args.perturb!r}: a fraction in [0, 1) (0.2 perturbs by up to ±20 %)")
    if args.perception is not None and args.perception not in ("", "lidar", "truth"):
        found.append(f"PERCEPTION={args.perception!r}: lidar (tracker_node on the scan) or truth (the world's obstacles)")
    return found


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario")
    ap.add_argument("--scenarios", help="comma-separated")
    ap.add_argument("--runs")
    ap.add_argument("--perturb")
    ap.add_argument("--perception")
    found = problems(ap.parse_args(argv))
    for line in found:
        print(f"make: {line}", file=sys.stderr)
    return 2 if found else 0


if __name__ == "__main__":
    sys.exit(main())
