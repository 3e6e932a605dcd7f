"""Where the parameter files are: one answer for every node, script and test."""

from __future__ import annotations

import os
from pathlib import Path


def config_dir() -> Path:
    """$TWBR_CONFIG_DIR (a checkout's config/), else the installed share/twbr_sim/config."""
    if os.environ.get("TWBR_CONFIG_DIR"):
        return Path(os.environ["TWBR_CONFIG_DIR"])
    from ament_index_python.packages import get_package_share_directory

    return Path(get_package_share_directory("twbr_sim")) / "config"
