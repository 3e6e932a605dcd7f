"""From one 2D LiDAR scan to discs in the odom frame: points, segments, and a disc per compact segment or a
chain of discs along a long one (a wall, a table edge).

1. Points: each finite return placed in odom from the robot's pose and pitch (the scanner is `height` up the
   leaning body, as twbr_sim/lidar.py casts it), at its own beam's instant: the pose is carried along the
   scan's turn at the robot's speed and yaw rate (deskewing: a robot turning at 3 rad/s turns 0.3 rad during
   one 10 Hz scan, which would put a person 5 m away 1.5 m off); a return whose hit is within
   `floor_margin` of the floor is the floor that a leaning scan sweeps, not an obstacle.
2. Segments: neighbouring beams whose points are closer than `gap` + `gap_per_metre` x range (the spacing
   of two beams grows with the range) belong together (the adaptive breakpoint rule of Borges & Aldon 2004),
   split again where two convex bodies touch (a fold deeper than `split_depth` between two bulging parts:
   people walking side by side, whose gap the breakpoint rule cannot see).
3. Discs: a segment no longer than `max_disc_extent` is one disc, fitted to its points by least squares
   (Kasa's algebraic circle fit) when that fit is sane, else the segment's centroid pushed away from the
   scanner by half its extent (a scanner sees only the near side of a person); a longer one is one disc
   too when its points lie on a circle (`arc_tolerance` RMS) of radius at most `max_arc_radius`, bulging
   towards the scanner by at least `arc_min_depth` (a large moving obstacle: a car, a cart, the paper's
   1.5-2 m discs), and otherwise a chain of discs `chain_spacing` apart along it (a wall, a row of posts).

Every step is a compiled kernel on flat arrays; `detect` composes them.
"""

from __future__ import annotations

import math

import numpy as np

from twbr_common.jit import kernel
from twbr_common.layout import Layout
from twbr_common.params import ParamSpec
from twbr_sim.lidar import (
    BEAM_DOWN,
    BEAM_DT,
    BEAM_DX,
    BEAM_DY,
    BEAM_HORIZONTAL,
    BEAM_SX,
    BEAM_SY,
    N_BEAM,
    scan_geometry,
    scanner_at,
)

DETECTION_SPECS: tuple[ParamSpec, ...] = (
    ParamSpec("detection.floor_margin", 0.05, "a return this close above the floor is the floor", "m", 0.0, 1.0),
    ParamSpec("detection.gap", 0.12, "break a segment where neighbouring points are farther apart than this,"
              " plus detection.gap_per_metre times their range", "m", 0.0, 5.0, low_open=True),
    ParamSpec("detection.gap_per_metre", 0.03, "breakpoint allowance per metre of range", "", 0.0, 1.0),
    ParamSpec("detection.min_points", 2, "fewer points than this are noise, not an object", "", 1, 100),
    ParamSpec("detection.max_disc_extent", 1.2, "a longer segment is a wall: a chain of discs", "m", 0.1, 10.0),
    ParamSpec("detection.min_radius", 0.05, "smallest disc reported", "m", 0.0, 5.0),
    ParamSpec("detection.chain_spacing", 0.4, "distance between the discs of a wall's chain", "m", 0.05, 5.0),
    ParamSpec("detection.max_arc_radius", 2.5, "a segment longer than max_disc_extent whose points lie on a circle"
              " of at most this radius is one large disc, not a wall's chain (0: never)", "m", 0.0, 50.0),
    ParamSpec("detection.arc_tolerance", 0.03, "the RMS distance of a segment's points from its fitted circle up to"
              " which they lie on it (about 3 range noise std)", "m", 0.0, 1.0, low_open=True),
    ParamSpec("detection.arc_min_depth", 0.05, "the least bulge of an arc towards the scanner, from the chord"
              " between its ends: a flatter one is a wall, whatever circle its noise fits", "m", 0.0, 5.0),
    ParamSpec("detection.split_depth", 0.1, "a segment is two objects where a point lies this much deeper than the"
              " nearest points on both its sides and both parts bulge towards the scanner (people side by side;"
              " 0: never)", "m", 0.0, 5.0),
    ParamSpec("detection.chain_depth", 2.0, "a chain disc's centre lies this many half-lengths of its stretch of"
              " wall behind it (away from the scanner), its radius reaching every point of the stretch: the"
              " deeper, the less the disc bulges in front of the wall (0: centred on the wall, bulging half its"
              " length)", "", 0.0, 10.0),
)

SETTINGS_LAYOUT = Layout(("floor_margin", "gap", "gap_per_metre", "min_points", "max_disc_extent", "min_radius",
                          "chain_spacing", "chain_depth", "max_arc_radius", "arc_tolerance", "arc_min_depth",
                          "split_depth"))
DS_FLOOR_MARGIN = SETTINGS_LAYOUT["floor_margin"]
DS_GAP = SETTINGS_LAYOUT["gap"]
DS_GAP_PER_METRE = SETTINGS_LAYOUT["gap_per_metre"]
DS_MIN_POINTS = SETTINGS_LAYOUT["min_points"]
DS_MAX_DISC_EXTENT = SETTINGS_LAYOUT["max_disc_extent"]
DS_MIN_RADIUS = SETTINGS_LAYOUT["min_radius"]
DS_CHAIN_SPACING = SETTINGS_LAYOUT["chain_spacing"]
DS_CHAIN_DEPTH = SETTINGS_LAYOUT["chain_depth"]
DS_MAX_ARC_RADIUS = SETTINGS_LAYOUT["max_arc_radius"]
DS_ARC_TOLERANCE = SETTINGS_LAYOUT["arc_tolerance"]
DS_ARC_MIN_DEPTH = SETTINGS_LAYOUT["arc_min_depth"]
DS_SPLIT_DEPTH = SETTINGS_LAYOUT["split_depth"]
N_SETTINGS = len(SETTINGS_LAYOUT)

# One disc: centre [m], radius [m], whether it is part of a wall's chain (1) or a compact object (0), when
# its beams saw it [s after the scan's first beam]: a person walks 5 cm in a 10 Hz scanner's turn, and
# whether it is clipped (1): a closer return right beside either end, so what shows may be part of it
# only and its fitted centre is off towards the part that shows; its points (rows lo..hi-1 of detect's
# points), whether they lie on a surface an earlier scan saw (still: surfaces.py marks it), and whether
# its centre is a circle's fitted to its points (1), not guessed from the near side it shows (0).
DISC_LAYOUT = Layout(("x", "y", "radius", "wall", "t", "clipped", "lo", "hi", "still", "fitted"))
DC_X = DISC_LAYOUT["x"]
DC_Y = DISC_LAYOUT["y"]
DC_RADIUS = DISC_LAYOUT["radius"]
DC_WALL = DISC_LAYOUT["wall"]
DC_T = DISC_LAYOUT["t"]
DC_CLIPPED = DISC_LAYOUT["clipped"]
DC_LO = DISC_LAYOUT["lo"]
DC_HI = DISC_LAYOUT["hi"]
DC_STILL = DISC_LAYOUT["still"]
DC_FITTED = DISC_LAYOUT["fitted"]
N_DISC = len(DISC_LAYOUT)


def settings_vector(cfg: dict) -> np.ndarray:
    s = np.zeros(N_SETTINGS)
    for name in SETTINGS_LAYOUT.names:
        s[SETTINGS_LAYOUT[name]] = cfg[f"detection.{name}"]
    return s


@kernel
def scan_points(ranges, geometry, z, floor_margin, first, points, beams, times):
    """The returns of a scan whose beams' geometry (twbr_sim.lidar.scan_geometry, the scanner `z` [m] above the
    floor) is `geometry`, as points in odom [m] (points[k]), taken round from beam `first`, with their place in
    that order (beams[k]) and their instant in the scan (times[k], s); the floor's and REP 117's infinities
    left out. Returns how many."""
    n = 0
    n_beams = ranges.shape[0]
    for k in range(n_beams):
        i = (first + k) % n_beams
        r = ranges[i]
        if not math.isfinite(r):
            continue
        if z - r * geometry[i, BEAM_DOWN] < floor_margin:  # the hit's height above the floor
            continue
        along = r * geometry[i, BEAM_HORIZONTAL]  # the scanner at this beam's instant, as the cast moved it
        points[n, 0] = geometry[i, BEAM_SX] + along * geometry[i, BEAM_DX]
        points[n, 1] = geometry[i, BEAM_SY] + along * geometry[i, BEAM_DY]
        beams[n] = k
        times[n] = geometry[i, BEAM_DT]
        n += 1
    return n


@kernel
def segment_points(points, beams, n, scanner_x, scanner_y, gap, gap_per_metre, starts):
    """Split points[:n] (in beam order) into segments; starts[k] is the first point of segment k and
    starts[count] = n. A segment also ends where more than one beam is missing between two points.
    Returns the number of segments."""
    if n == 0:
        starts[0] = 0
        return 0
    count = 0
    starts[0] = 0
    for k in range(1, n):
        if beams[k] - beams[k - 1] > 2:
            count += 1
            starts[count] = k
            continue
        fx = points[k, 0] - scanner_x
        fy = points[k, 1] - scanner_y
        jx = points[k, 0] - points[k - 1, 0]
        jy = points[k, 1] - points[k - 1, 1]
        allowed = gap + gap_per_metre * math.sqrt(fx * fx + fy * fy)  # (sqrt: libm's hypot is slower here)
        if jx * jx + jy * jy > allowed * allowed:
            count += 1
            starts[count] = k
    count += 1
    starts[count] = n
    return count


@kernel
def _centroid(points, lo, hi):
    cx = 0.0
    cy = 0.0
    for i in range(lo, hi):
        cx += points[i, 0]
        cy += points[i, 1]
    return cx / (hi - lo), cy / (hi - lo)


@kernel
def _circle_fit(points, lo, hi):
    """Kasa's least-squares circle through points[lo:hi]: (cx, cy, radius), radius inf when degenerate."""
    k = hi - lo
    mx, my = _centroid(points, lo, hi)
    suu = suv = svv = suuu = svvv = suvv = svuu = 0.0
    for i in range(lo, hi):
        u = points[i, 0] - mx
        v = points[i, 1] - my
        suu += u * u
        suv += u * v
        svv += v * v
        suuu += u * u * u
        svvv += v * v * v
        suvv += u * v * v
        svuu += v * u * u
    det = suu * svv - suv * suv
    if abs(det) < 1e-12:
        return mx, my, math.inf
    bu = 0.5 * (suuu + suvv)
    bv = 0.5 * (svvv + svuu)
    uc = (bu * svv - bv * suv) / det
    vc = (bv * suu - bu * suv) / det
    radius = math.sqrt(uc * uc + vc * vc + (suu + svv) / k)
    return mx + uc, my + vc, radius


@kernel
def _on_arc(s, points, lo, hi, fx, fy, fr, scanner_x, scanner_y):
    """Whether points[lo:hi] lie on their fitted circle (fx, fy, fr) [m], of at most `max_arc_radius`, and
    bulge towards the scanner (detection's third step)."""
    if hi - lo < 5 or s[DS_MAX_ARC_RADIUS] <= 0.0 or not fr <= s[DS_MAX_ARC_RADIUS]:
        return False
    square_sum = 0.0
    for i in range(lo, hi):
        square_sum += (math.sqrt((points[i, 0] - fx) ** 2 + (points[i, 1] - fy) ** 2) - fr) ** 2
    if square_sum > s[DS_ARC_TOLERANCE] ** 2 * (hi - lo):
        return False
    nx, ny = _towards_scanner(points, lo, hi, scanner_x, scanner_y)
    centre_side = nx * (fx - points[lo, 0]) + ny * (fy - points[lo, 1])
    # not flat, nor hollow towards the scanner
    return _bulge(points, lo, hi, scanner_x, scanner_y) >= s[DS_ARC_MIN_DEPTH] and centre_side <= 0.0


@kernel
def _towards_scanner(points, lo, hi, scanner_x, scanner_y):
    """The unit normal of the chord from points[lo] to points[hi - 1] on the scanner's side."""
    ex = points[hi - 1, 0] - points[lo, 0]
    ey = points[hi - 1, 1] - points[lo, 1]
    length = max(math.hypot(ex, ey), 1e-12)
    nx = -ey / length
    ny = ex / length
    if nx * (scanner_x - points[lo, 0]) + ny * (scanner_y - points[lo, 1]) < 0.0:
        return -nx, -ny
    return nx, ny


@kernel
def _bulge(points, lo, hi, scanner_x, scanner_y):
    """How far points[lo:hi] come out of the chord between their ends, towards the scanner [m]."""
    nx, ny = _towards_scanner(points, lo, hi, scanner_x, scanner_y)
    depth = 0.0
    for i in range(lo, hi):
        depth = max(depth, nx * (points[i, 0] - points[lo, 0]) + ny * (points[i, 1] - points[lo, 1]))
    return depth


@kernel
def _deepest_fold(s, points, beams, lo, hi, scanner_x, scanner_y, far, nearest_right):
    """Where points[lo:hi] part into two convex bodies touching, or -1 (the right part's first point): at the
    interior point lying deepest (by at least `split_depth`) behind the nearest points on both its sides,
    or between two points with a missing beam between them lying a quarter that deep (the beam passed
    between the bodies: far away, a body shows only a few beams and its flank points are shallow), with
    both parts bulging towards the scanner by `arc_min_depth`, three points each at least. `far` and
    `nearest_right` are scratch (each point's range, the least range after it)."""
    if hi - lo < 6:
        return -1
    for i in range(lo, hi):
        fx = points[i, 0] - scanner_x
        fy = points[i, 1] - scanner_y
        far[i] = math.sqrt(fx * fx + fy * fy)
    nearest_right[hi - 1] = math.inf
    for i in range(hi - 2, lo - 1, -1):
        nearest_right[i] = min(nearest_right[i + 1], far[i + 1])
    best = -1
    best_depth = s[DS_SPLIT_DEPTH]
    nearest_left = far[lo]  # the least range before k - 1
    for k in range(lo + 2, hi - 1):
        before = nearest_left  # before k - 1
        nearest_left = min(nearest_left, far[k - 1])
        if k - lo < 3 or hi - k < 3:
            continue
        depth = far[k] - max(nearest_left, nearest_right[k])  # the point k, first of the right part
        if beams[k] - beams[k - 1] > 1:  # a missing beam between k - 1 and k
            depth = max(depth, 4.0 * (min(far[k - 1], far[k]) - max(before, nearest_right[k])))
        if (depth >= best_depth and _bulge(points, lo, k, scanner_x, scanner_y) >= s[DS_ARC_MIN_DEPTH]
                and _bulge(points, k, hi, scanner_x, scanner_y) >= s[DS_ARC_MIN_DEPTH]):
            best = k
            best_depth = depth
    return best


@kernel
def split_folds(s, points, beams, n, starts, count, scanner_x, scanner_y, out):
    """The segments starts[:count + 1] split where two convex bodies touch (_deepest_fold, again in each part:
    people side by side are one segment by the breakpoint rule; a wall's corner has flat sides and stays
    whole), into out (the same form); returns the new count."""
    if s[DS_SPLIT_DEPTH] <= 0.0:
        out[:count + 1] = starts[:count + 1]
        return count
    far = np.empty(n)
    nearest_right = np.empty(n)
    pending = np.empty((n + 1, 2), dtype=np.int64)  # the parts still to look at, the leftmost last
    parts = 0
    for g in range(count):
        pending[0, 0] = starts[g]
        pending[0, 1] = starts[g + 1]
        waiting = 1
        while waiting > 0:
            waiting -= 1
            lo = pending[waiting, 0]
            hi = pending[waiting, 1]
            k = _deepest_fold(s, points, beams, lo, hi, scanner_x, scanner_y, far, nearest_right)
            if k < 0:
                out[parts] = lo
                parts += 1
                continue
            pending[waiting, 0] = k
            pending[waiting, 1] = hi
            pending[waiting + 1, 0] = lo
            pending[waiting + 1, 1] = k
            waiting += 2
    out[parts] = n
    return parts


@kernel
def _clipped(ranges, first, beams, lo, hi, points, scanner_x, scanner_y):
    """Whether the beam just outside either end of points[lo:hi] returns closer than that end: an object
    in front hides part of this one."""
    n_beams = ranges.shape[0]
    for end, step in ((lo, -1), (hi - 1, 1)):
        outside = ranges[(first + beams[end] + step) % n_beams]
        near = math.hypot(points[end, 0] - scanner_x, points[end, 1] - scanner_y)
        if outside == -math.inf or (math.isfinite(outside) and outside < near - 0.1):
            return True
    return False


@kernel
def _put_disc(discs, n, x, y, radius, wall, seen, clipped, lo, hi, fitted):
    """Row n of `discs` (DISC_LAYOUT), not still until surfaces.py says so."""
    discs[n, DC_LO] = lo
    discs[n, DC_HI] = hi
    discs[n, DC_STILL] = 0.0
    discs[n, DC_X] = x
    discs[n, DC_Y] = y
    discs[n, DC_RADIUS] = radius
    discs[n, DC_WALL] = wall
    discs[n, DC_T] = seen
    discs[n, DC_CLIPPED] = clipped
    discs[n, DC_FITTED] = fitted


@kernel
def fit_discs(s, points, times, starts, count, scanner_x, scanner_y, discs, ranges, first, beams):
    """The discs of segments 0..count-1 (DISC_LAYOUT rows of `discs`); returns how many."""
    n = 0
    for g in range(count):
        lo = starts[g]
        hi = starts[g + 1]
        if hi - lo < s[DS_MIN_POINTS]:
            continue
        clipped = 1.0 if _clipped(ranges, first, beams, lo, hi, points, scanner_x, scanner_y) else 0.0
        seen = 0.0
        for i in range(lo, hi):
            seen += times[i] / (hi - lo)
        extent = math.hypot(points[hi - 1, 0] - points[lo, 0], points[hi - 1, 1] - points[lo, 1])
        if extent <= s[DS_MAX_DISC_EXTENT]:
            cx, cy = _centroid(points, lo, hi)
            half = max(0.5 * extent, s[DS_MIN_RADIUS])
            fx, fy, fr = (_circle_fit(points, lo, hi) if hi - lo >= 3 else (cx, cy, math.inf))
            # a sane fit: a radius of the segment's size, its centre beyond the points seen from the scanner
            if (fr <= 1.5 * half + 0.05 and fr >= 0.5 * half
                    and math.hypot(fx - scanner_x, fy - scanner_y) > math.hypot(cx - scanner_x, cy - scanner_y)):
                _put_disc(discs, n, fx, fy, max(fr, s[DS_MIN_RADIUS]), 0.0, seen, clipped, lo, hi, 1.0)
            elif _on_arc(s, points, lo, hi, fx, fy, fr, scanner_x, scanner_y):  # a short arc of a large disc
                _put_disc(discs, n, fx, fy, fr, 0.0, seen, clipped, lo, hi, 1.0)  # (partly hidden, or seen end on)
            else:  # the near side of a disc of the segment's width
                d = math.hypot(cx - scanner_x, cy - scanner_y)
                _put_disc(discs, n, cx + half * (cx - scanner_x) / d, cy + half * (cy - scanner_y) / d, half, 0.0,
                          seen, clipped, lo, hi, 0.0)
            n += 1
            continue
        fx, fy, fr = _circle_fit(points, lo, hi)
        if _on_arc(s, points, lo, hi, fx, fy, fr, scanner_x, scanner_y):  # a large disc
            _put_disc(discs, n, fx, fy, fr, 0.0, seen, clipped, lo, hi, 1.0)
            n += 1
            continue
        pieces = math.ceil(extent / s[DS_CHAIN_SPACING])
        for q in range(pieces):  # a chain along the segment, each disc over its share of the points
            a = lo + (hi - lo) * q // pieces
            b = lo + (hi - lo) * (q + 1) // pieces
            if b <= a:
                continue
            cx, cy = _centroid(points, a, b)
            # behind the stretch along its normal, away from the scanner: a disc centred on the wall would
            # stand half its length out in front of it and close a passage by that much on each side
            ex = points[b - 1, 0] - points[a, 0]
            ey = points[b - 1, 1] - points[a, 1]
            length = math.hypot(ex, ey)
            if length > 0.0:
                nx = -ey / length
                ny = ex / length
                if nx * (cx - scanner_x) + ny * (cy - scanner_y) < 0.0:
                    nx = -nx
                    ny = -ny
                cx += s[DS_CHAIN_DEPTH] * 0.5 * length * nx
                cy += s[DS_CHAIN_DEPTH] * 0.5 * length * ny
            reach2 = 0.0
            for i in range(a, b):
                reach2 = max(reach2, (points[i, 0] - cx) ** 2 + (points[i, 1] - cy) ** 2)
            reach = math.sqrt(reach2)
            _put_disc(discs, n, cx, cy, max(reach, s[DS_MIN_RADIUS]), 1.0, seen, clipped, a, b, 0.0)
            n += 1
    return n


@kernel
def detect(s, ranges, angle_min, angle_increment, time_increment, x, y, yaw, speed, yaw_rate, pitch, axle_height,
           height, discs, points):
    """Discs in odom from one scan begun at the pose (x, y, yaw) [m, rad], moving at speed [m/s] and
    yaw_rate [rad/s], pitched by pitch [rad], its beams time_increment [s] apart; returns how many rows of
    `discs` (at least len(ranges) rows) are filled. `points` (as many rows, 2 columns) is left holding the
    scan's points [m] in odom, nan in the rows after the last (the discs' DC_LO:DC_HI index them)."""
    n_beams = ranges.shape[0]
    beams = np.empty(n_beams, dtype=np.int64)
    times = np.empty(n_beams)
    first = 0  # start the round at a beam without a return, so no object is cut in two at the seam
    for i in range(n_beams):
        if not math.isfinite(ranges[i]):
            first = i
            break
    sin_th = math.sin(pitch)
    cos_th = math.cos(pitch)
    needed = np.empty(n_beams, dtype=np.bool_)  # the returns' beams only
    for i in range(n_beams):
        needed[i] = math.isfinite(ranges[i])
    geometry = np.empty((n_beams, N_BEAM))
    scan_geometry(angle_min, angle_increment, time_increment, x, y, yaw, speed, yaw_rate, sin_th, cos_th,
                  height * sin_th, needed, geometry)
    n = scan_points(ranges, geometry, axle_height + height * cos_th, s[DS_FLOOR_MARGIN], first, points, beams,
                    times)
    points[n:, :] = math.nan
    scanner_x, scanner_y, _heading = scanner_at(x, y, yaw, speed, yaw_rate, 0.0, height * sin_th)
    starts = np.empty(n_beams + 1, dtype=np.int64)
    count = segment_points(points, beams, n, scanner_x, scanner_y, s[DS_GAP], s[DS_GAP_PER_METRE], starts)
    parts = np.empty(n_beams + 1, dtype=np.int64)
    count = split_folds(s, points, beams, n, starts, count, scanner_x, scanner_y, parts)
    return fit_discs(s, points, times, parts, count, scanner_x, scanner_y, discs, ranges, first, beams)
