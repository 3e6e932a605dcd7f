"""Gain tuning on the nonlinear model: step-response costs of the headless closed loop, minimised with scipy.

Start: an LQR design of the linearised forward/pitch model (about upright, no motor lag), mapped onto the
cascade: with common torque = kp_pitch (pitch - pitch_ref) + kd_pitch pitch_rate and pitch_ref =
kp_v (v_ref - v) + ki_v int(v_ref - v), the state feedback gains are kp_pitch, kd_pitch, kp_pitch kp_v and
kp_pitch ki_v; the set-point weight starts at 0.5. Then Nelder-Mead on the nonlinear closed loop (dynamics,
motors, current-loop driver, 200 Hz sampling, torque limit) over the paper's 0.1 m/s step, on the
nominal robot and on a 20 % lighter and a 20 % heavier body, so the gains do not hinge on a body mass
nobody knows exactly. The yaw-rate PI is tuned the same way on a 0.5 rad/s step.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.linalg
import scipy.optimize

from twbr_batch.closed_loop import Trace, run_closed_loop
from twbr_batch.response import PITCH_BAND, StepResponse, settle_time, step_response
from twbr_common.params import defaults
from twbr_control.lqr import linear_models
from twbr_sim.robot_params import ROBOT_SPECS

VELOCITY_STEP = 0.1  # m/s, the paper's Figure 6
YAW_RATE_STEP = 0.5  # rad/s
STEP_AT = 0.5  # s
BALANCE_GAINS = ("pitch.kp", "pitch.kd", "velocity.kp", "velocity.ki", "velocity.setpoint_weight",
                 "reference_rate.velocity")
MAX_ROLLBACK = 0.5  # the step's wrong-way roll, as a fraction of the step: the paper's "slightly backwards"
BOUNDS = {"velocity.setpoint_weight": 1.0, "lqr.setpoint_weight": 1.0}
YAW_GAINS = ("yaw_rate.kp", "yaw_rate.ki")
# LQR: the weights relative to the torque's (lqr.r_* stay 1); the reference ramp is the cascade's (one
# parameter for both laws, so that switching `controller` keeps the step's shape)
LQR_BALANCE_WEIGHTS = ("lqr.q_position", "lqr.q_velocity", "lqr.q_pitch", "lqr.q_pitch_rate", "lqr.setpoint_weight")
LQR_YAW_WEIGHTS = ("lqr.q_heading", "lqr.q_yaw_rate")


def lqr_balance_gains(robot: Mapping[str, Any] | None = None, q: Sequence[float] = (300.0, 1.0, 1.0, 0.1),
                      r: float = 0.3) -> dict[str, float]:
    """Cascade gains equal to the LQR state feedback on (int v, v, pitch, pitch rate), per wheel torque."""
    a, b, _, _ = linear_models({**defaults(ROBOT_SPECS), **(robot or {})})
    rr = np.array([[r]])
    k = np.linalg.solve(rr, b.T @ scipy.linalg.solve_continuous_are(a, b, np.diag(q), rr))[0]
    k_int, k_v, k_pitch, k_rate = -k
    return {"pitch.kp": k_pitch, "pitch.kd": k_rate, "velocity.kp": k_v / k_pitch, "velocity.ki": k_int / k_pitch}


def realistic_sensors() -> dict[str, Any]:
    """The simulator parameters of config/sensors_realistic.yaml."""
    from twbr_sim.scenario_files import sensor_preset

    return sensor_preset("realistic")


def velocity_step(control: Mapping[str, Any], robot: Mapping[str, Any] | None = None, size: float = VELOCITY_STEP,
                  duration: float = 5.0, sim: Mapping[str, Any] | None = None, seed: int = 1,
                  step_at: float = STEP_AT) -> Trace:
    return run_closed_loop(duration, lambda t, _s: (size if t >= step_at else 0.0, 0.0), control, robot, sim,
                           seed=seed)


def yaw_rate_step(control: Mapping[str, Any], robot: Mapping[str, Any] | None = None, size: float = YAW_RATE_STEP,
                  duration: float = 4.0, sim: Mapping[str, Any] | None = None, seed: int = 1,
                  step_at: float = STEP_AT) -> Trace:
    return run_closed_loop(duration, lambda t, _s: (0.0, size if t >= step_at else 0.0), control, robot, sim,
                           seed=seed)


@dataclass(frozen=True)
class StepCheck:
    """What the issue asks of a step, measured on one trace."""

    response: StepResponse
    pitch_settle_time_s: float  # from the step until |pitch - its final value| stays <= PITCH_BAND
    pitch_final_rad: float
    max_abs_pitch_rad: float
    max_torque_nm: float
    fallen: bool


def check_step(trace: Trace, signal: str, reference: str) -> StepCheck:
    """The figures of `signal`'s true value (the simulator's, not the sensors': they are equal unless the
    sensors are realistic) against `reference`."""
    truth = {"velocity": trace.velocity_true, "pitch": trace.pitch_true, "yaw_rate": trace.yaw_rate_true}
    response = step_response(trace.t, truth.get(signal, trace[signal]), trace[reference])
    assert response is not None
    pitch = trace.pitch_true
    tail = trace.t >= trace.t[-1] - 0.5
    final_pitch = float(np.mean(pitch[tail]))
    torque = max(np.abs(trace["left_torque"]).max(), np.abs(trace["right_torque"]).max())
    return StepCheck(
        response, settle_time(trace.t, pitch, final_pitch, PITCH_BAND, response.step_time_s), final_pitch,
        float(np.abs(pitch).max()), float(torque), trace.fallen,
    )


def _balance_cost(trace: Trace) -> float:
    """The 5 % settling time of the true speed, overshoot past 5 %, a roll-back past MAX_ROLLBACK of the step
    (a steep penalty: a constraint), and a little torque chatter (which sensor noise turns into motor heat).
    ITAE alone leaves a PI's slow tail in; the set-point weight is what buys a fast, flat step here."""
    if trace.fallen:
        return 1e6
    t = trace.t
    response = step_response(t, trace.velocity_true, trace["velocity_ref"])
    assert response is not None
    chatter = float(np.sum(np.diff(trace["left_torque"]) ** 2))
    rollback = response.undershoot / VELOCITY_STEP
    after = t >= response.step_time_s
    # the mean error after the step, in step sizes: a slope where noise makes the settling time jump
    iae = float(np.mean(np.abs(trace.velocity_true[after] - trace["velocity_ref"][after]))) / VELOCITY_STEP
    return (min(response.settle_time_s, 10.0) + 0.05 * max(0.0, response.overshoot_pct - 5.0)
            + 50.0 * max(0.0, rollback - MAX_ROLLBACK) + 1e-3 * chatter + 5.0 * iae)


def _yaw_cost(trace: Trace) -> float:
    if trace.fallen:
        return 1e6
    t = trace.t
    step_at = float(t[np.flatnonzero(trace["yaw_rate_ref"] != 0.0)[0]])
    after = t >= step_at
    err = (trace.yaw_rate_true - trace["yaw_rate_ref"])[after] / YAW_RATE_STEP
    dt = float(t[1] - t[0])
    overshoot = max(0.0, float(np.max(err)))
    settle = settle_time(t, trace.yaw_rate_true, YAW_RATE_STEP, 0.05 * YAW_RATE_STEP, step_at)
    chatter = float(np.sum(np.diff(trace["differential_torque"]) ** 2))
    return float(np.sum((t[after] - step_at) * np.abs(err)) * dt) + min(settle, 10.0) + 20.0 * overshoot**2 \
        + 1e-2 * chatter


def robot_variants(scale: float = 0.2) -> list[dict[str, float]]:
    """The nominal robot and a lighter and a heavier body."""
    mass = defaults(ROBOT_SPECS)["body_mass"]
    return [{}, {"body_mass": mass * (1 - scale)}, {"body_mass": mass * (1 + scale)}]


@dataclass(frozen=True)
class Case:
    """One closed-loop run the gains are judged on."""

    robot: Mapping[str, float]
    sim: Mapping[str, Any]
    seed: int = 1
    step_at: float = STEP_AT  # [s]
    extra: float = 0.0  # [s] run this much longer than the ideal case

    @property
    def name(self) -> str:
        robot = ", ".join(f"{k} {v:g}" for k, v in self.robot.items()) or "nominal"
        return f"{robot}, realistic sensors seed {self.seed}" if self.sim else robot

    def velocity_step(self, control: Mapping[str, Any]) -> Trace:
        return velocity_step(control, self.robot, duration=5.0 + self.extra, sim=self.sim, seed=self.seed,
                             step_at=self.step_at)

    def yaw_rate_step(self, control: Mapping[str, Any]) -> Trace:
        return yaw_rate_step(control, self.robot, duration=4.0 + self.extra, sim=self.sim, seed=self.seed,
                             step_at=self.step_at)


REALISTIC_SEEDS = (1, 2, 3, 4, 5, 6)
REALISTIC_STEP_AT = 3.0  # [s] the estimator has learnt the gyro's bias by then (as a user waits to drive off)


def tuning_cases(sensors: bool = False) -> list[Case]:
    """The runs the gains are tuned on: the three robot variants with ideal sensors, and with `sensors` the
    nominal robot with realistic ones (config/sensors_realistic.yaml) for REALISTIC_SEEDS."""
    cases = [Case(robot, {}) for robot in robot_variants()]
    if sensors:
        real = realistic_sensors()
        cases += [Case({}, real, seed, REALISTIC_STEP_AT, REALISTIC_STEP_AT - STEP_AT) for seed in REALISTIC_SEEDS]
    return cases


def _minimise(simulate: Callable[[Case, Mapping[str, Any]], Trace], cost: Callable[[Trace], float],
              names: Sequence[str], start: Mapping[str, float], base: Mapping[str, Any],
              max_evaluations: int, sensors: bool = False) -> tuple[dict[str, float], float, int]:
    """Nelder-Mead over log gains (they stay positive) of the cost averaged over the tuning cases."""
    cases = tuning_cases(sensors)

    def objective(log_gains: np.ndarray) -> float:
        gains = {**base, **dict(zip(names, np.exp(log_gains), strict=True))}
        if any(gains[n] > high for n, high in BOUNDS.items()):
            return 1e6
        return float(np.mean([cost(simulate(case, gains)) for case in cases]))

    x0 = np.log([start[n] for n in names])
    result = scipy.optimize.minimize(objective, x0, method="Nelder-Mead",
                                     options={"maxfev": max_evaluations, "xatol": 1e-3, "fatol": 1e-6})
    return dict(zip(names, (float(v) for v in np.exp(result.x)), strict=True)), float(result.fun), int(result.nfev)


def tune(base: Mapping[str, Any], max_evaluations: int = 300, sensors: bool = False,
         start: Mapping[str, float] | None = None) -> dict[str, Any]:
    """Balance gains from `start` (default: LQR) then Nelder-Mead; yaw-rate gains by Nelder-Mead; returns gains
    and costs. `sensors`: tune on the realistic-sensor case too (tuning_cases)."""
    lqr = base.get("controller") == "lqr"
    balance_names, yaw_names = (LQR_BALANCE_WEIGHTS, LQR_YAW_WEIGHTS) if lqr else (BALANCE_GAINS, YAW_GAINS)
    if start is None:
        start = ({**{n: base[n] for n in balance_names}, "lqr.setpoint_weight": 0.5} if lqr
                 else {**lqr_balance_gains(), "velocity.setpoint_weight": 0.5, "reference_rate.velocity": 0.5})
    start_cost = float(np.mean([_balance_cost(case.velocity_step({**base, **start})) for case in tuning_cases(sensors)]))
    balance_gains, balance_cost, n1 = _minimise(Case.velocity_step, _balance_cost, balance_names, start, base,
                                                max_evaluations, sensors)
    yaw_start = {n: base[n] for n in yaw_names}
    yaw_gains, yaw_cost, n2 = _minimise(Case.yaw_rate_step, _yaw_cost, yaw_names, yaw_start,
                                        {**base, **balance_gains}, max_evaluations, sensors)
    return {
        "lqr_start": start, "start_cost": start_cost, "gains": {**balance_gains, **yaw_gains},
        "balance_cost": balance_cost, "yaw_cost": yaw_cost, "evaluations": n1 + n2,
    }
