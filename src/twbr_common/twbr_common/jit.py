"""The numba flags of every compiled core kernel, in one place.

The scalar cores the nodes call and the batch engine call the same kernels, so a change of flags (for
example fastmath, which would let LLVM reorder the arithmetic) changes both alike and never makes them
drift apart. Compiled functions are cached on disk: a node or a batch worker loads them instead of
compiling them again.
"""

from __future__ import annotations

import numba

kernel = numba.njit(cache=True, fastmath=False, nogil=True)
