"""The batch engine against the scalar cores the nodes use: the same trajectories, robot by robot, on
every scenario, for several seeds and perturbed robots, and the same outcome whatever else is in the batch."""

import math

import numpy as np
import pytest

from twbr_batch import batch
from twbr_batch import montecarlo as mc
from twbr_batch.closed_loop import PlannerReference, run_closed_loop
from twbr_common.params import ConfigError
from twbr_sim.robot_params import robot_params
from twbr_sim.scenario import load_scenario
from twbr_sim.scenario_files import find_scenario, scenario_names, sensor_preset
from twbr_sim.world import N_SEGMENT, SEG_NEXT_DRAW, SEG_T, SEG_YAW_RATE, advance_segments
from twbr_tracker.evaluation import N_JUDGE, TrackingFigures

# (trace column, Trace field): what both record at every control sample.
COMPARED = (("t", "stamp"), ("pitch", "pitch"), ("velocity", "velocity"), ("left_torque", "left_torque"),
            ("right_torque", "right_torque"), ("velocity_ref", "velocity_ref"), ("yaw_rate_ref", "yaw_rate_ref"))
# Floating-point tolerance: the engines call the same compiled kernels in the same order, so they agree
# to the last bit here; the tolerance only allows a compiler to round a fused operation differently.
TOL = {"rtol": 1e-12, "atol": 1e-12}
RUNS = ((1, 0.0), (2, 0.0), (3, 0.2))  # (seed, perturbation)


@pytest.mark.parametrize("name", scenario_names())
def test_batch_trajectories_equal_the_scalar_cores(name):
    path = find_scenario(name)
    scenario = load_scenario(path)
    seeds = [seed for seed, _ in RUNS]
    params = np.stack([robot_params(mc.perturbed_robot(mc.perturbation_factors(seed, pert))) for seed, pert in RUNS])
    result = batch.run_batch(scenario, seeds, params, record=True, lanes=len(seeds))  # stepped together
    for i, (seed, pert) in enumerate(RUNS):
        row, trace = mc.run_one_traced(str(path), seed, pert)
        got = result.trace(i)
        assert len(got["t"]) == len(trace.t), f"{name} seed {seed}: run lengths differ"
        for column, field in COMPARED:
            np.testing.assert_allclose(got[column], trace[field], **TOL, err_msg=f"{name} seed {seed} {column}")
        np.testing.assert_allclose(got["x_c"], trace.x_c, **TOL)
        np.testing.assert_allclose(got["y_c"], trace.y_c, **TOL)
        z = result.table[i]
        assert bool(z[batch.Z_FALLEN]) == row.fallen == trace.fallen
        if row.time_to_reach_s is None:
            assert math.isnan(z[batch.Z_REACHED_AT])
        else:
            assert z[batch.Z_REACHED_AT] == pytest.approx(row.time_to_reach_s, abs=1e-12)


@pytest.mark.parametrize("name", ["dynamic_obstacles", "suite/head_on", "suite/trap_small", "suite/gap_1m",
                                  "suite/reactive_crowd", "suite/target_behind_wall"])
def test_the_robust_planner_runs_the_same_in_the_batch_and_on_the_scalar_cores(name):
    # Its boundary following, evasion and safety filter are one compiled implementation too; varied layouts
    # (suite scenarios) are each seed's in both.
    path = find_scenario(name)
    planner = {"method": "robust"}
    seeds = [1, 2]
    result = batch.run_batch(load_scenario(path), seeds, np.tile(robot_params(), (2, 1)), planner=planner,
                             record=True)
    for i, seed in enumerate(seeds):
        row, trace = mc.run_one_traced(str(path), seed, 0.0, planner=planner)
        got = result.trace(i)
        assert len(got["t"]) == len(trace.t), f"{name} seed {seed}: run lengths differ"
        for column, field in COMPARED:
            np.testing.assert_allclose(got[column], trace[field], **TOL, err_msg=f"{name} seed {seed} {column}")
        np.testing.assert_allclose(got["x_c"], trace.x_c, **TOL)
        assert result.table[i, batch.Z_COLLISIONS] == row.collisions
        assert row.reached  # the robust method reaches these targets
        # the jolt the suite reports: the largest change of a wheel's torque between two samples
        jolts = np.abs(np.diff(np.stack([trace["left_torque"], trace["right_torque"]]), axis=1))
        assert result.table[i, batch.Z_TORQUE_STEP_MAX] == pytest.approx(jolts.max(), abs=1e-12)
        # issue 35: no wheel's torque changes by more than 0.03 N·m between two samples (the shaped references'
        # jerk limits; 0.046-0.087 N·m without them where the planner reverses a turn)
        assert jolts.max() <= 0.03, f"{name} seed {seed}: a torque step of {jolts.max():.4f} N·m"


@pytest.mark.parametrize(("method", "name"), [("dwa", "suite/crowd_crossing"), ("vo", "suite/people_flow")])
def test_the_peer_methods_run_the_same_in_the_batch_and_on_the_scalar_cores(method, name):
    path = find_scenario(name)
    planner = {"method": method}
    result = batch.run_batch(load_scenario(path), [1], robot_params()[None, :], planner=planner, record=True)
    row, trace = mc.run_one_traced(str(path), 1, 0.0, planner=planner)
    got = result.trace(0)
    assert len(got["t"]) == len(trace.t) > 100
    for column, field in COMPARED:
        np.testing.assert_allclose(got[column], trace[field], **TOL, err_msg=f"{name} {method} {column}")
    np.testing.assert_allclose(got["x_c"], trace.x_c, **TOL)
    assert result.table[0, batch.Z_COLLISIONS] == row.collisions
    assert np.abs(trace["velocity_ref"]).max() > 0.3  # it drove


def test_the_runs_are_not_all_alike():
    # Guards the comparison above against a world that ignores the seed or a robot that ignores its
    # parameters: seeds move the target differently and a perturbed robot leans differently.
    scenario = load_scenario(find_scenario("dynamic_obstacles"))
    params = np.stack([robot_params(mc.perturbed_robot(mc.perturbation_factors(seed, pert))) for seed, pert in RUNS])
    table = batch.run_batch(scenario, [1, 2, 3], params).table
    assert len(set(table[:, batch.Z_REACHED_AT])) == 3
    assert len(set(table[:, batch.Z_PITCH_MAX])) == 3


def test_a_robot_runs_the_same_alone_and_among_others():
    scenario = load_scenario(find_scenario("dynamic_target"))
    p = robot_params()
    many = batch.run_batch(scenario, list(range(1, 41)), np.tile(p, (40, 1))).table
    alone = batch.run_batch(scenario, [17], p[None, :]).table
    np.testing.assert_array_equal(many[16], alone[0])
    assert many[:, batch.Z_SAMPLES].min() < many[:, batch.Z_SAMPLES].max()  # runs of different lengths


@pytest.mark.parametrize("sim", [None, {**sensor_preset("realistic"), "traction.friction": 0.05}],
                         ids=["ideal", "noisy-slippery"])
def test_robots_stepped_together_run_as_each_alone(sim):
    # More robots than run one by one (SERIAL_ROBOTS), so their physics steps in lane groups: some fall (a
    # 3 V supply), the others end on their targets at different times, and each robot's result and trace
    # are its own run's alone to the bit. With a robot that needs two RK4 sub-steps (half the inductance)
    # its group steps robot by robot, to the same results. With noisy sensors and little friction the
    # samples read the state's derivative (the IMU) and wheel loads (hundreds of slip events), which the
    # lane groups compute vectorised and a robot alone in its sample.
    scenario = load_scenario(find_scenario("dynamic_target"))
    kinds = [robot_params(), robot_params({"supply_voltage": 3.0}), robot_params({"body_mass": 14.0})]
    robots = [kinds[i % 3] for i in range(12)] + [robot_params({"armature_inductance": 0.0006})]
    seeds = list(range(1, len(robots) + 1))
    alone = [batch.run_batch(scenario, [seed], p[None, :], record=True, sim=sim)
             for seed, p in zip(seeds, robots, strict=True)]
    for n in (12, 13):
        assert n > batch.SERIAL_ROBOTS
        together = batch.run_batch(scenario, seeds[:n], np.stack(robots[:n]), lanes=n, record=True, sim=sim)
        table = together.table
        assert table[1, batch.Z_FALLEN] == 1.0 and table[0, batch.Z_FALLEN] == 0.0
        assert len(set(table[:, batch.Z_SAMPLES])) >= 6  # the runs end at their own times
        if sim is not None:
            assert table[:, batch.Z_SLIP_EVENTS].sum() > 1000 and table[:, batch.Z_PITCH_ERROR_SQUARES].min() > 0.0
        for i in range(n):
            np.testing.assert_array_equal(table[i], alone[i].table[0], err_msg=f"robot {i}")
            samples = int(alone[i].table[0, batch.Z_SAMPLES])
            np.testing.assert_array_equal(together.traces[i, :samples], alone[i].traces[0, :samples],
                                          err_msg=f"robot {i}")


def test_the_targets_move_on_at_their_turns_and_a_short_draw_list_is_an_error():
    # The batch books a group's physics in one call (robots_moved), moving each robot's target on to the
    # segment of its new time only when a turn is due; the draws are sized by draws_needed, so running out
    # of them is the batch's own error, never a silently frozen target.
    run = batch.RUN_LAYOUT.pack({name: 0.0 for name in batch.RUN_LAYOUT.names})
    run[batch.U_H] = 0.001
    run[batch.U_STEPS_PER_CONTROL] = 5
    run[batch.U_HAS_TARGET] = 1.0
    run[batch.U_TARGET_SPEED] = 0.5
    run[batch.U_TURN_INTERVAL] = 1.0
    results = np.zeros((2, batch.N_RESULT))
    results[:, batch.Z_PHYSICS_STEPS] = (995, 990)  # robot 0's step reaches t = 1 s, robot 1's does not
    segments = np.zeros((2, N_SEGMENT))
    segments[:, SEG_YAW_RATE] = 0.3
    segments[:, SEG_NEXT_DRAW] = 1
    draws = np.array([[0.3, -0.2, 0.1], [0.3, -0.2, 0.1]])
    running = np.array([0, 1])
    batch.robots_moved(run, results, segments, draws, running, 0, 2, np.array([False, True]))
    assert results[:, batch.Z_PHYSICS_STEPS].tolist() == [1000, 995]
    assert results[:, batch.Z_FALLEN].tolist() == [0.0, 1.0]
    assert segments[0, SEG_T] == 1.0 and segments[0, SEG_YAW_RATE] == -0.2 and segments[0, SEG_NEXT_DRAW] == 2
    assert segments[1, SEG_T] == 0.0 and segments[1, SEG_YAW_RATE] == 0.3  # no turn due: left as it was
    expected = segments[0].copy()
    advance_segments(expected, draws[0], 1.0, 0.5, 1.0)  # the world's own step: nothing more to do
    np.testing.assert_array_equal(segments[0], expected)
    results[0, batch.Z_PHYSICS_STEPS] = 2995  # two turns later: the third draw is the last there is
    with pytest.raises(ValueError, match="draws ran out"):
        batch.robots_moved(run, results, segments, draws, running, 0, 1, np.array([False]))


def test_mismatched_inputs_are_refused():
    scenario = load_scenario(find_scenario("step"))
    with pytest.raises(ConfigError, match="2 seeds and 1 parameter rows"):
        batch.run_batch(scenario, [1, 2], robot_params()[None, :])
    with pytest.raises(ConfigError, match="rate"):
        batch.run_batch(scenario, [1], robot_params()[None, :], control={"rate": -5.0})
    with pytest.raises(ConfigError, match="lanes=3: need 1 to the number of robots"):
        batch.run_batch(scenario, [1, 2], np.tile(robot_params(), (2, 1)), lanes=3)
    with pytest.raises(ConfigError, match=f"lanes=65: need 1 to the number of robots .100., at most {batch.LANES}"):
        batch.run_batch(scenario, list(range(100)), np.tile(robot_params(), (100, 1)), lanes=65)


@pytest.mark.parametrize(("name", "controller"), [("step", "pid"), ("dynamic_obstacles", "pid"),
                                                  ("dynamic_target", "lqr")])
def test_realistic_sensors_and_either_controller_run_the_same_in_the_batch(name, controller):
    """The noisy IMU, the encoders, the estimator and the traction tally are one compiled implementation too:
    robot i draws the noise of seed i, whatever thread runs it, as the simulator with that seed does."""
    path = find_scenario(name)
    seeds = [1, 2]
    params = np.stack([robot_params(mc.perturbed_robot(mc.perturbation_factors(seed, 0.2))) for seed in seeds])
    result = batch.run_batch(load_scenario(path), seeds, params, control={"controller": controller},
                             sim=sensor_preset("realistic"), record=True)
    for i, seed in enumerate(seeds):
        _row, trace = mc.run_one_traced(str(path), seed, 0.2, sensors="realistic", controller=controller)
        got = result.trace(i)
        assert len(got["t"]) == len(trace.t), f"{name} seed {seed}: run lengths differ"
        for column, field in COMPARED:
            np.testing.assert_allclose(got[column], trace[field], **TOL, err_msg=f"{name} seed {seed} {column}")
        np.testing.assert_allclose(got["x_c"], trace.x_c, **TOL)
        assert np.all(trace["pitch_estimated"])  # the controller really estimated: a raw IMU
        z = result.table[i]
        assert z[batch.Z_PITCH_ERROR_SQUARES] == pytest.approx(np.sum((trace["pitch"] - trace.pitch_true) ** 2),
                                                               rel=1e-9)
        assert z[batch.Z_PITCH_ERROR_SQUARES] > 0.0  # the noise reached the controller
        assert (z[batch.Z_LIFT_EVENTS], z[batch.Z_SLIP_EVENTS]) == (trace.traction.lift_events,
                                                                   trace.traction.slip_events)


@pytest.mark.parametrize("name", ["suite/head_on", pytest.param("suite/crowd_crossing", marks=pytest.mark.long),
                                  pytest.param("suite/target_behind_wall", marks=pytest.mark.long)])
def test_on_the_lidar_the_batch_runs_the_scan_tracker_and_target_filter_of_the_scalar_cores(name):
    # The scan cast and its noise, the tracker's detection, association and filters and the fused target,
    # in each robot of the batch, against the classes tracker_node and sim_node call (LaserScan's float32
    # included): the same path to the last bit, where the truth's and the tracker's plans differ.
    path = find_scenario(name)
    planner = {"method": "robust"}
    seeds = [1, 2]
    scenario = load_scenario(path)
    # the scenario's whole duration, as the scalar run's row counts its collisions
    lidar = batch.run_batch(scenario, seeds, np.tile(robot_params(), (2, 1)), planner=planner, record=True,
                            perception="lidar")
    truth = batch.run_batch(scenario, seeds, np.tile(robot_params(), (2, 1)), planner=planner, record=True,
                            duration=40.0)
    for i, seed in enumerate(seeds):
        row, trace = mc.run_one_traced(str(path), seed, 0.0, planner=planner, perception="lidar")
        got = result_trace = lidar.trace(i)
        n = min(len(got["t"]), len(trace.t))
        assert n > 400, f"{name} seed {seed}: only {n} samples"
        for column, field in COMPARED:
            np.testing.assert_allclose(got[column][:n], trace[field][:n], **TOL, err_msg=f"{name} seed {seed} {column}")
        np.testing.assert_allclose(got["x_c"][:n], trace.x_c[:n], **TOL)
        assert lidar.table[i, batch.Z_COLLISIONS] == row.collisions
        # what it saw is not the truth: the commands differ from the truth run's
        other = truth.trace(i)
        m = min(len(other["t"]), len(result_trace["t"]))
        assert np.abs(other["velocity_ref"][:m] - result_trace["velocity_ref"][:m]).max() > 1e-3


def test_the_lidar_needs_a_scanner():
    scenario = load_scenario(find_scenario("suite/head_on"))
    with pytest.raises(ConfigError, match=r"lidar\.rate = 0"):
        batch.run_batch(scenario, [1], robot_params()[None, :], perception="lidar", sim={"lidar.rate": 0.0})
    with pytest.raises(ConfigError, match="perception 'sonar'"):
        batch.run_batch(scenario, [1], robot_params()[None, :], perception="sonar")


def test_the_batch_judges_its_tracker_as_the_scalar_cores_do():
    # At every scan the tracks against the world's obstacles (evaluation.judge_lists): the batch's sums are
    # those of the scalar cores' run, and they judge something (a moving obstacle seen, matched, settled).
    scenario = load_scenario(find_scenario("suite/head_on"))
    planner = {"method": "robust"}
    reference = PlannerReference(planner, perception="lidar")
    run_closed_loop(20.0, reference, scenario=scenario, seed=1)
    z = batch.run_batch(scenario, [1], robot_params()[None, :], planner=planner, perception="lidar",
                        duration=20.0).table[0]
    judged = z[batch.Z_TRACKING:batch.Z_TRACKING + N_JUDGE]
    np.testing.assert_array_equal(judged, reference.perception.judge)
    figures = TrackingFigures.of(judged, 0.1)
    assert figures.instants >= 190 and figures.judged > 50 and figures.matched > 0.9 * figures.judged
    assert figures.position_rmse_m is not None and figures.position_rmse_m < 0.1
    truth = batch.run_batch(scenario, [1], robot_params()[None, :], planner=planner, duration=1.0).table[0]
    assert not truth[batch.Z_TRACKING:batch.Z_TRACKING + N_JUDGE].any()  # no scan, nothing judged
