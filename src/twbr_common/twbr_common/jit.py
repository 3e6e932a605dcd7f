"""The numba flags of every compiled core kernel, in one place.

The scalar cores the nodes call and the batch engine call the same kernels, so a change of flags (for
example fastmath, which would let LLVM reorder the arithmetic) changes both alike and never makes them
drift apart. Compiled functions are cached on disk: a node or a batch worker loads them instead of
compiling them again.

Of fastmath's liberties only `contract` is taken: a*b + c may become one fused multiply-add, which is
faster and rounds once instead of twice. Nothing assumes away NaN or inf, so the guards' and the fall
checks' comparisons keep their meaning. A machine without FMA rounds differently in the last bit, so
runs are bit-identical on one machine, not across machines.
"""

from __future__ import annotations

import numba

FASTMATH = {"contract"}
kernel = numba.njit(cache=True, fastmath=FASTMATH, nogil=True)
parallel_kernel = numba.njit(cache=True, fastmath=FASTMATH, nogil=True, parallel=True)
