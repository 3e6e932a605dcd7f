"""The tracker's figures (evaluation.py) on lists whose answer is known."""

from __future__ import annotations

import numpy as np
import pytest

from twbr_tracker.evaluation import (
    JG_ID_SWITCHES,
    JG_MATCHED,
    JG_MISSED,
    JG_POSITION_SQUARES,
    JG_SETTLED,
    N_JUDGE,
    evaluate,
    is_visible,
    judge_lists,
)
from twbr_tracker.tracker import WALL_IDS


def rows(*obstacles: tuple[float, ...]) -> np.ndarray:
    return np.array(obstacles, dtype=float).reshape(-1, 6)


def walk(seconds: float, offset: float = 0.0, switch_at: float | None = None, period: float = 0.1):
    """Two people walking at 0.5 m/s along y = 2 and y = -2, tracked `offset` off in x; from `switch_at` the
    first person's track has a new id."""
    for k in range(int(seconds / period)):
        t = k * period
        world = rows((1, 0.5 * t, 2.0, 0.5, 0.0, 0.3), (2, 0.5 * t, -2.0, 0.5, 0.0, 0.3))
        first = 7 if switch_at is not None and t >= switch_at else 1
        tracks = rows((first, 0.5 * t + offset, 2.0, 0.5, 0.0, 0.3), (2, 0.5 * t + offset, -2.0, 0.6, 0.0, 0.3),
                      (WALL_IDS, 5.0, 0.0, 0.0, 0.0, 0.2))  # a wall's disc: not a track
        yield t, tracks, world, (0.0, 0.0)


def test_tracks_on_their_people_have_the_offset_as_position_error_and_no_switch():
    f = evaluate(walk(5.0, offset=0.04), range_max=12.0)
    assert f.instants == 50 and f.judged == 100 and f.matched == 100
    assert f.position_rmse_m == pytest.approx(0.04)
    assert f.velocity_rmse_mps == pytest.approx(np.sqrt(0.5 * 0.1**2))  # one of two is 0.1 m/s off
    assert f.id_switches == 0 and f.missed == 0 and f.false_tracks == 0
    assert f.track_seconds == pytest.approx(10.0)


def test_a_track_that_changes_id_is_one_switch():
    f = evaluate(walk(5.0, switch_at=2.0), range_max=12.0)
    assert f.id_switches == 1
    assert f.id_switches_per_100_track_s == pytest.approx(10.0)


def test_the_first_second_of_a_track_is_not_judged_on_error():
    late = evaluate(walk(5.0, offset=0.04), range_max=12.0, settle=10.0)
    assert late.position_rmse_m is None and late.matched == 100


def test_a_track_off_by_more_than_the_gate_is_false_and_its_person_missed():
    f = evaluate(walk(1.0, offset=0.8), range_max=12.0)
    assert f.matched == 0 and f.missed == 20 and f.false_tracks == 20
    assert f.missed_pct == 100.0 and f.false_pct == 100.0


def test_a_person_behind_another_or_out_of_range_is_not_judged():
    world = rows((1, 3.0, 0.0, 0.5, 0.0, 0.3), (2, 6.0, 0.0, 0.5, 0.0, 0.3), (3, 0.0, 20.0, 0.5, 0.0, 0.3),
                 (4, 0.0, 3.0, 0.0, 0.0, 0.3))
    positions, radii = world[:, 1:3].copy(), world[:, 5].copy()
    assert [is_visible(positions, radii, w, 0.0, 0.0, 12.0) for w in range(4)] == [True, False, False, True]
    f = evaluate([(0.0, rows((1, 3.0, 0.0, 0.5, 0.0, 0.3)), world, (0.0, 0.0))], range_max=12.0)
    assert f.judged == 1 and f.missed == 0  # the hidden, the far and the standing one are not counted


def test_a_track_missing_from_a_list_is_born_again_when_it_comes_back():
    # Listed from 0 s, missing at 2.0 and 2.1 s, then back: its filter's first second is not judged again.
    judge = np.zeros(N_JUDGE)
    born = np.tile([-1.0, 0.0], (4, 1))
    last_track = np.full(1, -1.0)
    for k in range(40):
        t = round(0.1 * k, 1)
        world = rows((1, 0.5 * t, 2.0, 0.5, 0.0, 0.3))
        listed = rows((1, 0.5 * t + 0.04, 2.0, 0.5, 0.0, 0.3)) if t not in (2.0, 2.1) else rows()
        judge_lists(judge, born, last_track, t, listed, len(listed), world[:, 1:3].copy(), world[:, 3:5].copy(),
                    world[:, 5].copy(), 0.0, 0.0, 12.0, 0.5, 1.0)
    assert judge[JG_MATCHED] == 38 and judge[JG_MISSED] == 2 and judge[JG_ID_SWITCHES] == 0
    assert judge[JG_SETTLED] == 10 + 8  # 1.0-1.9 s and 3.2-3.9 s, not 2.2-3.1 s (born again at 2.2)
    assert judge[JG_POSITION_SQUARES] == pytest.approx(18 * 0.04**2)


def test_people_passing_through_each_other_keep_their_tracks():
    """Two small discs walk head-on through each other, each followed by its own track 0.1 m behind: just
    past the crossing each track is nearer the other person, and the nearest pairing would swap them and
    back (four switches); CLEAR-MOT keeps each person on its track while that stays within the gate."""
    def crossing():
        for k in range(41):
            t = 0.05 * k
            world = rows((1, -1.0 + t, 0.0, 1.0, 0.0, 0.04), (2, 1.0 - t, 0.0, -1.0, 0.0, 0.04))
            tracks = rows((11, -1.1 + t, 0.0, 1.0, 0.0, 0.04), (12, 1.1 - t, 0.0, -1.0, 0.0, 0.04))
            yield t, tracks, world, (0.0, -5.0)

    f = evaluate(crossing(), range_max=12.0, period=0.05)
    assert f.matched == f.judged > 70
    assert f.id_switches == 0
    assert f.position_rmse_m == pytest.approx(0.1)
