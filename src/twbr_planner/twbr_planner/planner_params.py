"""The planner's parameters: one table for the node, the headless runs and docs/parameters.md."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from twbr_common.params import ConfigError, ParamSpec, defaults, tunable, validate_all
from twbr_sim.robot_limits import ROBOT_FILE_SPEC, RobotLimits, at_most, limits_from_file

METHODS = ("paper", "robust", "dwa", "vo")

APF_SPECS: tuple[ParamSpec, ...] = (
    *tunable(
    ParamSpec("method", "robust", "robust: the paper's field with goal-reachable repulsion, an escape from local"
              " minima down a navigation function, dynamic repulsion, a braking speed policy and a safety filter;"
              " paper: the paper's field (eqs. 19-28 with the documented fixes), which its three scenarios pin"
              " (docs/planner.md); dwa, vo: the dynamic window approach (Fox et al. 1997) and velocity obstacles"
              " (Fiorini & Shiller 1998), baseline peers under the same limits", choices=METHODS),
    ParamSpec("k_p", 1.0, "K_p: attractive gain on the target's relative position (eq. 21)", "1/s²", 0.0, 1000.0,
              low_open=True),
    ParamSpec("k_v", 0.5, "K_v: attractive gain on the target's relative velocity (eq. 21)", "1/s", 0.0, 1000.0),
    ParamSpec("k_o", 10.0, "K_o: repulsive gain (eq. 23)", "m²/s²", 0.0, 1e6),
    ParamSpec("rho_o", 2.0, "rho_o: obstacle detection range, measured from the obstacle's surface", "m",
              0.0, 100.0, low_open=True),
    ParamSpec("k_s", 2.0, "K_s: yaw-rate gain on the heading error (eq. 27)", "1/s", 0.0, 100.0, low_open=True),
    ParamSpec("v_max", 0.6, "v_max: forward speed away from obstacles (eq. 28)", "m/s", 0.0, 10.0, low_open=True),
    ParamSpec("max_yaw_rate", 1.5, "limit of the yaw-rate command", "rad/s", 0.0, 20.0, low_open=True),
    ParamSpec("robot_radius", 0.3, "robot footprint radius subtracted from obstacle distances (0: a point robot)",
              "m", 0.0, 10.0),
    ParamSpec("min_distance", 0.02, "distances below this count as this (the repulsion stays finite on contact)",
              "m", 0.0, 1.0, low_open=True),
    ParamSpec("capture_radius", 0.5, "a static target this close is reached: stop and balance", "m", 0.0, 100.0,
              low_open=True),
    ParamSpec("approach_gain", 1.0, "near a static target the speed is at most this times the distance", "1/s",
              0.0, 100.0, low_open=True),
    ParamSpec("slow_in_turns", True, "scale the speed by cos(heading error) (never negative): turn before driving"),
    ParamSpec("max_acceleration", 0.06, "limit of the forward speed command's rate of change (a balancing robot"
              " leans about a/g to accelerate)", "m/s²", 0.0, 100.0, low_open=True),
    ParamSpec("max_yaw_acceleration", 1.0, "limit of the yaw-rate command's rate of change", "rad/s²", 0.0, 1000.0,
              low_open=True),
    ParamSpec("max_yaw_jerk", 10.0, "robust, dwa, vo: limit of the yaw acceleration's change from one command to"
              " the next (and the yaw rate eased into its goal): a turn reversed at once jolts the wheels' torque"
              " through the yaw loop; robust takes evasion_yaw_jerk instead while evading a threat; the"
              " paper's method has none; 0: no limit", "rad/s³", 0.0, 1e6),
    ParamSpec("evasion_yaw_jerk", 0.0, "robust: the same limit while evading a threat (steeper than max_yaw_jerk:"
              " a late turn there is a collision, and a turn reversed at once jolts the wheels); 0: no limit",
              "rad/s³", 0.0, 1e6),
    ),
    ParamSpec("stuck_time", 8.0, "no progress over this long is reported as stuck (a local minimum)", "s",
              0.1, 1000.0),
    *tunable(ParamSpec("stuck_progress", 0.2, "progress towards the target below this over stuck_time is no"
                       " progress", "m", 0.0, 100.0),
    # The robust method's additions (method: robust); each has a value that switches it off.
    ParamSpec("repulsion_range", 0.8, "robust: the repulsion (eq. 23) acts within this clearance (rho_o stays the"
              " detection range of the speed policy and the safety filter)", "m", 0.0, 100.0, low_open=True),
    ParamSpec("goal_fade", 1.5, "robust: the repulsion is scaled by min(1, (distance to target / goal_fade)^2)"
              " so that it vanishes at the target; 0 turns it off", "m", 0.0, 100.0),
    ParamSpec("follow_range", 1.0, "robust: a way to the target blocked this close starts the local-minimum"
              " escape (down a navigation function; boundary following where no way leads to the target); 0 turns"
              " it off", "m", 0.0, 100.0),
    ParamSpec("follow_clearance", 0.45, "robust: clearance kept while following a boundary (the escape where no"
              " way leads to the target)", "m", 0.0, 100.0, low_open=True),
    ParamSpec("follow_gain", 2.0, "robust: how hard boundary following corrects its distance to the boundary",
              "1/m", 0.0, 100.0),
    ParamSpec("leave_progress", 0.2, "robust: the escape ends once this much closer to the target than where it"
              " began (and the way towards the target is free)", "m", 0.0, 100.0),
    ParamSpec("follow_flip_time", 40.0, "robust: boundary following on one side this long without leaving turns"
              " to the other side", "s", 0.0, 1e4, low_open=True),
    ParamSpec("free_margin", 0.05, "robust: the way is free when it passes every footprint-inflated obstacle by"
              " this much", "m", 0.0, 10.0),
    ParamSpec("free_steer", 0.3, "robust: on a free way the repulsion steers with at most this fraction of the"
              " attraction", "", 0.0, 100.0),
    ParamSpec("way_look", 1.4, "robust: a way round a blocked straight way must be free this far (or to the"
              " target)", "m", 0.0, 100.0, low_open=True),
    ParamSpec("way_fan_step", math.pi / 24.0, "robust: angle between the directions tried for a way round",
              "rad", 0.0, math.pi, low_open=True),
    ParamSpec("way_fan_steps", 10, "robust: directions tried for a way round on each side (10 x pi/24: up to 75"
              " degrees from the target's direction); 0 turns the way round off", "", 0, 100),
    ParamSpec("evade_horizon", 8.0, "robust: a moving obstacle whose closest approach comes within this time"
              " pushes the robot out of its path; 0 turns it off", "s", 0.0, 1000.0),
    ParamSpec("evade_margin", 0.4, "robust: an approach closer than this to the footprint is a threat", "m",
              0.0, 100.0),
    ParamSpec("evade_switch", 0.3, "robust: a dead-on threat is passed on the side first chosen until the other"
              " side is this much clearer", "m", 0.0, 10.0),
    ParamSpec("reverse_below", 0.05, "robust: a robot slower than this backs out of a threat's path when the way"
              " out is behind it (instead of turning on the spot first)", "m/s", 0.0, 10.0),
    ParamSpec("behind_angle", math.pi - 0.5, "robust: a heading error beyond this is nearly behind: the robot turns"
              " on the way it already turns", "rad", 0.0, math.pi),
    ParamSpec("turning_yaw_rate", 0.05, "robust: a robot turning faster than this keeps its turn's direction"
              " towards a way behind it", "rad/s", 0.0, 20.0),
    ParamSpec("evade_gain", 1.5, "robust: safety factor on the sideways distance out of a threat's path against"
              " the distance the robot can drive before the closest approach (their ratio, at most 1, weighs the"
              " way out against the field's direction)", "", 0.0, 1000.0),
    ParamSpec("brake_deceleration", 0.12, "robust: the speed may fall this fast (it rises at most by"
              " max_acceleration): the speed policy and the safety filter brake with it; a balancing robot leans"
              " back about a/g to brake", "m/s²", 0.0, 100.0, low_open=True),
    ParamSpec("speed_policy", True, "robust: at most the speed that brake_deceleration stops before the first"
              " obstacle ahead and the first one the way it turns to, never slowed by a moving obstacle being evaded"
              " (false: eq. 28)"),
    ParamSpec("safety_filter", True, "robust: a control barrier function per obstacle keeps the command"
              " admissible (within one period's acceleration)"),
    ParamSpec("safety_gamma", 0.5, "robust: the barrier's rate: dh/dt + safety_gamma h >= 0", "1/s", 0.0, 1000.0,
              low_open=True),
    ParamSpec("safety_margin", 0.05, "robust: clearance the safety filter and the speed policy keep", "m", 0.0,
              10.0),
    ParamSpec("safety_lookahead", 0.3, "robust: the barrier is on a point this far ahead of the axle (where the"
              " yaw rate acts too)", "m", 0.0, 10.0, low_open=True),
    ParamSpec("safety_speed_samples", 5, "robust: forward speeds the safety filter tries within one period's"
              " acceleration", "", 2, 100),
    ParamSpec("safety_yaw_rate_samples", 11, "robust: yaw rates the safety filter tries within one period's yaw"
              " acceleration", "", 2, 100),
    ParamSpec("safety_yaw_rate_weight", 0.1, "robust: the safety filter's cost of a yaw-rate change against a"
              " speed change", "s²", 0.0, 1000.0),
    ParamSpec("safety_moving_near", 0.5, "robust: an obstacle faster than the robot is guarded against only"
              " within this clearance (farther, evasion handles it: a barrier would turn the robot along its"
              " path)", "m", 0.0, 100.0),
    ParamSpec("yield_horizon", 6.5, "robust: how far ahead the command's rollout is checked against the moving"
              " obstacles' predicted discs; a conflict makes the robot wait, step aside or back out (yielding.py);"
              " 0 turns it off", "s", 0.0, 60.0),
    ParamSpec("yield_uncertainty", 0.1, "robust: a moving obstacle's predicted disc grows by this share of the"
              " distance it walks (it may turn, slow down or stop)", "", 0.0, 10.0),
    ParamSpec("yield_margin", 0.1, "robust: clearance the look-ahead keeps from the predicted discs", "m", 0.0,
              10.0),
    ParamSpec("yield_discount", 3.0, "robust: once the command's look-ahead conflicts, the candidate that overlaps"
              " the predicted discs least is taken, an overlap t seconds ahead weighted by exp(-t / yield_discount)"
              " (a nearer one is surer and sooner)", "s", 0.1, 1000.0),
    ParamSpec("window_horizon", 3.0, "robust: while a moving obstacle can come near within this, the field's"
              " direction is driven by a dynamic window of rollouts this long (window.py); 0 turns it off", "s",
              0.0, 60.0),
    ParamSpec("window_min_speed", 0.3, "robust: only an obstacle this fast starts the window (people walk at"
              " 0.3 m/s or more; a LiDAR track of a disc seen in part may seem to move at 0.1-0.3 m/s)", "m/s",
              0.0, 10.0),
    ParamSpec("window_acceleration", 0.12, "robust: while the window acts (a walker-fast obstacle within reach) the"
              " speed may rise this fast, and the window's and the yielding's rollouts assume it: a robot that"
              " accelerates at max_acceleration cannot get out of a walker's way (0: max_acceleration)", "m/s²",
              0.0, 100.0),
    ParamSpec("window_lane_angle", 0.52, "robust: a threat walking within this angle of the robot's way (towards it"
              " or after it) leaves the window to drive the field's own direction, not the evasion's push across"
              " the way: people in a flow give way, and the window's rollouts keep clear of them (0: always the"
              " push)", "rad", 0.0, 1.5708),
    ParamSpec("window_margin", 0.15, "robust: a window rollout that comes this close to an obstacle is not"
              " admissible", "m", 0.0, 10.0),
    ParamSpec("window_heading_weight", 1.0, "robust: the window's weight of the heading to the field's direction"
              " at a rollout's end", "", 0.0, 100.0),
    ParamSpec("window_clearance_weight", 0.3, "robust: the window's weight of a rollout's clearance (capped at"
              " window_clearance_cap)", "", 0.0, 100.0),
    ParamSpec("window_speed_weight", 0.6, "robust: the window's weight of the speed", "", 0.0, 100.0),
    ParamSpec("window_clearance_cap", 1.0, "robust: a rollout's clearance beyond this scores no more in the"
              " window", "m", 0.0, 100.0, low_open=True),
    ParamSpec("prediction_strength", 2.1, "robust: the social force's push at contact (Helbing's A) with which a"
              " moving obstacle's predicted path bends round the static discs in its way (prediction.py); 0:"
              " straight lines", "m/s²", 0.0, 1000.0),
    ParamSpec("prediction_range", 0.3, "robust: the predicted push's decay length (Helbing's B)", "m", 0.0, 100.0,
              low_open=True),
    ParamSpec("prediction_relaxation_time", 0.5, "robust: a predicted walker regains its present velocity in this"
              " time", "s", 0.0, 100.0, low_open=True),
    # The baseline peers (method: dwa, method: vo); they share v_max, the acceleration limits,
    # brake_deceleration, robot_radius, safety_margin, rho_o (the mode's range), arrival and the stuck report.
    ParamSpec("dwa_horizon", 3.0, "dwa: each (v, omega) is rolled out this long, obstacles at constant velocity",
              "s", 0.0, 60.0, low_open=True),
    ParamSpec("dwa_heading_weight", 1.0, "dwa: weight of the heading to the target at the rollout's end", "", 0.0,
              100.0),
    ParamSpec("dwa_clearance_weight", 0.3, "dwa: weight of the rollout's clearance (capped at dwa_clearance_cap)",
              "", 0.0, 100.0),
    ParamSpec("dwa_speed_weight", 0.6, "dwa: weight of the speed", "", 0.0, 100.0),
    ParamSpec("dwa_clearance_cap", 1.0, "dwa: clearance beyond this scores no more", "m", 0.0, 100.0,
              low_open=True),
    ParamSpec("vo_horizon", 5.0, "vo: a velocity that meets an obstacle within this time is in its velocity"
              " obstacle", "s", 0.0, 60.0, low_open=True),
    ),
)

NODE_SPECS: tuple[ParamSpec, ...] = (
    ParamSpec("rate", 20.0, "planning rate, in odom stamps", "Hz", 0.1, 1000.0),
    ParamSpec("world_timeout", 0.5, "target or obstacles older than this (against the odom stamp) stop the robot",
              "s", 0.01, 60.0),
    ParamSpec("world_period", 0.05, "period of the target's publisher (the world's 1/world_rate): a plan at"
              " stamp t waits for a target stamped after t - world_period, the target of its instant", "s",
              0.001, 10.0),
    ParamSpec("obstacles_period", 0.05, "period of the obstacles' publisher: the world's 1/world_rate, or"
              " tracker_node's scan period (1/lidar.rate); a plan at stamp t waits for obstacles stamped after"
              " t - obstacles_period", "s", 0.001, 10.0),
    ParamSpec("world_wait", 0.2, "wall time a plan waits for the world of its instant before it plans with"
              " what it has (keep it below the simulator's lockstep_timeout)", "s", 0.0, 10.0),
    ParamSpec("odom_timeout", 0.5, "odom stamped this much before the node's clock is stale and dropped", "s",
              0.001, 60.0),
    ParamSpec("enable_stamped_cmd_vel", False, "publish geometry_msgs/TwistStamped (Nav2's name) instead of Twist"),
    ParamSpec("marker_rate", 5.0, "rate of the force markers", "Hz", 0.1, 100.0),
    ROBOT_FILE_SPEC,
)


def check_within_robot(cfg: dict, limits: RobotLimits) -> dict:
    """Refuse settings the robot cannot meet (in range, but past what its motors and balance allow): a plan
    that assumes them steers into what the robot cannot avoid."""
    at_most(cfg, "v_max", limits, "top_speed", "m/s")
    at_most(cfg, "max_yaw_rate", limits, "top_yaw_rate", "rad/s")
    at_most(cfg, "max_acceleration", limits, "max_acceleration", "m/s²")
    at_most(cfg, "brake_deceleration", limits, "max_acceleration", "m/s²")
    at_most(cfg, "window_acceleration", limits, "max_acceleration", "m/s²")
    at_most(cfg, "max_yaw_acceleration", limits, "max_yaw_acceleration", "rad/s²")
    return cfg


def check_consistent(cfg: dict) -> dict:
    """Refuse combinations that no single range can: repulsion that could never act, a target never reached."""
    if cfg["min_distance"] >= cfg["rho_o"]:
        raise ConfigError(
            f"invalid parameter 'rho_o' = {cfg['rho_o']:g}: must be above min_distance = {cfg['min_distance']:g} m"
        )
    if cfg["rho_o"] < cfg["robot_radius"]:
        raise ConfigError(
            f"invalid parameter 'rho_o' = {cfg['rho_o']:g}: must be at least robot_radius = {cfg['robot_radius']:g} m"
            " (a detection range smaller than the robot sees obstacles only once they are about to touch it)"
        )
    if cfg["stuck_progress"] >= cfg["v_max"] * cfg["stuck_time"]:
        raise ConfigError(
            f"invalid parameter 'stuck_progress' = {cfg['stuck_progress']:g}: must be below v_max * stuck_time"
            f" = {cfg['v_max'] * cfg['stuck_time']:g} m (else a robot at full speed counts as stuck)"
        )
    return cfg


def resolve(overrides: Mapping[str, Any] | None = None, scenario: Any = None) -> dict:
    """The planner's settings for a headless run: the defaults, then what `scenario` pins (its `planner`
    field), then `overrides`, validated and checked."""
    pinned = dict(scenario.planner) if scenario is not None else {}
    if pinned:
        try:
            validate_all(APF_SPECS, {**defaults(APF_SPECS), **pinned})
        except ConfigError as e:
            raise ConfigError(f"scenario {scenario.name!r}, field 'planner': {e}") from None
    cfg = check_consistent(validate_all(APF_SPECS, {**defaults(APF_SPECS), **pinned, **(overrides or {})}))
    return check_within_robot(cfg, limits_from_file(""))


# The robust method's additions and the value of the parameter that switches each off (docs/planner.md).
ROBUST_ADDITIONS = (("goal-reachable field", "goal_fade", 0.0), ("escape", "follow_range", 0.0),
                    ("evasion", "evade_horizon", 0.0), ("speed policy", "speed_policy", False),
                    ("yielding", "yield_horizon", 0.0), ("safety filter", "safety_filter", False),
                    ("dynamic window", "window_horizon", 0.0),
                    ("social prediction", "prediction_strength", 0.0))


def describe(cfg: Mapping[str, Any]) -> str:
    """What this planner runs, for its start-up log line: the method, and the settings that shape it."""
    method = cfg["method"]
    limits = f"v_max {cfg['v_max']:g} m/s, max_yaw_rate {cfg['max_yaw_rate']:g} rad/s"
    if method == "paper":
        return (f"the paper's potential field (eqs. 19-28): K_p {cfg['k_p']:g}, K_v {cfg['k_v']:g}, K_o"
                f" {cfg['k_o']:g}, rho_o {cfg['rho_o']:g} m, K_s {cfg['k_s']:g}, {limits}")
    if method == "robust":
        on, off = [], []
        for name, key, off_value in ROBUST_ADDITIONS:
            (off if cfg[key] == off_value else on).append(name)
        return (f"the robust potential field: K_p {cfg['k_p']:g}, K_o {cfg['k_o']:g} within repulsion_range"
                f" {cfg['repulsion_range']:g} m, {limits}; with {', '.join(on) or 'no addition'}"
                + (f"; off: {', '.join(off)}" if off else ""))
    if method == "dwa":
        return (f"the dynamic window (Fox et al. 1997): {cfg['dwa_horizon']:g} s rollouts, weights heading"
                f" {cfg['dwa_heading_weight']:g}, clearance {cfg['dwa_clearance_weight']:g}, speed"
                f" {cfg['dwa_speed_weight']:g}, {limits}")
    return f"velocity obstacles (Fiorini & Shiller 1998): {cfg['vo_horizon']:g} s horizon, {limits}"

