"""The wall memory (wall_memory.py): a wall out of view is kept for walls.memory seconds, replaced where the
scan shows it again, cleared where a beam now passes through, and the least recently seen make room."""

from __future__ import annotations

import math

import numpy as np

from twbr_common.params import defaults
from twbr_tracker.detection import DC_RADIUS, DC_WALL, DC_X, DC_Y, N_DISC
from twbr_tracker.wall_memory import WALL_MEMORY_SPECS, WL_SEEN, WL_X, remember_walls, settings_vector

BEAMS = 360
INCREMENT = math.radians(1.0)


def chain(xs: list[float], y: float) -> np.ndarray:
    discs = np.zeros((len(xs), N_DISC))
    discs[:, DC_X], discs[:, DC_Y], discs[:, DC_RADIUS], discs[:, DC_WALL] = xs, y, 0.3, 1.0
    return discs


def ranges_with(bearing_hits: dict[float, float]) -> np.ndarray:
    """A scan from the origin, heading 0, with no return but at these bearings [rad]: range [m]."""
    ranges = np.full(BEAMS, math.inf)
    for bearing, r in bearing_hits.items():
        ranges[round((bearing + math.pi) / INCREMENT) % BEAMS] = r
    return ranges


def step(s, walls, n, t, discs, ranges):
    return remember_walls(s, walls, n, t, discs, len(discs), ranges, -math.pi, INCREMENT, 0.0, 0.0, 0.0)


def test_a_wall_out_of_view_is_kept_for_its_memory_then_forgotten():
    s = settings_vector(defaults(WALL_MEMORY_SPECS))  # 20 s
    walls = np.zeros((256, 4))
    wall = chain([-0.8, -0.4, 0.0, 0.4, 0.8], 3.0)
    n = step(s, walls, 0, 0.0, wall, ranges_with({math.pi / 2: 2.7}))
    assert n == 5
    # out of view now (a scan that shows nothing of it, and no beam through it: short returns before it)
    hidden = ranges_with({math.atan2(3.0, x): 1.0 for x in (-0.8, -0.4, 0.0, 0.4, 0.8)})
    n = step(s, walls, n, 10.0, chain([], 0.0), hidden)
    assert n == 5 and sorted(np.round(walls[:n, WL_X], 1)) == [-0.8, -0.4, 0.0, 0.4, 0.8]
    n = step(s, walls, n, 20.5, chain([], 0.0), hidden)  # 20.5 s after it was last seen
    assert n == 0


def test_a_scan_showing_the_wall_again_replaces_it_and_a_beam_through_it_clears_it():
    s = settings_vector(defaults(WALL_MEMORY_SPECS))
    walls = np.zeros((256, 4))
    n = step(s, walls, 0, 0.0, chain([-0.4, 0.0, 0.4], 3.0), ranges_with({}))
    n = step(s, walls, n, 1.0, chain([-0.35, 0.05, 0.45], 3.0), ranges_with({}))  # the same wall, stretches moved
    assert n == 3 and np.all(walls[:n, WL_SEEN] == 1.0)
    # a beam towards the middle disc returns 6 m away: the place is free now (a person who stood, a door)
    free = ranges_with({math.atan2(3.0, 0.05): 6.0, math.atan2(3.0, -0.35): 2.0, math.atan2(3.0, 0.45): 2.0})
    n = step(s, walls, n, 2.0, chain([], 0.0), free)
    assert n == 2 and 0.05 not in np.round(walls[:n, WL_X], 2)


def test_a_full_memory_forgets_the_least_recently_seen():
    s = settings_vector({**defaults(WALL_MEMORY_SPECS), "walls.max_discs": 4})
    walls = np.zeros((4, 4))
    hidden = ranges_with({b: 0.5 for b in np.linspace(0.1, 3.0, 60)})  # short returns ahead of everything
    n = step(s, walls, 0, 0.0, chain([-3.0, -2.0], 3.0), hidden)
    n = step(s, walls, n, 1.0, chain([2.0, 3.0, 4.0], 3.0), hidden)
    assert n == 4 and sorted(walls[:n, WL_SEEN]) == [0.0, 1.0, 1.0, 1.0]


def test_no_memory_is_the_scan_s_own_walls():
    s = settings_vector({**defaults(WALL_MEMORY_SPECS), "walls.memory": 0.0})
    walls = np.zeros((256, 4))
    n = step(s, walls, 0, 0.0, chain([0.0, 0.4], 3.0), ranges_with({}))
    n = step(s, walls, n, 0.1, chain([5.0], -3.0), ranges_with({}))
    assert n == 1 and walls[0, WL_X] == 5.0
