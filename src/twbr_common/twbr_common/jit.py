"""The numba flags of every compiled core kernel, in one place.

The scalar cores the nodes call and the batch engine call the same kernels, so a change of flags (for
example fastmath, which would let LLVM reorder the arithmetic) changes both alike and never makes them
drift apart. Compiled functions are cached on disk: a node or a batch worker loads them instead of
compiling them again.

None of fastmath's liberties is taken, not even `contract` (a*b + c as one fused multiply-add): the
compiler fuses differently in a loop's vectorised body and in its scalar remainder, so a robot's run would
depend in the last bit on its place in a lane group (the batch's robots would differ from the same robot
run alone by 1e-11 after a minute). IEEE arithmetic rounds every operation the same wherever it runs:
vectorised, scalar, or interpreted (TWBR_JIT=off); the price is ~9 % of the batch's speed. Nothing
assumes away NaN or inf, so the guards' and the fall checks' comparisons keep their meaning.

numba invalidates a cached kernel when its own file changes, not when a kernel it calls (and inlined)
changes in another file: the batch engine would keep running yesterday's controller. So the cache lives
in a directory named by a digest of every twbr package's source, under ~/.cache/twbr/numba (or
$XDG_CACHE_HOME/twbr/numba); NUMBA_CACHE_DIR, when set, wins. Inside it a kernel is filed by its package
and module, not by the path it was imported from (`PackageCacheLocator`): the kernels compiled at set-up
from src/ (twbr_batch.warm) are the ones the installed packages load, and a `make clean` or a
second checkout of the same sources finds them too.

TWBR_JIT=off runs the same kernels as plain Python and never imports numba (whose LLVM is ~60 MiB and
~0.3 s of every process that loads it). The deployable nodes default to it (`twbr_common.deploy`):
the controller's step takes ~30 µs interpreted against ~9 µs compiled, well inside its 5 ms period.
"""

from __future__ import annotations

import contextlib
import hashlib
import importlib.util
import os
import time
from collections.abc import Callable, Iterable
from pathlib import Path

from twbr_common.deploy import JIT_ENV as ENV
from twbr_common.params import env_choice

CHOICES = ("on", "off")


def jit_mode() -> str:
    return env_choice(ENV, CHOICES, "on")


PACKAGES = ("twbr_common", "twbr_sim", "twbr_control", "twbr_planner", "twbr_runner", "twbr_tracker")


def source_digest(package_dirs: Iterable[Path]) -> str:
    """A digest of the Python files directly in each directory (names and contents)."""
    h = hashlib.sha256()
    for directory in package_dirs:
        for path in sorted(Path(directory).glob("*.py")):
            h.update(path.name.encode() + b"\0" + path.read_bytes() + b"\0")
    return h.hexdigest()[:16]


def _package_dirs() -> list[Path]:
    dirs = []
    for name in PACKAGES:
        spec = importlib.util.find_spec(name)
        if spec is not None and spec.submodule_search_locations:
            dirs += [Path(d) for d in spec.submodule_search_locations]
    return dirs


def cache_dir() -> Path:
    base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return base / "twbr" / "numba" / source_digest(_package_dirs())


def loading_kernels(log: Callable[[str], None], what: str, first_run_s: float) -> Callable[[], None]:
    """Say before loading `what`'s kernels that a first run after a change of the sources compiles them
    (~first_run_s), and return the call that says, after, how long it took when it compiled."""
    if not COMPILED:
        return lambda: None
    log(f"loading {what}'s compiled kernels (the first run after a change of the sources compiles them:"
        f" ~{first_run_s:.0f} s on 2 cores; cached in {numba.config.CACHE_DIR})")
    started = time.monotonic()

    def done() -> None:
        took = time.monotonic() - started
        if took > 3.0:
            log(f"compiled {what}'s kernels in {took:.1f} s (the next start loads them in ~1 s)")

    return done


FASTMATH: set[str] = set()
COMPILED = jit_mode() == "on"

if COMPILED:
    import numba
    from numba.core.caching import UserProvidedCacheLocator

    class PackageCacheLocator(UserProvidedCacheLocator):
        """Files a twbr kernel under <cache dir>/<package>, whichever copy of the package it came from;
        numba's own locator files it under a digest of the source file's absolute path. The entry is
        still checked against a hash of the source file's content (numba's source stamp)."""

        def __init__(self, py_func, py_file):
            super().__init__(py_func, py_file)
            self._cache_path = os.path.join(numba.config.CACHE_DIR, py_func.__module__.split(".")[0])

        @classmethod
        def from_function(cls, py_func, py_file):
            if not py_func.__module__.startswith("twbr_"):
                return None
            return super().from_function(py_func, py_file)

    if not os.environ.get("NUMBA_CACHE_DIR"):
        numba.config.CACHE_DIR = str(cache_dir())
    if not numba.config.CACHE_LOCATOR_CLASSES:
        numba.config.CACHE_LOCATOR_CLASSES = (f"{__name__}.PackageCacheLocator,UserProvidedCacheLocator,"
                                              "InTreeCacheLocator,UserWideCacheLocator")
    kernel = numba.njit(cache=True, fastmath=FASTMATH, nogil=True)
    # The equations of one lane, for loops over the robots of a lane group. Inlined into the caller's IR: a
    # call between compiled functions passes arrays with reference counting, which keeps the loop from being
    # vectorised. A division is not checked for zero (numpy's rule: inf or nan), since the check's exception
    # would be an exit from the loop, with the same effect. Only equations whose denominators cannot vanish
    # (a mass matrix, an inertia) are compiled with it. The loop vectorises where its arrays are allocated
    # with a constant shape in a parallel kernel's body (dynamics.step_batch, batch._run_robots).
    lane_kernel = numba.njit(cache=True, fastmath=FASTMATH, nogil=True, error_model="numpy", inline="always")
    # A small helper of a kernel, inlined into its callers' IR: a call between compiled functions passes its
    # arrays with reference counting, which costs more than the helper's arithmetic.
    inline_kernel = numba.njit(cache=True, fastmath=FASTMATH, nogil=True, inline="always")
    parallel_kernel = numba.njit(cache=True, fastmath=FASTMATH, nogil=True, parallel=True)
    prange = numba.prange
    parallel_chunksize = numba.parallel_chunksize
    get_num_threads = numba.get_num_threads
else:
    def kernel(function):  # the same source, run by the interpreter
        return function

    parallel_kernel = kernel
    lane_kernel = kernel
    inline_kernel = kernel
    prange = range

    def parallel_chunksize(_size: int) -> contextlib.AbstractContextManager:
        return contextlib.nullcontext()

    def get_num_threads() -> int:
        return 1
