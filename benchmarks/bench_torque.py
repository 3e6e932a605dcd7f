"""Torque smoothness: what the motors get in the paper's dynamic-obstacle run, before and after the
controller shapes its references, and the 0.1 m/s step's roll-back.

Figures per wheel: the largest sample-to-sample change of the commanded torque [N·m] and the torque's power
above 10 Hz [(N·m)^2, the mean square of the part of the signal above 10 Hz]. "before" is the controller with
the reference shaping off and the gains of config/controller.yaml before issue 17 (set below); "held" is today's
controller with each 20 Hz command of v and omega held as it comes (reference_hold.* 0); "v stepped" holds
only v's commands as they come (issue 35: the 20 Hz sawtooth while the planner accelerates); "catch-up 1" is
the hold as first shipped (v_ref and omega_ref continued along the planner's slope, the gap to each command
closed within one interval: where the planner reverses its yaw acceleration the line bends twice as hard);
"no jerk" closes the gap over reference_hold.catch_up 3 intervals, the shaped references' slopes free to
bend at once (as shipped until issue 35's jerk limits); "shipped" is today's defaults (that, with the slopes
changing by at most reference_jerk.yaw_rate 40 rad/s^3 and reference_jerk.velocity 2 m/s^3); "smoothed"
is that averaged over 0.1 s while the planner ramps (reference_smoothing.*, off by default: the bends where
its yaw acceleration reverses no longer jolt the torques, but the steering lags); "yaw ramp"
instead limits omega_ref's rate to the planner's own max_yaw_acceleration, which spreads each command step
over a period (and lags the planner by it). Runs are the headless closed loop of the nodes' cores (planner
included, paper's method as the scenario pins): exactly reproducible.

    tools/run.sh python benchmarks/bench_torque.py
"""

from __future__ import annotations

import sys

import numpy as np
from results_file import RESULTS, write_results

from twbr_batch.closed_loop import PlannerReference, run_closed_loop, scenario_reference
from twbr_batch.response import step_response
from twbr_sim.scenario import load_scenario
from twbr_sim.scenario_files import find_scenario

BEFORE = {  # the shipped controller before issue 17 (commit 29e32f1)
    "reference_rate.velocity": 0.0, "reference_rate.yaw_rate": 0.0, "reference_hold.yaw_rate": 0.0,
    "velocity.kp": 0.4529, "velocity.ki": 0.6938, "velocity.kd": 0.0, "velocity.setpoint_weight": 0.494,
    "velocity.derivative_filter": 0.02, "pitch.kp": 42.52, "pitch.ki": 0.0, "pitch.kd": 8.793,
    "pitch.derivative_filter": 0.005, "yaw_rate.kp": 3.429, "yaw_rate.ki": 0.9293,
    "reference_jerk.yaw_rate": 0.0, "reference_jerk.velocity": 0.0,
}
NO_JERK = {"reference_jerk.yaw_rate": 0.0, "reference_jerk.velocity": 0.0}
HELD = {**NO_JERK, "reference_hold.yaw_rate": 0.0, "reference_hold.velocity": 0.0}
V_STEPPED = {**NO_JERK, "reference_hold.velocity": 0.0}
CATCH_UP_1 = {**NO_JERK, "reference_hold.catch_up": 1.0}
SMOOTHED = {**NO_JERK, "reference_smoothing.yaw_rate": 0.1, "reference_smoothing.velocity": 0.1}
RAMP = {**NO_JERK, "reference_hold.yaw_rate": 0.0, "reference_rate.yaw_rate": 1.0}  # the planner's max_yaw_acceleration
PLANNER_HZ = 20.0
LINE_WINDOW = (15.0, 20.0)  # [s] of make demo's run: the planner accelerating away from the start
CUTOFF_HZ = 10.0


def high_frequency_power(signal: np.ndarray, rate: float, cutoff: float = CUTOFF_HZ) -> float:
    """Mean square of the part of `signal` above `cutoff` [Hz] (Parseval on the FFT)."""
    spectrum = np.fft.rfft(signal - signal.mean())
    freqs = np.fft.rfftfreq(len(signal), 1.0 / rate)
    power = np.abs(spectrum) ** 2
    power[1:-1] *= 2.0  # one-sided
    return float(power[freqs > cutoff].sum() / len(signal) ** 2)


def line_amplitude(signal: np.ndarray, rate: float, frequency: float) -> float:
    """[N·m] the amplitude of `signal`'s spectral line nearest `frequency` [Hz]."""
    spectrum = np.abs(np.fft.rfft(signal - signal.mean())) * 2.0 / len(signal)
    return float(spectrum[np.argmin(np.abs(np.fft.rfftfreq(len(signal), 1.0 / rate) - frequency))])


def torque_figures(control: dict) -> dict:
    sc = load_scenario(find_scenario("dynamic_obstacles"))
    trace = run_closed_loop(sc.duration, PlannerReference(), control, scenario=sc, seed=sc.seed,
                            stop=lambda sim: sim.assess().target_reached)
    rate = 1.0 / float(np.median(np.diff(trace.t)))
    out = {"sim_time_s": float(trace.t[-1])}
    for wheel in ("left", "right"):
        torque = trace[f"{wheel}_torque"]
        out[f"{wheel}_max_step_nm"] = float(np.abs(np.diff(torque)).max())
        out[f"{wheel}_power_above_10hz"] = high_frequency_power(torque, rate)
        window = (trace.t >= LINE_WINDOW[0]) & (trace.t < LINE_WINDOW[1])
        out[f"{wheel}_line_20hz_nm"] = line_amplitude(torque[window], rate, PLANNER_HZ)
    step = load_scenario(find_scenario("step"))
    s = run_closed_loop(step.duration, scenario_reference(step), control, scenario=step)
    r = step_response(s.t, s.velocity_true, s["velocity_ref"])
    out.update(step_rollback_pct=100.0 * r.undershoot / abs(r.final - r.initial), step_settle_s=r.settle_time_s,
               step_overshoot_pct=r.overshoot_pct)
    return out


def main() -> int:
    rows = {"before": torque_figures(BEFORE), "held": torque_figures(HELD), "v stepped": torque_figures(V_STEPPED),
            "catch-up 1": torque_figures(CATCH_UP_1), "no jerk": torque_figures(NO_JERK), "shipped": torque_figures({}),
            "smoothed": torque_figures(SMOOTHED), "yaw ramp": torque_figures(RAMP)}
    print(f"{'':10} {'max step L/R N·m':>18} {'power >10 Hz L/R (N·m)²':>26} {'20 Hz line 15-20 s L/R N·m':>27}"
          f" {'step roll-back %':>17} {'settle s':>9} {'overshoot %':>12} {'run s':>6}")
    for name, r in rows.items():
        print(f"{name:10} {r['left_max_step_nm']:8.4f}/{r['right_max_step_nm']:.4f} "
              f"{r['left_power_above_10hz']:12.3e}/{r['right_power_above_10hz']:.3e}"
              f" {r['left_line_20hz_nm']:13.4f}/{r['right_line_20hz_nm']:.4f} {r['step_rollback_pct']:17.1f}"
              f" {r['step_settle_s']:9.3f} {r['step_overshoot_pct']:12.2f} {r['sim_time_s']:6.2f}")
    write_results(RESULTS / "bench_torque.json", {"rows": rows})
    return 0


if __name__ == "__main__":
    sys.exit(main())
