"""Where the parameter files are: one answer for every node, script and test."""

from __future__ import annotations

import contextlib
import os
from pathlib import Path


def installed_config_dir() -> Path | None:
    """share/twbr_config/config of the sourced workspace, or None where twbr_config is not installed or no
    workspace is sourced (ament_index raises OSError without AMENT_PREFIX_PATH)."""
    try:
        from ament_index_python.packages import PackageNotFoundError, get_package_share_directory
    except ImportError:
        return None
    with contextlib.suppress(PackageNotFoundError, OSError):
        return Path(get_package_share_directory("twbr_config")) / "config"
    return None


def config_dir() -> Path:
    """$TWBR_CONFIG_DIR (a checkout's config/), else the installed share/twbr_config/config."""
    if os.environ.get("TWBR_CONFIG_DIR"):
        return Path(os.environ["TWBR_CONFIG_DIR"])
    installed = installed_config_dir()
    if installed is None:
        raise FileNotFoundError("twbr_config is not installed and TWBR_CONFIG_DIR is not set")
    return installed


def config_dirs() -> list[Path]:
    """Every place parameter files and scenarios are looked for, in order: $TWBR_CONFIG_DIR, then installed."""
    dirs = [Path(os.environ["TWBR_CONFIG_DIR"])] if os.environ.get("TWBR_CONFIG_DIR") else []
    installed = installed_config_dir()
    return dirs + ([installed] if installed is not None else [])
