"""Tracks of the compact discs a scan shows (detection.py): a constant-velocity Kalman filter each, matched
to the next scan's discs by the Hungarian method on a gated distance, born from an unmatched disc,
confirmed after `confirm_hits` matches, dropped after `max_misses` scans without one (a tentative track at
its first miss), and called moving above `moving_speed` (static again below half of it, or as soon as its
disc lies on a surface an earlier scan saw: surfaces.py; or, unseen, while it lies on a wall's chain of
discs, which a wall's end it was has merged into). A static track is published still (velocity 0):
the filter's velocity of a post seen from a moving robot is noise, and a planner would evade it as if it
walked. A disc partly hidden behind a nearer one (detection's DC_CLIPPED) moves its track's position but
not its velocity: its centre slides with the edge of the shadow as the robot drives past (0.4-0.7 m/s in
the suite's static clutter, where the planner then drove among the posts as among people), and a track
coasting behind it would carry that speed on (benchmarks/HISTORY.md, thirteenth session). A fitted clipped
disc as large as its track's body (`whole_radius` of the track's radius, once an unclipped sighting has
set it) is whole: the nearer object only stands beside it in the scan, as the posts beside a walker in
clutter do, and the walker's velocity would otherwise freeze for as long as it walks among them
(twentieth session). A whole disc then updates the track's position and velocity as an unclipped one does,
but not its radius: a disc that may be 0.85 of the body would otherwise pull the radius down a little at
each scan, and a smaller radius lets a smaller sliver count as whole at the next.

A person hidden behind another (or behind a wall) is not missing: a track whose predicted disc lies behind
closer returns over most of its width (`occluded`) coasts on its prediction without counting misses, for
up to `max_coast` seconds since its last match, and is published meanwhile (the planner still avoids
where the person must be). Its gate widens with its uncertainty (three position standard deviations, at
most `max_gate`), so it takes the person back when they reappear instead of a new track being born:
in a crowd most of a track's gaps are such occlusions, and each new id is an ID switch.

A confirmed track that is dropped anyway (hidden longer than `max_coast`, out of range, missed) is not
forgotten at once: it is kept unpublished ("lost") on its prediction until `reidentify_time` after its last
match, and a disc that no live track takes and that lies within a lost track's gate takes that track back,
id and all, instead of starting a new one (the lost-track buffer of SORT-family trackers: Wojke, Bewley &
Paulus 2017, DeepSORT's max_age; here on position alone, since a scan has no appearance). It comes back at
the mean velocity of its jump only if it was ever seen whole: a track only ever seen clipped has no
velocity of its own, and a wall's sliver taken back 0.4 m off would walk on at that jump's speed
(narrow_passage on the LiDAR: benchmarks/HISTORY.md, twenty-third session).

The state is (x, y, vx, vy) in odom [m, m/s]; the motion model is white-noise acceleration of spectral
density `acceleration_noise` (Bar-Shalom, Li & Kirubarajan 2001, ch. 6: Q for a step dt is
q [dt^3/3, dt^2/2; dt^2/2, dt] per axis); a disc's centre is measured with std `position_noise`. A wall's
chain (detection's DC_WALL) is not tracked: its discs slide along it as the robot moves, and a tracker would
read that as motion; they pass through as static obstacles.
"""

from __future__ import annotations

import math

import numpy as np

from twbr_common.jit import kernel
from twbr_common.layout import Layout
from twbr_common.params import ParamSpec
from twbr_tracker.assignment import assign
from twbr_tracker.detection import DC_CLIPPED, DC_FITTED, DC_RADIUS, DC_STILL, DC_T, DC_WALL, DC_X, DC_Y

TRACK_SPECS: tuple[ParamSpec, ...] = (
    ParamSpec("tracking.gate", 0.8, "a disc farther than this from a track's prediction is not its own", "m",
              0.0, 10.0, low_open=True),
    ParamSpec("tracking.confirm_hits", 3, "matches before a track is published", "", 1, 100),
    ParamSpec("tracking.max_misses", 5, "scans without a match before a confirmed track is dropped", "", 0, 1000),
    ParamSpec("tracking.acceleration_noise", 0.3, "spectral density of the white-noise acceleration", "m^2/s^3",
              0.0, 100.0, low_open=True),
    ParamSpec("tracking.position_noise", 0.1, "std of a disc centre as detection measures it", "m", 0.0, 5.0,
              low_open=True),
    ParamSpec("tracking.initial_speed_std", 1.0, "std of a new track's velocity", "m/s", 0.0, 100.0, low_open=True),
    ParamSpec("tracking.moving_speed", 0.15, "a track faster than this is moving (published with its velocity);"
              " below half of it static again (published still)", "m/s", 0.0,
              10.0),
    ParamSpec("tracking.max_tracks", 64, "tracks kept at once, lost ones included (a birth into a full table"
              " takes the oldest lost track's place, else waits)", "", 1, 10000),
    ParamSpec("tracking.max_coast", 2.0, "an occluded confirmed track coasts on its prediction this long after"
              " its last match", "s", 0.0, 60.0),
    ParamSpec("tracking.max_gate", 1.5, "the widest a coasting track's gate grows (3 position std)", "m", 0.0, 10.0,
              low_open=True),
    ParamSpec("tracking.clipped_noise", 0.3, "std of a clipped disc's centre (partly hidden: detection's"
              " DC_CLIPPED): it keeps its track but hardly moves it", "m", 0.0, 10.0, low_open=True),
    ParamSpec("tracking.reidentify_time", 8.0, "a dropped confirmed track is kept unpublished this long after its"
              " last match, and a new disc within its gate takes it back with its id (0: off)", "s", 0.0, 600.0),
    ParamSpec("tracking.occlusion_margin", 0.2, "a beam shorter than a track's near side by this much passes in"
              " front of it", "m", 0.0, 5.0),
    ParamSpec("tracking.whole_radius", 0.85, "a fitted clipped disc at least this fraction of its track's radius"
              " (once an unclipped sighting has set it) shows the whole body: it updates the track as an"
              " unclipped one does, position and velocity; the radius only an unclipped disc sets (above 1:"
              " never)", "", 0.0, 10.0),
)

SETTINGS_LAYOUT = Layout(("gate", "confirm_hits", "max_misses", "acceleration_noise", "position_noise",
                          "initial_speed_std", "moving_speed", "max_tracks", "max_coast", "max_gate",
                          "clipped_noise", "occlusion_margin", "reidentify_time", "whole_radius"))
TS_GATE = SETTINGS_LAYOUT["gate"]
TS_CONFIRM_HITS = SETTINGS_LAYOUT["confirm_hits"]
TS_MAX_MISSES = SETTINGS_LAYOUT["max_misses"]
TS_ACCELERATION_NOISE = SETTINGS_LAYOUT["acceleration_noise"]
TS_POSITION_NOISE = SETTINGS_LAYOUT["position_noise"]
TS_INITIAL_SPEED_STD = SETTINGS_LAYOUT["initial_speed_std"]
TS_MOVING_SPEED = SETTINGS_LAYOUT["moving_speed"]
TS_MAX_TRACKS = SETTINGS_LAYOUT["max_tracks"]
TS_MAX_COAST = SETTINGS_LAYOUT["max_coast"]
TS_MAX_GATE = SETTINGS_LAYOUT["max_gate"]
TS_CLIPPED_NOISE = SETTINGS_LAYOUT["clipped_noise"]
TS_OCCLUSION_MARGIN = SETTINGS_LAYOUT["occlusion_margin"]
TS_REIDENTIFY_TIME = SETTINGS_LAYOUT["reidentify_time"]
TS_WHOLE_RADIUS = SETTINGS_LAYOUT["whole_radius"]
N_SETTINGS = len(SETTINGS_LAYOUT)

TRACK_LAYOUT = Layout(("id", "x", "y", "vx", "vy", "radius", "hits", "misses", "confirmed", "moving", "t",
                       "born", "seen", "occluded", "lost", "whole"))
TR_ID = TRACK_LAYOUT["id"]
TR_X = TRACK_LAYOUT["x"]
TR_Y = TRACK_LAYOUT["y"]
TR_VX = TRACK_LAYOUT["vx"]
TR_VY = TRACK_LAYOUT["vy"]
TR_RADIUS = TRACK_LAYOUT["radius"]
TR_HITS = TRACK_LAYOUT["hits"]
TR_MISSES = TRACK_LAYOUT["misses"]
TR_CONFIRMED = TRACK_LAYOUT["confirmed"]
TR_MOVING = TRACK_LAYOUT["moving"]
TR_T = TRACK_LAYOUT["t"]  # [s] the instant the state is at
TR_BORN = TRACK_LAYOUT["born"]  # [s]
TR_SEEN = TRACK_LAYOUT["seen"]  # [s] its last match
TR_OCCLUDED = TRACK_LAYOUT["occluded"]  # 1: hidden behind closer returns in the last scan
TR_LOST = TRACK_LAYOUT["lost"]  # 1: dropped, unpublished, kept for re-identification
TR_WHOLE = TRACK_LAYOUT["whole"]  # 1: seen unclipped at least once (its radius set from the body, not a sliver)
N_TRACK = len(TRACK_LAYOUT)


def settings_vector(cfg: dict) -> np.ndarray:
    s = np.zeros(N_SETTINGS)
    for name in SETTINGS_LAYOUT.names:
        s[SETTINGS_LAYOUT[name]] = cfg[f"tracking.{name}"]
    return s


def new_tracks(s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """An empty track table (TRACK_LAYOUT rows) and its covariances (4 x 4 per track)."""
    capacity = int(s[TS_MAX_TRACKS])
    return np.zeros((capacity, N_TRACK)), np.zeros((capacity, 4, 4))


@kernel
def kalman_predict(track, cov, t, q):
    """Track and covariance from their instant to t, white-noise acceleration of density q: x += v dt,
    P = F P F' + Q (F = [I dt I; 0 I], written out: no matrix is allocated at every track and scan)."""
    dt = t - track[TR_T]
    if dt <= 0.0:
        return
    track[TR_X] += track[TR_VX] * dt
    track[TR_Y] += track[TR_VY] * dt
    track[TR_T] = t
    for j in range(4):  # F P: the position rows gain dt times the velocity rows
        cov[0, j] += dt * cov[2, j]
        cov[1, j] += dt * cov[3, j]
    for i in range(4):  # (F P) F': the position columns likewise
        cov[i, 0] += dt * cov[i, 2]
        cov[i, 1] += dt * cov[i, 3]
    for axis in range(2):
        cov[axis, axis] += q * dt ** 3 / 3.0
        cov[axis, axis + 2] += q * dt ** 2 / 2.0
        cov[axis + 2, axis] += q * dt ** 2 / 2.0
        cov[axis + 2, axis + 2] += q * dt


@kernel
def kalman_update(track, cov, zx, zy, variance, velocity_too=True):
    """The Kalman update on a measured position (zx, zy) [m] of isotropic `variance` [m²]: K = P H' S^-1
    with S = H P H' + R the 2 x 2 innovation covariance, P = (I - K H) P, written out. Without
    `velocity_too` the velocity is a considered state (the Schmidt-Kalman update: its gain rows zero, its
    covariance block unchanged, its cross-covariance the updated position rows')."""
    s00 = cov[0, 0] + variance
    s01 = cov[0, 1]
    s10 = cov[1, 0]
    s11 = cov[1, 1] + variance
    det = s00 * s11 - s01 * s10
    i00 = s11 / det
    i01 = -s01 / det
    i10 = -s10 / det
    i11 = s00 / det
    ex = zx - track[TR_X]
    ey = zy - track[TR_Y]
    t00, t01, t02, t03 = cov[0, 0], cov[0, 1], cov[0, 2], cov[0, 3]  # H P: what the gain takes from every row
    t10, t11, t12, t13 = cov[1, 0], cov[1, 1], cov[1, 2], cov[1, 3]
    for k in range(4 if velocity_too else 2):  # row k's gain reads only row k: each row updated in place
        g0 = cov[k, 0] * i00 + cov[k, 1] * i10
        g1 = cov[k, 0] * i01 + cov[k, 1] * i11
        track[TR_X + k] += g0 * ex + g1 * ey
        cov[k, 0] -= g0 * t00 + g1 * t10
        cov[k, 1] -= g0 * t01 + g1 * t11
        cov[k, 2] -= g0 * t02 + g1 * t12
        cov[k, 3] -= g0 * t03 + g1 * t13
    if not velocity_too:
        for i in range(2):
            for j in range(2, 4):
                cov[j, i] = cov[i, j]


@kernel
def _update(s, track, cov, zx, zy, radius, clipped, fitted):
    """A disc's centre (zx, zy) [m] into its track; the radius is smoothed. A clipped disc's centre is
    trusted less, leaves the radius be and moves the position only: it slides with the edge of what hides
    it, and as a velocity that slide is a post walking. Unless it is a fitted circle as large as the track's
    body (`whole_radius`, once an unclipped sighting has set the radius): then what hides it only stands
    beside it, and the disc moves the velocity too; the radius only an unclipped disc sets."""
    whole = (not clipped or (fitted and track[TR_WHOLE] != 0.0 and radius >= s[TS_WHOLE_RADIUS] * track[TR_RADIUS]))
    kalman_update(track, cov, zx, zy, (s[TS_POSITION_NOISE] if whole else s[TS_CLIPPED_NOISE]) ** 2, whole)
    if not clipped:
        track[TR_RADIUS] = 0.7 * track[TR_RADIUS] + 0.3 * radius if track[TR_WHOLE] != 0.0 else radius
        track[TR_WHOLE] = 1.0


@kernel
def mark_occluded(s, tracks, n, t, ranges, angle_min, angle_increment, x, y, yaw):
    """TR_OCCLUDED of tracks[:n] for the scan at t [s] from (x, y, yaw): set where more than half the beams
    across the track's disc, where it is predicted at t, return short of its near side."""
    beams = ranges.shape[0]
    for j in range(n):
        ahead = max(0.0, t - tracks[j, TR_T])
        dx = tracks[j, TR_X] + tracks[j, TR_VX] * ahead - x
        dy = tracks[j, TR_Y] + tracks[j, TR_VY] * ahead - y
        dist = math.hypot(dx, dy)
        radius = tracks[j, TR_RADIUS]
        tracks[j, TR_OCCLUDED] = 0.0
        if dist <= radius:
            continue
        # the bearing from the first beam, within one turn
        bearing = (math.atan2(dy, dx) - yaw - angle_min) % (2.0 * math.pi)
        half = math.asin(radius / dist)
        first = math.ceil((bearing - half) / angle_increment)
        last = math.floor((bearing + half) / angle_increment)
        near = dist - radius - s[TS_OCCLUSION_MARGIN]
        across = 0
        blocked = 0
        turn = round(2.0 * math.pi / angle_increment)  # beams in a full turn (a 270 degree scanner has fewer)
        for b in range(first, last + 1):
            i = b % turn
            if i >= beams:
                continue  # outside the scanner's field of view: neither seen nor hidden
            r = ranges[i]
            across += 1
            if r < near or r == -math.inf:  # -inf: closer than the device measures (REP 117)
                blocked += 1
        if across > 0 and 2 * blocked > across:
            tracks[j, TR_OCCLUDED] = 1.0


@kernel
def gate_of(s, cov):
    """A track's gate [m]: `gate`, widened to three position std of its covariance, at most `max_gate`."""
    sigma = math.sqrt(max(cov[0, 0], cov[1, 1]))
    return max(s[TS_GATE], min(3.0 * sigma, s[TS_MAX_GATE]))


@kernel
def _associate(s, tracks, cov, n, discs, compact, m, taken, match, lost):
    """Hungarian assignment of the discs not yet taken to the live tracks (lost False) or to the lost ones
    (lost True), each track's distance scaled by its own gate (gate_of); fills match and taken."""
    rows = np.empty(n, dtype=np.int64)
    n_rows = 0
    for j in range(n):
        if (tracks[j, TR_LOST] != 0.0) == lost:
            rows[n_rows] = j
            n_rows += 1
    cols = np.empty(m, dtype=np.int64)
    n_cols = 0
    for k in range(m):
        if not taken[k]:
            cols[n_cols] = k
            n_cols += 1
    if n_rows == 0 or n_cols == 0:
        return
    cost = np.empty((n_rows, n_cols))
    for r in range(n_rows):
        j = rows[r]
        scale = s[TS_GATE] / gate_of(s, cov[j])  # a distance within the track's own gate is within `gate`
        for c in range(n_cols):
            d = compact[cols[c]]
            cost[r, c] = scale * math.hypot(discs[d, DC_X] - tracks[j, TR_X], discs[d, DC_Y] - tracks[j, TR_Y])
    pairs = np.empty(n_rows, dtype=np.int64)
    assign(cost, s[TS_GATE], pairs)
    for r in range(n_rows):
        if pairs[r] >= 0:
            match[rows[r]] = cols[pairs[r]]
            taken[cols[pairs[r]]] = True


@kernel
def _revive(s, track, cov, t, zx, zy):
    """A lost track taken back by the disc at (zx, zy) [m]: there now, if it was ever seen whole at the mean
    velocity from its last match to here (its prediction is that match carried at its old velocity), else at
    the velocity it had; with the covariance of a velocity from two fixes `gap` apart plus the random walk
    of the velocity over the gap."""
    gap = max(t - track[TR_SEEN], 1e-3)
    if track[TR_WHOLE] != 0.0:
        track[TR_VX] += (zx - track[TR_X]) / gap
        track[TR_VY] += (zy - track[TR_Y]) / gap
    track[TR_X] = zx
    track[TR_Y] = zy
    variance = s[TS_POSITION_NOISE] ** 2
    cov[:, :] = 0.0
    cov[0, 0] = cov[1, 1] = variance
    cov[2, 2] = cov[3, 3] = 2.0 * variance / gap ** 2 + s[TS_ACCELERATION_NOISE] * gap / 3.0
    track[TR_LOST] = 0.0
    track[TR_MISSES] = 0.0
    track[TR_HITS] += 1.0
    track[TR_SEEN] = t


@kernel
def _remove(tracks, cov, j, n):
    """Drop row j of tracks[:n] (the last row takes its place); returns the new n."""
    n -= 1
    tracks[j, :] = tracks[n, :]
    cov[j, :, :] = cov[n, :, :]
    return n


@kernel
def _evict_lost(tracks, cov, n):
    """Drop the lost track last matched longest ago, if there is one; returns the new n."""
    oldest = -1
    for j in range(n):
        if tracks[j, TR_LOST] != 0.0 and (oldest < 0 or tracks[j, TR_SEEN] < tracks[oldest, TR_SEEN]):
            oldest = j
    return n if oldest < 0 else _remove(tracks, cov, oldest, n)


@kernel
def on_a_wall(track, discs, n_discs):
    """Whether an unseen track's disc overlaps one of the scan's wall discs: the end of a wall that a scan
    showed as a compact piece has merged into the wall's chain as the robot drove on, and its filter would
    coast it on along its slide as a walker (trap_large on the LiDAR: a moving track at 72-86 % of the
    scans; benchmarks/HISTORY.md, twenty-first session). A person hidden behind a post is behind closer
    returns, not on them."""
    for d in range(n_discs):
        if discs[d, DC_WALL] != 0.0:
            reach = discs[d, DC_RADIUS] + track[TR_RADIUS]
            dx = track[TR_X] - discs[d, DC_X]
            dy = track[TR_Y] - discs[d, DC_Y]
            if dx * dx + dy * dy < reach * reach:
                return True
    return False


@kernel
def track_step(s, tracks, cov, n, next_id, t, discs, n_discs):
    """One scan's discs (detection's rows) at time t [s] into the tracks tracks[:n] (their TR_OCCLUDED
    marked for this scan, mark_occluded); returns the new (n, next_id). Rows move: a dropped track's row
    takes the last one's."""
    for j in range(n):
        kalman_predict(tracks[j], cov[j], t, s[TS_ACCELERATION_NOISE])
    compact = np.empty(n_discs, dtype=np.int64)
    m = 0
    for d in range(n_discs):
        if discs[d, DC_WALL] == 0.0:
            compact[m] = d
            m += 1
    taken = np.zeros(m, dtype=np.bool_)
    match = np.full(n, -1, dtype=np.int64)
    _associate(s, tracks, cov, n, discs, compact, m, taken, match, False)
    _associate(s, tracks, cov, n, discs, compact, m, taken, match, True)  # the discs left, to the lost tracks
    for j in range(n):
        k = match[j]
        still = False
        if tracks[j, TR_LOST] != 0.0:
            if k >= 0:  # re-identified: the track is back, id and all
                d = compact[k]
                _revive(s, tracks[j], cov[j], t, discs[d, DC_X], discs[d, DC_Y])
            continue
        if k >= 0:
            d = compact[k]
            taken[k] = True
            # seen DC_T into the scan: carried back to the scan's instant along the track's velocity
            back = discs[d, DC_T]
            _update(s, tracks[j], cov[j], discs[d, DC_X] - tracks[j, TR_VX] * back,
                    discs[d, DC_Y] - tracks[j, TR_VY] * back, discs[d, DC_RADIUS], discs[d, DC_CLIPPED] != 0.0,
                    discs[d, DC_FITTED] != 0.0)
            tracks[j, TR_HITS] += 1.0
            tracks[j, TR_MISSES] = 0.0
            tracks[j, TR_SEEN] = t
            if tracks[j, TR_HITS] >= s[TS_CONFIRM_HITS]:
                tracks[j, TR_CONFIRMED] = 1.0
            still = discs[d, DC_STILL] != 0.0
        else:
            if tracks[j, TR_OCCLUDED] == 0.0 or tracks[j, TR_CONFIRMED] == 0.0:
                tracks[j, TR_MISSES] += 1.0
            still = on_a_wall(tracks[j], discs, n_discs)
        # static / moving, with hysteresis: moving above moving_speed, static again below half of it, and
        # static whatever its speed while its disc lies on a surface an earlier scan saw (surfaces.py), or,
        # unseen, on a wall's chain of discs
        speed = math.hypot(tracks[j, TR_VX], tracks[j, TR_VY])
        if still:
            tracks[j, TR_MOVING] = 0.0
        elif speed > s[TS_MOVING_SPEED]:
            tracks[j, TR_MOVING] = 1.0
        elif speed < 0.5 * s[TS_MOVING_SPEED]:
            tracks[j, TR_MOVING] = 0.0
    j = 0
    while j < n:  # drop: a tentative track at its first miss, a confirmed one after max_misses or max_coast
        limit = s[TS_MAX_MISSES] if tracks[j, TR_CONFIRMED] != 0.0 else 0.0
        since = t - tracks[j, TR_SEEN]
        if tracks[j, TR_LOST] != 0.0:
            gone = since > s[TS_REIDENTIFY_TIME] + 1e-9
        else:
            gone = tracks[j, TR_MISSES] > limit or since > s[TS_MAX_COAST] + 1e-9
            if gone and tracks[j, TR_CONFIRMED] != 0.0 and since <= s[TS_REIDENTIFY_TIME] + 1e-9:
                tracks[j, TR_LOST] = 1.0  # kept, unpublished, for re-identification
                gone = False
        if gone:
            n = _remove(tracks, cov, j, n)
        else:
            j += 1
    for k in range(m):  # births
        if taken[k]:
            continue
        if n >= tracks.shape[0]:
            n = _evict_lost(tracks, cov, n)  # a full table makes room from its oldest lost track
            if n >= tracks.shape[0]:
                continue
        d = compact[k]
        tracks[n, :] = 0.0
        tracks[n, TR_ID] = next_id
        tracks[n, TR_X] = discs[d, DC_X]
        tracks[n, TR_Y] = discs[d, DC_Y]
        tracks[n, TR_RADIUS] = discs[d, DC_RADIUS]
        tracks[n, TR_HITS] = 1.0
        tracks[n, TR_T] = t
        tracks[n, TR_BORN] = t
        tracks[n, TR_SEEN] = t
        tracks[n, TR_CONFIRMED] = 1.0 if s[TS_CONFIRM_HITS] <= 1.0 else 0.0
        tracks[n, TR_WHOLE] = 1.0 if discs[d, DC_CLIPPED] == 0.0 else 0.0
        cov[n, :, :] = 0.0
        cov[n, 0, 0] = cov[n, 1, 1] = s[TS_POSITION_NOISE] ** 2
        cov[n, 2, 2] = cov[n, 3, 3] = s[TS_INITIAL_SPEED_STD] ** 2
        next_id += 1
        n += 1
    return n, next_id
