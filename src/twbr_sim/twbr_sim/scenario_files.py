"""Where scenario files are found: a path as given, or a name in the installed config/scenarios."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

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
    if value and path.is_dir():
        inside = sorted(p.name for p in path.glob("*.y*ml"))
        hint = f" (its scenario files: {', '.join(inside[:8])}{', ...' if len(inside) > 8 else ''})" if inside else ""
        raise ConfigError(f"invalid parameter 'scenario' = {value!r}: is a directory, not a scenario file{hint}")
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



SENSOR_PRESETS = ("ideal", "realistic")


def sensor_preset(name: str) -> dict[str, Any]:
    """The simulator's sensor parameters of a preset: none for ideal, config/sensors_realistic.yaml's for
    realistic (the file a user passes to sim_node, so studies and the graph use the same figures)."""
    from twbr_common.param_files import node_parameters

    if name not in SENSOR_PRESETS:
        raise ConfigError(f"unknown sensors {name!r}: one of {', '.join(SENSOR_PRESETS)}")
    if name == "ideal":
        return {}
    for d in config_dirs():
        path = d / f"sensors_{name}.yaml"
        if path.is_file():
            return node_parameters(path, "sim_node")
    raise ConfigError(f"sensors_{name}.yaml is in none of {', '.join(map(str, config_dirs()))}")
