"""sim_node's stepping decisions, without ROS (twbr_sim.stepping)."""

from twbr_sim.stepping import (
    SCRIPT_QUIET_NS,
    LockstepExchange,
    Missing,
    Publications,
    RealtimeTicks,
    TimeoutAction,
)

STATE_NS = 5_000_000  # one state every 5 ms


def test_only_the_command_stamped_with_the_pending_state_answers_it():
    ex = LockstepExchange()
    ex.offered(STATE_NS, 5)
    assert not ex.command(0)  # the previous state's command, late
    assert not ex.answered()
    assert ex.command(STATE_NS)  # the first answer (its latency is measured)
    assert not ex.command(STATE_NS)  # a duplicate is not a new answer
    assert ex.answered()
    ex.offered(2 * STATE_NS, 10)
    assert not ex.answered() and ex.missing() is Missing.COMMAND


def test_at_planning_instants_the_planner_output_is_awaited_too():
    ex = LockstepExchange(planner_every=50)  # 20 Hz at 1 kHz physics
    ex.offered(45 * 1_000_000, 45)  # not a planning instant
    ex.command(45 * 1_000_000)
    assert ex.answered()
    ex.offered(50 * 1_000_000, 50)
    ex.command(50 * 1_000_000)
    assert not ex.answered() and ex.missing() is Missing.PLANNER
    ex.planner(45 * 1_000_000)  # a stale planner_state does not stand in for this instant's
    assert not ex.answered()
    ex.planner(50 * 1_000_000)
    assert ex.answered()


def test_where_a_scripted_profile_changes_its_new_command_is_awaited_too():
    """A command_player starved on a loaded host stepped the paper's velocity step 0.1-0.2 s late (the
    simulator ran on with the controller alone): now the state of the change waits for the new command."""
    ex = LockstepExchange()
    ex.offered(200 * STATE_NS, 200, expected=(0.1, 0.0))  # the profile's step at t = 1 s
    ex.command(200 * STATE_NS)
    assert not ex.answered() and ex.missing() is Missing.SCRIPTED
    ex.scripted((0.0, 0.0))  # the player's repeat of the old command, late: not the answer
    assert not ex.answered()
    ex.scripted((0.1, 0.0))
    assert ex.answered()
    ex.offered(201 * STATE_NS, 201)  # between changes only the controller is awaited
    ex.command(201 * STATE_NS)
    assert ex.answered()


def test_a_quiet_player_is_awaited_again_before_the_controllers_cmd_vel_goes_stale():
    """The step test once settled in 4.5 s, not 2: the player's 20 Hz keep-alives could starve past the
    controller's 0.5 s cmd_vel_timeout while the simulator stepped on with the controller alone."""
    ex = LockstepExchange()
    command = (0.1, 0.0)
    ex.offered(200 * STATE_NS, 200, expected=command)
    ex.scripted(command)
    assert not ex.script_quiet(command, 200 * STATE_NS + SCRIPT_QUIET_NS - 1)
    assert ex.script_quiet(command, 200 * STATE_NS + SCRIPT_QUIET_NS)
    assert ex.script_quiet((0.2, 0.0), 201 * STATE_NS)  # another value was never heard
    # a keep-alive awaited in vain (the player died): one timeout, then the clock runs on without it
    ex.offered(300 * STATE_NS, 300, expected=command)
    ex.command(300 * STATE_NS)
    assert ex.missing() is Missing.SCRIPTED and ex.timed_out() is TimeoutAction.STEP_ON
    ex.stepping()  # as sim_node steps on after the timeout
    assert not ex.script_quiet(command, 400 * STATE_NS)
    ex.scripted(command)  # heard again: awaited again once it goes quiet
    assert ex.script_quiet(command, 300 * STATE_NS + SCRIPT_QUIET_NS)


def test_nobody_answering_t0_holds_it_but_a_missing_answer_later_is_a_timeout():
    ex = LockstepExchange(wait_for_first_command=True)
    ex.offered(0, 0)
    assert ex.timed_out() is TimeoutAction.OFFER_AGAIN
    ex.command(0)
    ex.stepping()
    ex.offered(STATE_NS, 5)
    assert ex.timed_out() is TimeoutAction.STEP_ON
    assert LockstepExchange(wait_for_first_command=False).timed_out() is TimeoutAction.STEP_ON


def test_realtime_telemetry_waits_for_the_answer_at_most_half_a_period():
    ticks = RealtimeTicks(period=0.005, now=100.0)
    assert not ticks.telemetry_due(answered=False, now=100.001)
    assert ticks.telemetry_due(answered=True, now=100.001)
    assert ticks.telemetry_due(answered=False, now=100.0025)
    assert ticks.wake_at() == 100.0025
    ticks.telemetry_done()
    assert ticks.wake_at() == 100.005 and not ticks.tick_due(100.0049) and ticks.tick_due(100.005)


def test_realtime_ticks_keep_their_schedule_but_never_catch_up_more_than_a_period():
    ticks = RealtimeTicks(period=0.005, now=0.0)
    ticks.sent(0.0051)  # a little late: the schedule holds
    assert abs(ticks.next_tick - 0.010) < 1e-12
    ticks.sent(0.100)  # a 90 ms stall: at most one period of catching up, no burst of 18 ticks
    assert abs(ticks.next_tick - 0.095) < 1e-12
    assert ticks.tick_due(0.100)
    ticks.sent(0.100)
    assert abs(ticks.next_tick - 0.100) < 1e-12  # then 0.105, ... : back on a 5 ms grid
    ticks.sent(0.1001)
    assert abs(ticks.next_tick - 0.105) < 1e-12


def test_publications_decimate_the_state_and_telemetry_topics():
    pub = Publications(clock_rate=200.0, world_rate=20.0, tf_rate=50.0, marker_rate=5.0, scan_rate=10.0,
                       detection_rate=5.0)
    states = [pub.with_state(k * 0.005, hosting_world=True) for k in range(200)]  # 1 s of 200 Hz states
    assert sum(s.clock for s in states) == 200 and sum(s.world for s in states) == 20
    assert sum(s.scan for s in states) == 10 and all(s.world for s in states if s.scan)  # a scan goes with a world
    assert sum(s.detections for s in states) == 5
    tele = [pub.with_state_telemetry(k * 0.005, hosting_world=True) for k in range(200)]
    assert sum(t.tf for t in tele) == 50 and sum(t.markers for t in tele) == 5
    status = [pub.status_due(k * 0.005, flags_changed=(k == 7)) for k in range(200)]
    assert sum(status) == 21 and status[7]  # 20 Hz, and at once on a flag change
    quiet = Publications(200.0, 20.0, 50.0, 5.0)
    assert not any(quiet.with_state(k * 0.005, hosting_world=False).world for k in range(200))
    assert not any(quiet.with_state(k * 0.005, hosting_world=True).scan for k in range(200))  # scan_rate 0
