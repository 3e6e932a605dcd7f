"""Seeded random numbers inside the compiled kernels: splitmix64 and Box-Muller.

The simulated sensors draw their noise in the kernels that the simulator node and the batch engine share,
so a robot's noise must come from a generator that lives in that robot's own memory (a one-element uint64
array), not from numba's per-thread state: robot i of a parallel batch then draws exactly what the
simulator node with the same seed draws, whichever thread runs it.
"""

from __future__ import annotations

import math
import warnings

import numpy as np

from twbr_common.jit import kernel

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)
_S30 = np.uint64(30)
_S27 = np.uint64(27)
_S31 = np.uint64(31)
_S11 = np.uint64(11)
_INV_2_53 = 1.0 / 9007199254740992.0
# Interpreted (TWBR_JIT=off), numpy warns where uint64 products wrap; splitmix64 means them to wrap.
warnings.filterwarnings("ignore", "overflow encountered in scalar multiply", RuntimeWarning, __name__)


def new_generator(seed: int, stream: int) -> np.ndarray:
    """A generator for `seed` and a stream number (one per sensor, so adding one leaves the others' draws)."""
    g = np.zeros(1, dtype=np.uint64)
    g[0] = np.uint64((int(seed) * 0x100000001B3 + int(stream) * 0x9E3779B1) % 2**64)
    uniform(g)  # one step away from the raw seed: nearby seeds start far apart
    return g


@kernel
def uniform(g):
    """A float in [0, 1) with 53 random bits; advances the generator."""
    g[0] += _GOLDEN
    z = g[0]
    z = (z ^ (z >> _S30)) * _MIX1
    z = (z ^ (z >> _S27)) * _MIX2
    z = z ^ (z >> _S31)
    return (z >> _S11) * _INV_2_53


@kernel
def normal(g):
    """A standard normal draw (Box-Muller, one of the pair)."""
    u1 = 1.0 - uniform(g)  # (0, 1]: log is finite
    u2 = uniform(g)
    return math.sqrt(-2.0 * math.log(u1)) * math.cos(2.0 * math.pi * u2)
