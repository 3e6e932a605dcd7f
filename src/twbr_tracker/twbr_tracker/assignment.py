"""The optimal one-to-one assignment of tracks to detections (the Hungarian method), compiled.

Kuhn (1955) and Munkres (1957), in the shortest-augmenting-path form with row and column potentials that
runs in O(n^2 m) for n <= m (the form e-maxx and Jonker & Volgenant give): each row in turn is added to the
matching along the cheapest augmenting path, the potentials keeping every reduced cost >= 0. It gives what
`scipy.optimize.linear_sum_assignment` gives (test_assignment compares them), inside a compiled kernel the
batch engine can call. A pair costing more than `gate` is never matched: a track with no detection within
its gate is left unmatched rather than paired with a far one.
"""

from __future__ import annotations

import math

import numpy as np

from twbr_common.jit import kernel


@kernel
def _assign_rows(cost, row_of_column):
    """Rows of `cost` (n <= m columns) to distinct columns at the least total cost: row_of_column[j] is
    the row given column j, or -1."""
    n, m = cost.shape
    u = np.zeros(n + 1)  # row potentials (1-based; 0 is the virtual start)
    v = np.zeros(m + 1)  # column potentials
    p = np.zeros(m + 1, dtype=np.int64)  # p[j]: the row matched to column j (0: none)
    way = np.zeros(m + 1, dtype=np.int64)
    min_reduced = np.empty(m + 1)
    used = np.empty(m + 1, dtype=np.bool_)
    for i in range(1, n + 1):
        p[0] = i
        j0 = 0
        min_reduced[:] = math.inf
        used[:] = False
        while True:  # grow the tree of alternating paths until it reaches a free column
            used[j0] = True
            i0 = p[j0]
            delta = math.inf
            j1 = 0
            for j in range(1, m + 1):
                if not used[j]:
                    reduced = cost[i0 - 1, j - 1] - u[i0] - v[j]
                    if reduced < min_reduced[j]:
                        min_reduced[j] = reduced
                        way[j] = j0
                    if min_reduced[j] < delta:
                        delta = min_reduced[j]
                        j1 = j
            for j in range(m + 1):
                if used[j]:
                    u[p[j]] += delta
                    v[j] -= delta
                else:
                    min_reduced[j] -= delta
            j0 = j1
            if p[j0] == 0:
                break
        while True:  # flip the path: every column on it takes the row before it
            j1 = way[j0]
            p[j0] = p[j1]
            j0 = j1
            if j0 == 0:
                break
    for j in range(1, m + 1):
        row_of_column[j - 1] = p[j] - 1


@kernel
def assign(cost, gate, match):
    """match[i]: the column assigned to row i at the least total cost over the pairs within `gate`, or -1.
    `cost` is (rows, columns), either way round; pairs above the gate cost a constant that no within-gate
    pairing can beat, and are then dropped."""
    n, m = cost.shape
    match[:] = -1
    if n == 0 or m == 0:
        return
    big = 1.0 + (n + m) * max(gate, 1.0) * 4.0  # above any sum of within-gate costs
    if n <= m:
        bounded = np.empty((n, m))
        for i in range(n):
            for j in range(m):
                bounded[i, j] = cost[i, j] if cost[i, j] <= gate else big
        row_of_column = np.empty(m, dtype=np.int64)
        _assign_rows(bounded, row_of_column)
        for j in range(m):
            i = row_of_column[j]
            if i >= 0 and cost[i, j] <= gate:
                match[i] = j
    else:
        bounded = np.empty((m, n))
        for i in range(n):
            for j in range(m):
                bounded[j, i] = cost[i, j] if cost[i, j] <= gate else big
        column_of_row = np.empty(n, dtype=np.int64)
        _assign_rows(bounded, column_of_row)  # columns of cost as rows
        for i in range(n):
            j = column_of_row[i]
            if j >= 0 and cost[i, j] <= gate:
                match[i] = j
