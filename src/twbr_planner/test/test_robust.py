"""The robust method's additions, each on a case whose answer is known without running the robot."""

import math

import numpy as np
import pytest
from unicycle import drive as drive_unicycle

from twbr_common.params import defaults
from twbr_planner import apf
from twbr_planner.apf import Mode, Obstacles
from twbr_planner.evasion import evasion
from twbr_planner.field import ray_clearance
from twbr_planner.planner import ApfPlanner, Target
from twbr_planner.planner_params import APF_SPECS
from twbr_planner.safety_filter import safety_filter
from twbr_planner.speed_policy import speed

ROBUST = {**defaults(APF_SPECS), "method": "robust"}
PAPER = {**defaults(APF_SPECS), "method": "paper"}
A = apf.settings_vector(ROBUST)
JERK = ROBUST["max_yaw_jerk"]


def memory() -> np.ndarray:
    """A planner's memory as it starts."""
    return np.zeros(apf.N_MEMORY)


def settled(planner: ApfPlanner, x, y, yaw, speed, target, obstacles, steps=60):
    """Plan `steps` times from the same state (the command's rate limits settle), the last output."""
    out = None
    for k in range(steps):
        out = planner.step(0.05 * k, x, y, yaw, speed, target, obstacles)
    return out


def test_ray_clearance_is_the_distance_to_the_inflated_disc():
    positions = np.array([[5.0, 0.0], [2.0, 3.0]])
    radii = np.array([1.0, 0.5])
    still = np.zeros(2, dtype=np.bool_)
    assert ray_clearance(0.0, 0.0, 1.0, 0.0, positions, radii, 0.3, 100.0, still, False) == pytest.approx(3.7)
    assert ray_clearance(0.0, 0.0, -1.0, 0.0, positions, radii, 0.3, 100.0, still, False) == 100.0  # behind
    assert ray_clearance(0.0, 0.0, 1.0, 0.0, positions, radii, 0.3, 2.0, still, False) == 2.0  # beyond reach
    moving = np.array([True, False])
    assert ray_clearance(0.0, 0.0, 1.0, 0.0, positions, radii, 0.3, 100.0, moving, True) == 100.0


def test_a_target_next_to_an_obstacle_is_approached_by_robust_and_held_off_by_paper():
    # Target 0.6 m from the surface of a disc, the robot 1.2 m from the target on the far side of it from
    # the disc: the paper's repulsion there outweighs the attraction; the robust one fades at the target.
    disc = Obstacles.of([(1, 0.0, 0.0, 1.0)])
    target = Target(1.6, 0.0, 0.0, 0.0)
    robust = settled(ApfPlanner(ROBUST), 2.8, 0.0, math.pi, 0.2, target, disc)
    paper = settled(ApfPlanner(PAPER), 2.8, 0.0, math.pi, 0.2, target, disc)
    assert abs(robust.heading_error) < 0.1 and robust.velocity_cmd > 0.05  # heads for it
    assert abs(paper.desired_heading) < 0.5  # pushed away from it, back the way it came


def test_a_gap_the_robot_fits_through_is_taken_on_a_free_way():
    # Two discs 1.0 m apart (surface to surface), target straight through: the robust field heads through.
    gap = Obstacles.of([(1, 2.0, 0.9, 0.4), (2, 2.0, -0.9, 0.4)])
    target = Target(5.0, 0.0, 0.0, 0.0)
    out = settled(ApfPlanner(ROBUST), 0.8, 0.0, 0.0, 0.2, target, gap)
    assert out.mode in (Mode.AVOIDING, Mode.TRACKING) and abs(out.desired_heading) < 0.05
    assert out.velocity_cmd > 0.0


# A wall of discs 6 m long across the way, 0.1 m from the footprint; the target behind it, to the left.
WALL = Obstacles.of([(k, 2.0, -3.0 + 0.5 * k, 0.4) for k in range(13)])


def test_a_blocked_way_starts_boundary_following_on_the_side_nearer_the_target():
    # No direction within 75 degrees of the target's is free for WAY_LOOK: follow the wall, on
    # the side nearer the target's direction.
    out = settled(ApfPlanner(ROBUST), 1.2, 0.0, 0.0, 0.0, Target(6.0, 0.5, 0.0, 0.0), WALL, steps=3)
    assert out.mode is Mode.ESCAPING and out.escape_side != 0
    assert out.desired_heading > 1.0  # along the wall, to the left
    mirrored = Obstacles.of([(k, 2.0, 3.0 - 0.5 * k, 0.4) for k in range(13)])
    out = settled(ApfPlanner(ROBUST), 1.2, 0.0, 0.0, 0.0, Target(6.0, -0.5, 0.0, 0.0), mirrored, steps=3)
    assert out.desired_heading < -1.0


def test_boundary_following_is_off_when_follow_range_is_zero():
    out = settled(ApfPlanner({**ROBUST, "follow_range": 0.0}), 1.2, 0.0, 0.0, 0.0, Target(6.0, 0.5, 0.0, 0.0),
                  WALL, steps=3)
    assert out.mode is not Mode.ESCAPING and out.escape_side == 0


def test_evasion_steps_out_of_the_path_on_the_robots_side():
    positions = np.array([[8.0, 0.3]])
    radii = np.array([0.5])
    velocities = np.array([[-1.0, 0.0]])  # head-on, its path 0.3 m to the robot's left
    moving = np.ones(1, dtype=np.bool_)
    ex, ey, threat, tx, ty = evasion(A, memory(), 0.0, 0.0, 0.3, 0.0, positions, velocities, radii, moving)
    assert threat == 0 and ey < 0.0 and ex == pytest.approx(0.0, abs=1e-12)  # to the right, away from it
    assert (tx, ty) == pytest.approx((0.0, -1.0))  # the threat's own way out, the same direction
    ex, ey, threat, _tx, _ty = evasion(A, memory(), 0.0, 0.0, 0.3, 0.0, np.array([[8.0, -0.3]]), velocities, radii, moving)
    assert ey > 0.0
    # One that passes wide, or is far in time, or goes away, or stands still, is no threat.
    assert evasion(A, memory(), 0.0, 0.0, 0.3, 0.0, np.array([[8.0, 3.0]]), velocities, radii, moving)[2] == -1
    assert evasion(A, memory(), 0.0, 0.0, 0.3, 0.0, np.array([[80.0, 0.0]]), velocities, radii, moving)[2] == -1
    assert evasion(A, memory(), 0.0, 0.0, 0.0, 0.0, np.array([[3.0, 0.0]]), np.array([[1.0, 0.0]]), radii, moving)[2] == -1
    assert evasion(A, memory(), 0.0, 0.0, 0.3, 0.0, positions, velocities, radii, ~moving)[2] == -1
    off = apf.settings_vector({**ROBUST, "evade_horizon": 0.0})
    assert evasion(off, memory(), 0.0, 0.0, 0.3, 0.0, positions, velocities, radii, moving)[2] == -1


def test_the_safety_filter_keeps_the_nominal_command_when_it_is_admissible():
    m = np.zeros(apf.N_MEMORY)
    m[apf.R_HAS_LAST] = 1.0
    m[apf.R_LAST_V] = 0.3
    positions = np.array([[10.0, 0.0]])
    v, w, binding = safety_filter(A, 0.05, m, 0.0, 0.0, 0.0, 0.3, 0.1, positions, np.zeros((1, 2)), np.array([0.5]),
                                  -1, JERK)
    # the yaw rate only by its acceleration limits: from a steady turn, the jerk limit's first step
    assert (v, w, binding) == (0.3, pytest.approx(ROBUST["max_yaw_jerk"] * 0.05 * 0.05), -1)


def test_the_safety_filter_brakes_or_turns_before_a_disc_it_would_reach():
    # Driving at 0.3 m/s straight at a disc whose surface is 0.2 m from the footprint: the barrier
    # (dh/dt + gamma h >= 0 on the look-ahead point) asks for less speed towards it, or a turn.
    m = np.zeros(apf.N_MEMORY)
    m[apf.R_HAS_LAST] = 1.0
    m[apf.R_LAST_STAMP] = 0.0
    m[apf.R_LAST_V] = 0.3
    positions = np.array([[1.0, 0.0]])
    radii = np.array([0.5])
    v, w, binding = safety_filter(A, 0.05, m, 0.0, 0.0, 0.0, 0.3, 0.0, positions, np.zeros((1, 2)), radii, -1, JERK)
    assert binding == 0
    # The look-ahead point (0.3 m ahead) is already 0.7 m from the centre, inside the barrier's 0.85 m: no
    # command within one period is admissible, and a turn does not change dh/dt here (the point moves
    # across the line to the disc). The least violation is the hardest braking one period allows, and
    # among equal violations the nominal yaw rate.
    assert v == pytest.approx(0.3 - ROBUST["brake_deceleration"] * 0.05, abs=1e-12)
    assert w == 0.0


def test_the_robust_speed_brakes_no_harder_than_brake_deceleration_and_rises_at_max_acceleration():
    planner = ApfPlanner(ROBUST)
    far = Target(30.0, 0.0, 0.0, 0.0)
    v = [planner.step(0.05 * k, 0.0, 0.0, 0.0, 0.0, far, Obstacles.empty()).velocity_cmd for k in range(40)]
    assert np.diff(v).max() <= ROBUST["max_acceleration"] * 0.05 + 1e-12
    wall = Obstacles.of([(1, 1.6, 0.0, 0.5)])  # suddenly 0.8 m ahead of the footprint
    after = [planner.step(0.05 * (40 + k), 0.3, 0.0, 0.0, v[-1], far, wall).velocity_cmd for k in range(10)]
    drops = -np.diff([v[-1], *after])
    assert drops.max() <= ROBUST["brake_deceleration"] * 0.05 + 1e-12
    assert drops.max() > ROBUST["max_acceleration"] * 0.05  # it does brake harder than it accelerates


def test_with_a_walker_in_reach_the_robust_speed_rises_at_window_acceleration():
    far = Target(30.0, 0.0, 0.0, 0.0)
    behind = Obstacles.of([(1, -2.5, 0.8, 0.3, 0.5, 0.0)])  # a walker overtaking beside the robot's line
    for obstacles, rate in ((behind, ROBUST["window_acceleration"]), (Obstacles.empty(), ROBUST["max_acceleration"])):
        planner = ApfPlanner(ROBUST)
        v = [planner.step(0.05 * k, 0.0, 0.0, 0.0, 0.0, far, obstacles).velocity_cmd for k in range(40)]
        assert np.diff(v).max() == pytest.approx(rate * 0.05)


def test_the_speed_can_stop_before_what_is_ahead_or_turned_to_but_not_for_a_disc_beside_the_way():
    """speed_policy: at most sqrt(2 b room), room the clearance along the heading and along the direction
    the robot turns to; a disc beside the way (0.3 m off the footprint) leaves v_max."""
    b, margin = ROBUST["brake_deceleration"], ROBUST["safety_margin"]
    still = np.zeros(1, dtype=np.bool_)

    def v(error, disc):
        positions = np.array([disc])
        return speed(A, 0.0, 0.0, 0.0, error, 1.0, -1, positions, np.array([0.4]), still, math.inf)

    room = 2.0 - 0.4 - ROBUST["robot_radius"] - margin
    assert v(0.0, (2.0, 0.0)) == pytest.approx(math.sqrt(2.0 * b * room))  # ahead: 1.3 m to stop in
    beside = v(0.0, (0.0, 1.0))
    assert beside == pytest.approx(ROBUST["v_max"])  # 0.3 m beside the footprint: no brake for it
    # 0.8 rad to the left, where it turns to, 1.2 m away (0.86 m off the heading: not ahead)
    turned = v(0.8, (1.2 * math.cos(0.8), 1.2 * math.sin(0.8)))
    assert turned == pytest.approx(math.sqrt(2.0 * b * (1.2 - 0.4 - ROBUST["robot_radius"] - margin)))
    assert turned < ROBUST["v_max"] * math.cos(0.8)  # what slowing in turns alone would allow


def test_the_paper_method_is_unchanged_by_the_robust_parameters():
    # The robust parameters have no effect on the paper's method: the same outputs, step by step.
    disc = Obstacles.of([(1, 3.0, 0.2, 1.0, 0.1, -0.1)])
    target = Target(6.0, 0.5, 0.0, 0.0)
    odd = {**PAPER, "repulsion_range": 0.3, "goal_fade": 0.0, "follow_range": 3.0, "evade_horizon": 0.0,
           "safety_filter": False, "speed_policy": False, "brake_deceleration": 5.0}
    a, b = ApfPlanner(PAPER), ApfPlanner(odd)
    for k in range(100):
        oa = a.step(0.05 * k, 0.01 * k, 0.0, 0.0, 0.2, target, disc)
        ob = b.step(0.05 * k, 0.01 * k, 0.0, 0.0, 0.2, target, disc)
        assert (oa.velocity_cmd, oa.yaw_rate_cmd, oa.mode) == (ob.velocity_cmd, ob.yaw_rate_cmd, ob.mode)


def test_the_safety_filter_never_reverses_a_forward_command():
    # Stopped between two discs, ahead and behind: whatever it finds least violating, it does not back
    # into the one behind (its look-ahead point guards the front only while it drives forwards).
    m = np.zeros(apf.N_MEMORY)
    m[apf.R_HAS_LAST] = 1.0
    positions = np.array([[0.9, 0.0], [-0.9, 0.0]])
    radii = np.array([0.5, 0.5])
    for nominal in (0.0, 0.2):
        v, _w, _binding = safety_filter(A, 0.05, m, 0.0, 0.0, 0.0, nominal, 0.0, positions, np.zeros((2, 2)), radii,
                                        -1, JERK)
        assert v >= 0.0


def test_a_stopped_robot_facing_a_disc_may_turn_away_through_it():
    # Stopped 0.27 m from a disc's footprint, facing just past it, the way on to the right behind the
    # disc: the look-ahead point would sweep through the disc, but a turn on the spot moves no part of
    # the robot, so the filter lets it turn (this was a deadlock in the clutter suite).
    m = np.zeros(apf.N_MEMORY)
    m[apf.R_HAS_LAST] = 1.0
    positions = np.array([[0.97, -0.29]])
    radii = np.array([0.45])
    yaw = 0.38
    v, w, _binding = safety_filter(A, 0.05, m, 0.0, 0.0, yaw, 0.0, -1.0, positions, np.zeros((1, 2)), radii, -1, JERK)
    assert v == 0.0 and w == pytest.approx(-ROBUST["max_yaw_jerk"] * 0.05 * 0.05)  # the turn eased in
    # and it does not let the robot drive into the disc instead
    v, w, binding = safety_filter(A, 0.05, m, 0.0, 0.0, -0.29, 0.3, 0.0, positions, np.zeros((1, 2)), radii, -1,
                                  JERK)
    assert v < 0.3 * 0.5 and binding == 0


def drive(planner: ApfPlanner, x, y, yaw, target, obstacles, duration):
    """A unicycle that does what the planner commands, every 0.05 s: when it came within 0.5 m of the
    target (None: never), and its smallest clearance to a footprint on the way."""
    speed = 0.0
    closest = math.inf
    for k in range(int(duration / 0.05)):
        out = planner.step(0.05 * k, x, y, yaw, speed, target, obstacles)
        speed = out.velocity_cmd
        yaw += 0.05 * out.yaw_rate_cmd
        x += 0.05 * speed * math.cos(yaw)
        y += 0.05 * speed * math.sin(yaw)
        closest = min(closest, out.nearest_obstacle_distance)
        if math.hypot(target.x - x, target.y - y) < 0.5:
            return 0.05 * k, closest
    return None, closest


def test_a_trap_is_left_down_the_navigation_function():
    # Into a U of discs 2.6 m deep whose bottom lies between the robot and the target: the paper's field
    # stops at the bottom; the robust method leaves by the mouth and goes round.
    u = Obstacles.of([(k, 7.0, -2.35 + 0.47 * k, 0.35) for k in range(11)]
                     + [(20 + k, 4.0 + 0.5 * k, 2.35, 0.35) for k in range(6)]
                     + [(30 + k, 4.0 + 0.5 * k, -2.35, 0.35) for k in range(6)])
    target = Target(10.0, 0.0, 0.0, 0.0)
    arrived, closest = drive(ApfPlanner(ROBUST), 2.0, 0.1, 0.0, target, u, 120.0)
    assert arrived is not None and arrived < 90.0 and closest > 0.05
    arrived, _closest = drive(ApfPlanner(PAPER), 2.0, 0.1, 0.0, target, u, 120.0)
    assert arrived is None


def test_a_dead_on_obstacle_is_passed_on_the_side_first_chosen():
    # An obstacle crossing at 1.2 m/s straight at where the robot will be: as the robot's speed wavers the
    # miss crosses zero; the widening direction must not flip with it (braking, then speeding up, in its path).
    m = np.zeros(apf.N_MEMORY)
    velocities = np.array([[0.0, 1.2]])
    radii = np.array([0.5])
    moving = np.ones(1, dtype=np.bool_)
    _ex, _ey, threat, tx, _ty = evasion(A, m, 0.0, 0.0, 0.4, 0.0, np.array([[1.05, -3.0]]), velocities, radii, moving)
    assert threat == 0 and tx < 0.0  # it would pass just ahead of the robot: let it, hang back
    # a moment later the robot is a little faster: the miss is 0.05 m on the other side
    _ex, _ey, threat, tx, _ty = evasion(A, m, 0.0, 0.0, 0.45, 0.0, np.array([[1.05, -3.0]]), velocities, radii, moving)
    assert threat == 0 and tx < 0.0
    # a fresh memory would have switched
    _ex, _ey, _threat, tx, _ty = evasion(A, memory(), 0.0, 0.0, 0.45, 0.0, np.array([[1.05, -3.0]]),
                                         velocities, radii, moving)
    assert tx > 0.0


def test_a_way_behind_the_robot_is_turned_to_the_way_it_already_turns():
    # The target moves from just left of straight behind to just right of it: a robot already turning left
    # keeps turning left (either way round is as short) instead of reversing its turn at every step.
    planner = ApfPlanner(ROBUST)
    for k in range(10):
        turning = planner.step(0.05 * k, 0.0, 0.0, 0.0, 0.0, Target(-5.0, 0.4, 0.0, 0.0), Obstacles.empty())
    assert turning.yaw_rate_cmd > 0.1
    out = planner.step(0.5, 0.0, 0.0, 0.0, 0.0, Target(-5.0, -0.4, 0.0, 0.0), Obstacles.empty())
    assert out.yaw_rate_cmd > 0.1
    fresh = settled(ApfPlanner(ROBUST), 0.0, 0.0, 0.0, 0.0, Target(-5.0, -0.4, 0.0, 0.0), Obstacles.empty(), steps=10)
    assert fresh.yaw_rate_cmd < -0.1


def test_a_step_reads_no_distance_it_has_not_computed():
    # `distances` is the step's scratch output (the field fills it): the method's pieces, one module each,
    # must read it only after the field ran, whatever the buffer held before.
    from twbr_planner.robust import robust_step

    rng = np.random.default_rng(3)
    for _ in range(50):
        n = int(rng.integers(1, 10))
        positions, radii = rng.uniform(-3.0, 3.0, (n, 2)), rng.uniform(0.2, 0.6, n)
        velocities = rng.uniform(-0.5, 0.5, (n, 2)) * (rng.random((n, 1)) < 0.5)
        outs = []
        for fill in (np.nan, 0.0, 1e9):
            out, m, ring = np.zeros(apf.N_OUTPUTS), memory(), np.zeros((200, apf.PROGRESS_COLUMNS))
            robust_step(A, m, ring, out, 1.0, -4.0, 0.2, 0.1, 0.3, 5.0, 0.0, 0.0, 0.0, positions, velocities, radii,
                        np.full(n, fill))
            outs.append(np.concatenate([out, m]))
        assert np.array_equal(outs[0], outs[1], equal_nan=True) and np.array_equal(outs[0], outs[2], equal_nan=True)


def _rate_limited(settings: dict, wanted: list[float]) -> np.ndarray:
    """The yaw-rate commands limit_rates lets through, at 20 Hz, for a stream of wanted yaw rates."""
    a, m = apf.settings_vector(settings), memory()
    return np.array([apf.limit_rates(a, m, 0.05 * k, 0.0, w, 1.0, a[apf.A_MAX_YAW_JERK])[1] for k, w in enumerate(wanted)])


def test_a_reversed_turn_changes_the_yaw_acceleration_by_at_most_the_jerk_limit():
    """Issue 35: a yaw acceleration reversed from one command to the next bends the controller's held
    reference at once, a jolt of the wheels' torque; max_yaw_jerk spreads the reversal over several commands,
    and a turn ends at the rate asked for without overshooting it."""
    wanted = [1.0] * 30 + [-1.0] * 60
    jerk = ROBUST["max_yaw_jerk"]
    w = _rate_limited(ROBUST, wanted)
    acceleration = np.diff(np.concatenate(([0.0], w))) / 0.05
    assert np.abs(acceleration).max() <= ROBUST["max_yaw_acceleration"] + 1e-9
    assert np.abs(np.diff(acceleration)).max() <= jerk * 0.05 + 1e-9
    assert w.max() <= 1.0 + 1e-12 and w[25:30] == pytest.approx(np.ones(5))
    assert w.min() >= -1.0 - 1e-12 and w[-5:] == pytest.approx(-np.ones(5))
    # without the limit the acceleration flips from +1 to -1 rad/s^2 in one command
    free = _rate_limited({**ROBUST, "max_yaw_jerk": 0.0}, [1.0] * 10 + [-1.0] * 10)
    assert np.diff(np.diff(free)).min() == pytest.approx(-2.0 * ROBUST["max_yaw_acceleration"] * 0.05)


def test_the_safety_filter_chooses_within_the_jerk_limited_window():
    """The filter's candidates are what the next command can reach: one turning at full yaw acceleration
    cannot reverse it at once, so its choice is not undone by the rate limits after it."""
    m = memory()
    m[apf.R_HAS_LAST] = 1.0
    m[apf.R_LAST_OMEGA] = 0.5
    m[apf.R_LAST_YAW_ACCELERATION] = ROBUST["max_yaw_acceleration"]
    _, w, _ = safety_filter(A, 0.05, m, 0.0, 0.0, 0.0, 0.0, -1.0, np.empty((0, 2)), np.empty((0, 2)), np.empty(0), -1,
                            JERK)
    lowest = 0.5 + (ROBUST["max_yaw_acceleration"] - ROBUST["max_yaw_jerk"] * 0.05) * 0.05
    assert w == pytest.approx(lowest)


def test_the_jerk_limit_holds_in_ordinary_driving_and_gives_way_to_an_evasion():
    """A person walking head-on at 0.5 m/s while the robot drives to its target: every command outside an
    evasion changes the yaw acceleration by at most max_yaw_jerk x 50 ms; out of a threat's path the robot
    turns as fast as its yaw acceleration allows (a late turn there is a collision, a jolt is not)."""
    _poses, outputs, clearance = drive_unicycle("robust", (12.0, 0.0), [(1, 10.0, 0.05, 0.3, -0.5, 0.0)], seconds=30.0)
    w = np.array([0.0] + [o.yaw_rate_cmd for o in outputs])
    jerk_steps = np.abs(np.diff(w, 2))  # [i]: the change of the yaw acceleration at output i + 1
    evading = np.array([o.threat_id >= 0 for o in outputs])[1:]  # a threat (the mode may say it yields to it)
    assert evading.any() and clearance > 0.0
    assert jerk_steps[~evading].max() <= JERK * 0.05 ** 2 + 1e-12
    assert np.abs(np.diff(w)).max() <= ROBUST["max_yaw_acceleration"] * 0.05 + 1e-12


def test_an_evasion_keeps_its_own_jerk_limit_when_one_is_set():
    """evasion_yaw_jerk: the same head-on walker, the evasion's commands changing the yaw acceleration by at
    most that limit x 50 ms, where the default (none) reverses it at once; the robot still passes clear."""
    walker = [(1, 10.0, 0.05, 0.3, -0.5, 0.0)]
    limit = 20.0
    for evasion_jerk in (0.0, limit):
        _poses, outputs, clearance = drive_unicycle("robust", (12.0, 0.0), walker, seconds=30.0,
                                                    evasion_yaw_jerk=evasion_jerk)
        w = np.array([0.0] + [o.yaw_rate_cmd for o in outputs])
        jerk_steps = np.abs(np.diff(w, 2))
        evading = np.array([o.threat_id >= 0 for o in outputs])[1:]
        assert evading.any() and clearance > 0.0
        if evasion_jerk > 0.0:
            assert jerk_steps[evading].max() <= limit * 0.05 ** 2 + 1e-12
        else:
            assert jerk_steps[evading].max() > limit * 0.05 ** 2 * 1.5  # unlimited: well past it


@pytest.mark.parametrize("offset", [0.0, 0.08])
def test_an_escape_pressed_against_a_disc_slides_off_it(offset: float):
    # clutter on the LiDAR, seed 108: the robot stands against a post (the first disc) and the navigation
    # function's way through the gap beyond cuts 0.3 rad into the post (the robot's grid cell lies inside
    # the inflated disc). Followed, it held the robot pressed there for 90 s (the safety filter forbids the
    # turn, the collision monitor the speed); touching, the escape turns out along the post instead. 0.08 m
    # off the post the way is followed as the grid has it.
    from twbr_planner.escape import escape
    from twbr_planner.navigation import navigation_direction

    positions = np.array([[4.48, -0.89], [4.55, 0.72], [2.36, 0.17], [2.56, -1.83]])
    radii = np.array([0.43, 0.34, 0.29, 0.40])
    moving = np.zeros(4, dtype=np.bool_)
    out_x, out_y = (3.86 - 4.48) / 0.735, (-0.5 + 0.89) / 0.735  # from the post's centre out to the robot
    x, y = 3.86 + offset * out_x, -0.5 + offset * out_y
    tx, ty = 10.5, 0.0
    m = memory()
    m[apf.R_FOLLOWING], m[apf.R_HIT_DISTANCE] = 1.0, 100.0  # escaping, far from leaving
    d = math.hypot(tx - x, ty - y)
    gx, gy = (tx - x) / d, (ty - y) / d
    ex, ey, side, escaping = escape(A, m, 1.0, x, y, d, False, tx, ty, gx, gy, gx, gy, False, 0.5, gx, gy, positions,
                                    radii, moving)
    way_x, way_y, found = navigation_direction(x, y, tx, ty, positions, radii, moving,
                                               A[apf.A_ROBOT_RADIUS] + A[apf.A_FREE_MARGIN])
    assert escaping and found and side != 0.0
    assert way_x * out_x + way_y * out_y < 0.0  # the grid's way cuts into the post
    if offset == 0.0:
        assert (ex * out_x + ey * out_y) / math.hypot(ex, ey) > 0.5  # off the post, more out than along
    else:
        assert (ex, ey) == (way_x, way_y)
