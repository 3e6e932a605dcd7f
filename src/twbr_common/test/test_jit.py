"""The compiled kernels' cache follows the source of every package, not only the kernel's own file."""

from __future__ import annotations

import os
from pathlib import Path

import numba
import numpy as np

from twbr_common import jit


def test_the_digest_changes_with_any_file_of_any_package(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir(), b.mkdir()
    (a / "cascade.py").write_text("K = 1\n")
    (b / "batch.py").write_text("import a\n")
    before = jit.source_digest([a, b])
    assert jit.source_digest([a, b]) == before
    (a / "cascade.py").write_text("K = 2\n")  # a callee edited; the caller's file is unchanged
    assert jit.source_digest([a, b]) != before
    (a / "cascade.py").write_text("K = 1\n")
    assert jit.source_digest([a, b]) == before
    (b / "notes.txt").write_text("not source")
    assert jit.source_digest([a, b]) == before


def test_kernels_are_cached_under_the_digest_of_the_installed_packages():
    if os.environ.get("NUMBA_CACHE_DIR"):
        assert os.environ["NUMBA_CACHE_DIR"] == numba.config.CACHE_DIR
        return
    # ~/.cache/twbr/numba/<digest of the .py files of every package whose kernels inline each other>: found
    # here from the imported modules themselves, not from jit's own list of directories
    import twbr_common
    import twbr_control
    import twbr_planner
    import twbr_runner
    import twbr_sim

    dirs = [Path(d) for m in (twbr_common, twbr_sim, twbr_control, twbr_planner, twbr_runner) for d in m.__path__]
    base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    assert Path(numba.config.CACHE_DIR) == base / "twbr" / "numba" / jit.source_digest(dirs)
    from twbr_control import pid

    pid.pid_update(np.zeros(pid.N_GAINS), np.zeros(pid.N_MEMORY), 0.0, 0.0, 0.005, 0.0, False, 0)
    assert list(Path(numba.config.CACHE_DIR).rglob("pid.pid_update-*.nbi"))
