"""The compiled kernels' cache follows the source of every package, not only the kernel's own file."""

from __future__ import annotations

import os
import subprocess
import sys
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
    import twbr_tracker

    dirs = [Path(d) for m in (twbr_common, twbr_sim, twbr_control, twbr_planner, twbr_runner, twbr_tracker)
            for d in m.__path__]
    base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    assert Path(numba.config.CACHE_DIR) == base / "twbr" / "numba" / jit.source_digest(dirs)
    from twbr_control import pid

    pid.pid_update(np.zeros(pid.N_GAINS), np.zeros(pid.N_MEMORY), 0.0, 0.0, 0.005, 0.0, False, 0)
    assert list(Path(numba.config.CACHE_DIR).rglob("pid.pid_update-*.nbi"))


KERNEL_MODULE = """
from twbr_common.jit import kernel

@kernel
def triple(x):
    return FACTOR * x
"""

PROBE = """
from twbr_cachetest.k import triple
assert triple(2.0) == 2.0 * FACTOR
signature = triple.signatures[0]
print(triple.stats.cache_hits.get(signature, 0), triple.stats.cache_misses.get(signature, 0))
"""


def _write_package(checkout: Path, factor: float) -> None:
    (checkout / "twbr_cachetest").mkdir(parents=True, exist_ok=True)
    (checkout / "twbr_cachetest" / "__init__.py").write_text("")
    (checkout / "twbr_cachetest" / "k.py").write_text(KERNEL_MODULE.replace("FACTOR", repr(factor)))


def _probe(checkout: Path, cache: Path, factor: float) -> tuple[int, int]:
    """(cache hits, cache misses) of the kernel's first call in a new process importing it from checkout."""
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "TWBR_JIT": "on",
           "PYTHONPATH": os.pathsep.join([str(checkout), os.environ.get("PYTHONPATH", "")])}
    out = subprocess.run([sys.executable, "-c", PROBE.replace("FACTOR", repr(factor))], env=env,
                         capture_output=True, text=True, check=True)
    hits, misses = out.stdout.split()
    return int(hits), int(misses)


def test_a_kernel_compiled_from_one_copy_of_a_package_loads_from_another(tmp_path):
    """What set-up relies on: it compiles the kernels from src/ (tools/bootstrap.sh, twbr_batch.warm) and
    the installed packages, elsewhere on disk, load them; an edited copy is compiled again."""
    cache, src, install = tmp_path / "cache", tmp_path / "src", tmp_path / "install"
    _write_package(src, 3.0)
    _write_package(install, 3.0)
    assert _probe(src, cache, 3.0) == (0, 1)  # compiled
    assert _probe(install, cache, 3.0) == (1, 0)  # loaded: compiled from the other copy
    assert (cache / "twbr_cachetest").is_dir()  # filed by package, not by the path it came from
    _write_package(install, 4.0)
    assert _probe(install, cache, 4.0) == (0, 1)  # never served the old kernel
