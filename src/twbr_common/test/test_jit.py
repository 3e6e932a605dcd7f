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
    assert Path(numba.config.CACHE_DIR) == jit.cache_dir()
    assert Path(numba.config.CACHE_DIR).parent.name == "numba"
    from twbr_control import pid

    pid.pid_update(np.zeros(pid.N_GAINS), np.zeros(pid.N_MEMORY), 0.0, 0.0, 0.005, 0.0, False, 0)
    assert list(Path(numba.config.CACHE_DIR).rglob("pid.pid_update-*.nbi"))
