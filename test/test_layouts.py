"""Each flat vector the kernels share is laid out by the names of the spec it carries (no slot kept in sync
by hand): what a spec names reaches the slot of that name, and nothing else does."""

from __future__ import annotations

from dataclasses import fields

import numpy as np

from twbr_common.params import defaults
from twbr_control import cascade, pid
from twbr_control.controller_params import CONTROL_SPECS
from twbr_planner import apf
from twbr_planner.planner import PlannerOutput
from twbr_planner.planner_params import APF_SPECS
from twbr_sim import dynamics, robot_params
from twbr_sim.robot_params import ROBOT_SPECS


def test_robot_layout_holds_every_robot_parameter_by_name_then_the_derived_constants():
    # A distinct value per parameter comes back from the slot of its name, and the derived constants follow.
    distinct = {s.name: 0.01 * (i + 1) for i, s in enumerate(ROBOT_SPECS) if s.kind is float}
    p = robot_params.robot_params(distinct)
    for name, value in distinct.items():
        assert p[robot_params.ROBOT_LAYOUT[name]] == value, name
    p = robot_params.robot_params({"wheel_radius": 0.123, "fall_limit": 0.7})
    assert p[robot_params.P_R] == 0.123 and p[robot_params.P_FALL] == 0.7
    assert p[robot_params.D_INV_R] == 1.0 / 0.123
    assert len(p) == len(robot_params.ROBOT_LAYOUT)


def test_controller_settings_take_each_parameter_from_its_spec_name():
    cfg = defaults(CONTROL_SPECS)
    scalars = [n for n in cascade.SETTINGS_LAYOUT.names if n not in ("velocity", "pitch", "yaw_rate", "lqr")]
    spec_names = {s.name for s in CONTROL_SPECS}
    # the derived slots: 1/rate, and `controller` as a number (its LQR gains are the `lqr` block)
    assert set(scalars) - spec_names == {"period", "control_law"}
    # A distinct value per parameter lands in its own slot.
    distinct = {n: 0.01 * (i + 1) for i, n in enumerate(scalars) if n not in ("period", "control_law")}
    c = cascade.settings_vector({**cfg, **distinct, "rate": 250.0})
    for name, value in distinct.items():
        assert c[cascade.SETTINGS_LAYOUT[name]] == value, name
    assert c[cascade.C_PERIOD] == 1.0 / 250.0
    pitch = c[cascade.SETTINGS_LAYOUT.block("pitch")]
    assert pitch[pid.G_KP] == cfg["pitch.kp"] and pitch[pid.G_KD] == cfg["pitch.kd"]


def test_pid_gains_layout_is_the_dataclass_fields():
    assert pid.GAINS_LAYOUT.names == tuple(f.name for f in fields(pid.PidGains))
    v = pid.PidGains(1.0, 2.0, 3.0, 4.0, 5.0, 0.5).vector()
    assert v[pid.G_LIMIT] == 5.0 and v[pid.G_WEIGHT] == 0.5


def test_planner_settings_are_the_apf_specs_by_name():
    g = {s.name: float(i + 1) for i, s in enumerate(APF_SPECS)}
    # every A_ index the kernels read is the slot of the parameter it is named after
    indices = {name[2:].lower(): getattr(apf, name) for name in dir(apf) if name.startswith("A_")}
    assert set(indices) == set(g)
    a = apf.settings_vector({**g, "method": "robust"})
    for name, index in indices.items():
        assert name == "method" or a[index] == g[name], name
    for method, code in (("paper", apf.PAPER), ("robust", apf.ROBUST)):
        a = apf.settings_vector({**g, "method": method})
        assert a[apf.A_METHOD] == code
        assert a[apf.A_RHO_O] == g["rho_o"] and a[apf.A_STUCK_PROGRESS] == g["stuck_progress"]
        assert a[apf.A_REPULSION_RANGE] == g["repulsion_range"] and a[apf.A_SAFETY_LOOKAHEAD] == g["safety_lookahead"]
        assert sorted(a[[i for i, s in enumerate(APF_SPECS) if s.name != "method"]]) == sorted(
            v for k, v in g.items() if k != "method")  # every other parameter in a slot of its own


def test_planner_outputs_are_named_like_planner_output():
    out_fields = {f.name for f in fields(PlannerOutput)}
    for name in ("velocity_cmd", "yaw_rate_cmd", "distance_to_target", "nearest_obstacle_distance", "mode"):
        assert name in apf.OUTPUT_LAYOUT.names and name in out_fields


def test_state_layout_is_the_state_names():
    s = dynamics.initial_state(1.0, 2.0, 0.3, 0.01)
    assert (s[dynamics.S_XC], s[dynamics.S_YC], s[dynamics.S_PSI], s[dynamics.S_TH]) == (1.0, 2.0, 0.3, 0.01)
    assert s.shape == (len(dynamics.STATE_LAYOUT),) and np.count_nonzero(s) == 4


def test_lqr_gains_fill_their_block_only_for_the_lqr_law():
    cfg = defaults(CONTROL_SPECS)
    assert not cascade.settings_vector(cfg)[cascade.SETTINGS_LAYOUT.block("lqr")].any()
    c = cascade.settings_vector({**cfg, "controller": "lqr"})
    assert c[cascade.C_CONTROLLER] == 1.0
    assert np.all(c[cascade.SETTINGS_LAYOUT.block("lqr")] != 0.0)


def test_each_index_prefix_names_one_layout_in_the_project():
    """`R_LAST_V` is the planner's memory and nothing else: a prefix shared by two layouts (the IMU's reading
    was R_ too) lets an index of one be read into the other without any error."""
    import re
    from pathlib import Path

    owners: dict[str, set[tuple[str, str]]] = {}
    for path in sorted((Path(__file__).parents[1] / "src").glob("*/*/*.py")):
        for prefix, layout in re.findall(r"^([A-Z]{1,3})_[A-Z0-9_]+ = ([A-Z_]*LAYOUT)\[", path.read_text(), re.M):
            owners.setdefault(prefix, set()).add((path.name, layout))
    assert len(owners) > 20  # the scan finds the layouts
    assert {p: o for p, o in owners.items() if len(o) > 1} == {}
