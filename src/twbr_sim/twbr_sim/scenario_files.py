"""Where scenario files are found: a path as given, or a name in the installed config/scenarios."""

from __future__ import annotations

import os
from pathlib import Path

from twbr_common.params import ConfigError
from twbr_common.paths import config_dirs


def scenario_dirs() -> list[Path]:
    """$TWBR_CONFIG_DIR/scenarios first (a checkout's config/), then the installed share directory."""
    return [d / "scenarios" for d in config_dirs()]


def scenario_names() -> list[str]:
    """Names of the scenarios find_scenario knows, sorted (the suite's are `suite/<name>`)."""
    return sorted({p.stem for d in scenario_dirs() if d.is_dir() for p in d.glob("*.yaml")})


def suite_names() -> list[str]:
    """Names of the hard suite's scenarios (config/scenarios/suite), sorted, without the `suite/`."""
    return sorted({p.stem for d in scenario_dirs() if (d / "suite").is_dir() for p in (d / "suite").glob("*.yaml")})


def find_scenario(value: str) -> Path:
    """A scenario file by path, or by name in the installed scenarios (`static`, `suite/gap_1m`)."""
    path = Path(value)
    if path.suffix in (".yaml", ".yml") or (os.sep in value and path.is_file()):
        if path.is_file():
            return path
        raise ConfigError(f"invalid parameter 'scenario' = {value!r}: no such file")
    if os.sep in value and (value.startswith(os.sep) or ".." in Path(value).parts):
        raise ConfigError(f"invalid parameter 'scenario' = {value!r}: no such file")
    for d in scenario_dirs():
        candidate = d / f"{value}.yaml"
        if candidate.is_file():
            return candidate
    choices = ", ".join(scenario_names() + [f"suite/{n}" for n in suite_names()]) or "(none installed)"
    raise ConfigError(f"invalid parameter 'scenario' = {value!r}: must be a scenario file or one of {choices}")

