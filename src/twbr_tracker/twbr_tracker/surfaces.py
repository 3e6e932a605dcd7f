"""The surfaces an earlier scan saw: what tells the end of a wall that seems to move from a person who does.

A disc fitted to the part of a wall that a scan shows (its end, an inside corner, a face seen past another
wall) slides as the robot drives and sees more or less of it, and its filter reads the slide as walking:
the planner then yields to a wall (trap_large on the LiDAR: the robot waits at the trap's mouth for
"people" that are its corners). What a person shows a second later lies where the scanner then saw through
(free space) or saw something else; what a wall shows lies on the surface it saw. So the tracker keeps a
scan between `surfaces.age` and twice that old, its points binned by their bearing from where it was taken
(in odom), and a disc whose points lie on that scan's surface (within `surfaces.tolerance` of a point or
of the line between two neighbouring points), at least `surfaces.still_fraction` of those the earlier scan
could judge, is still: its track is published without velocity whatever its filter reads. A point the
earlier scan saw through (its return there was farther), or saw a little short of (within
`surfaces.receded`: what stood there has moved away, as a person walking off does), is a vote against; a
point it could not see (something well in front of it) says nothing. A disc larger than `surfaces.max_radius` is never still
by this test (a compact piece of wall is at most detection.max_disc_extent long): a body 3 m across
drifting sideways lies mostly on its own earlier surface, and is no wall. A person standing still, or a
post, is still by it too (as the speed threshold would have them), and moves again as soon as its points
leave what the earlier scan saw. This is the free-space test of scan differencing in SLAM
with the detection and tracking of moving objects (Wang, Thorpe, Thrun, Hebert & Durrant-Whyte 2007,
IJRR 26(9)): a point where an earlier scan saw through is on something that moved. Figures:
benchmarks/HISTORY.md, issue 36, tenth session.
"""

from __future__ import annotations

import math

import numpy as np

from twbr_common.jit import kernel
from twbr_common.layout import Layout
from twbr_common.params import ParamSpec
from twbr_tracker.detection import DC_HI, DC_LO, DC_RADIUS, DC_STILL, DC_WALL

SURFACE_SPECS: tuple[ParamSpec, ...] = (
    ParamSpec("surfaces.age", 0.5, "the earlier scan a disc is compared with is between this and twice this old"
              " (0: off, every track's motion is its filter's)", "s", 0.0, 10.0),
    ParamSpec("surfaces.tolerance", 0.05, "a point this close to the earlier scan's surface lies on it (about five"
              " range noise std)", "m", 0.0, 1.0, low_open=True),
    ParamSpec("surfaces.link", 0.5, "two neighbouring points of the earlier scan farther apart than this are not"
              " one surface", "m", 0.0, 5.0),
    ParamSpec("surfaces.receded", 0.2, "a point up to this much beyond the earlier scan's return on its bearing"
              " (beyond the tolerance) is on something that moved away, a vote against; farther, it was hidden"
              " then", "m", 0.0, 5.0),
    ParamSpec("surfaces.max_radius", 1.0, "a disc larger than this is a large body (a car, the paper's 1.5-2 m"
              " obstacles), never still by this test: drifting sideways, it lies mostly on its own earlier"
              " surface", "m", 0.0, 50.0),
    ParamSpec("surfaces.still_fraction", 0.8, "a disc is still when at least this fraction of its points the"
              " earlier scan could judge lie on its surface", "", 0.0, 1.0, low_open=True),
)

SETTINGS_LAYOUT = Layout(("age", "tolerance", "link", "receded", "max_radius", "still_fraction"))
SU_AGE = SETTINGS_LAYOUT["age"]
SU_TOLERANCE = SETTINGS_LAYOUT["tolerance"]
SU_LINK = SETTINGS_LAYOUT["link"]
SU_RECEDED = SETTINGS_LAYOUT["receded"]
SU_MAX_RADIUS = SETTINGS_LAYOUT["max_radius"]
SU_STILL_FRACTION = SETTINGS_LAYOUT["still_fraction"]
N_SETTINGS = len(SETTINGS_LAYOUT)

# Two scans are kept (OLDER, NEWER: the newer replaces the older once it is `age` old, so the older is
# always between age and twice age old). A scan is REF_BINS + 1 rows of (x, y, range): row 0 when and
# where it was taken ([s], odom [m]), then one row per bearing bin from there of the nearest point seen
# in it [m] (range +inf: the beams there returned nothing within range; nan: nothing known).
OLDER = 0
NEWER = 1
REF_BINS = 360
SEARCH = 2  # bins either side of a point's own where the earlier scan's neighbouring points are looked for
REF_T = 0
REF_X = 1
REF_Y = 2
REF_RANGE = 2


def settings_vector(cfg: dict) -> np.ndarray:
    return SETTINGS_LAYOUT.pack({name: cfg[f"surfaces.{name}"] for name in SETTINGS_LAYOUT.names})


def new_surfaces() -> np.ndarray:
    """No earlier scan yet."""
    return np.full((2, REF_BINS + 1, 3), math.nan)


@kernel
def _bin(ox, oy, px, py):
    """The bearing bin of (px, py) seen from (ox, oy), in 0..REF_BINS-1."""
    bearing = math.atan2(py - oy, px - ox) % (2.0 * math.pi)
    return int(bearing * REF_BINS / (2.0 * math.pi)) % REF_BINS


@kernel
def remember_scan(u, surfaces, t, points, ranges, angle_min, angle_increment, time_increment, yaw, yaw_rate, sx,
                  sy):
    """This scan, begun at the heading yaw [rad] turning at yaw_rate [rad/s] from the scanner at (sx, sy) [m]
    (its points in odom, nan rows unused; the no-returns of `ranges`, REP 117's +inf, along their beams'
    headings) as the newer one when the newer one is `age` old; the newer becomes the older."""
    if u[SU_AGE] <= 0.0 or t - surfaces[NEWER, 0, REF_T] < u[SU_AGE]:  # nan (none yet): not less
        return
    surfaces[OLDER, :, :] = surfaces[NEWER, :, :]
    ref = surfaces[NEWER]
    ref[1:, :] = math.nan
    ref[0, REF_T] = t
    ref[0, REF_X] = sx
    ref[0, REF_Y] = sy
    for i in range(ranges.shape[0]):
        if ranges[i] == math.inf:  # its heading as scanner_at turns it (its position does not matter here)
            bearing = (yaw + yaw_rate * i * time_increment + angle_min + i * angle_increment) % (2.0 * math.pi)
            row = 1 + int(bearing * REF_BINS / (2.0 * math.pi)) % REF_BINS
            if math.isnan(ref[row, REF_RANGE]):
                ref[row, REF_RANGE] = math.inf
    for k in range(points.shape[0]):
        px = points[k, 0]
        if math.isnan(px):
            continue
        py = points[k, 1]
        row = 1 + _bin(sx, sy, px, py)
        r = math.hypot(px - sx, py - sy)
        if not r >= ref[row, REF_RANGE]:  # nearer, or the first (nan, +inf)
            ref[row, 0] = px
            ref[row, 1] = py
            ref[row, REF_RANGE] = r


@kernel
def _segment_distance2(px, py, ax, ay, bx, by):
    """The squared distance [m²] from (px, py) to the segment from (ax, ay) to (bx, by)."""
    ex = bx - ax
    ey = by - ay
    length2 = ex * ex + ey * ey
    f = 0.0 if length2 <= 0.0 else min(1.0, max(0.0, ((px - ax) * ex + (py - ay) * ey) / length2))
    dx = px - ax - f * ex
    dy = py - ay - f * ey
    return dx * dx + dy * dy


@kernel
def point_state(u, ref, px, py):
    """What the earlier scan `ref` says of the point (px, py): 1 on its surface, -1 where it saw through or
    a little short of it (`receded`: what it saw there has moved away), 0 nothing (it saw something well
    in front, or nothing is known)."""
    ox = ref[0, REF_X]
    oy = ref[0, REF_Y]
    k = _bin(ox, oy, px, py)
    tolerance = u[SU_TOLERANCE]
    tolerance2 = tolerance * tolerance  # squared distances throughout: this runs for every point of a disc
    link2 = u[SU_LINK] * u[SU_LINK]
    last = -1  # the previous bin with a point, in bearing order
    for q in range(k - SEARCH, k + SEARCH + 1):
        row = 1 + q % REF_BINS
        if not math.isfinite(ref[row, REF_RANGE]):
            continue
        dx = px - ref[row, 0]
        dy = py - ref[row, 1]
        if dx * dx + dy * dy <= tolerance2:
            return 1
        if last >= 0:
            lx = ref[row, 0] - ref[last, 0]
            ly = ref[row, 1] - ref[last, 1]
            if (lx * lx + ly * ly <= link2
                    and _segment_distance2(px, py, ref[last, 0], ref[last, 1], ref[row, 0], ref[row, 1]) <= tolerance2):
                return 1
        last = row
    d = math.sqrt((px - ox) ** 2 + (py - oy) ** 2)
    for step in range(SEARCH + 1):  # the nearest bin that knows something, this side first
        for q in (k - step, k + step):
            r = ref[1 + q % REF_BINS, REF_RANGE]
            if not math.isnan(r):
                return -1 if r > d + tolerance or r > d - tolerance - u[SU_RECEDED] else 0
    return 0


@kernel
def mark_still(u, surfaces, points, discs, m):
    """DC_STILL of the compact discs[:m]: 1 where their points (points[DC_LO:DC_HI]) lie on the older
    scan's surface (the module's rule) and they are no larger than a wall's piece, else 0."""
    ref = surfaces[OLDER]
    ready = u[SU_AGE] > 0.0 and not math.isnan(ref[0, REF_T])
    for i in range(m):
        discs[i, DC_STILL] = 0.0
        if not ready or discs[i, DC_WALL] != 0.0 or discs[i, DC_RADIUS] > u[SU_MAX_RADIUS]:
            continue
        on = 0
        judged = 0
        hi = int(discs[i, DC_HI])
        for k in range(int(discs[i, DC_LO]), hi):
            state = point_state(u, ref, points[k, 0], points[k, 1])
            if state != 0:
                judged += 1
                on += state > 0
            left = hi - 1 - k  # stop once the points left could not make it still: a walker's first votes
            if (on + left) * (1.0 - u[SU_STILL_FRACTION]) < u[SU_STILL_FRACTION] * (judged - on) or on + left < 2:
                break
        if on >= 2 and on >= u[SU_STILL_FRACTION] * judged:
            discs[i, DC_STILL] = 1.0
