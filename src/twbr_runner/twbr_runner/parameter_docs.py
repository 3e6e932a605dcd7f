"""docs/parameters.md, generated from the parameter specs the nodes declare, so the docs cannot drift.

`python -m twbr_runner.parameter_docs docs/parameters.md` rewrites it; test/test_docs.py fails when the
file differs from what this renders.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path

from twbr_common.guard import INPUT_SPECS
from twbr_common.node_process import PROCESS_SPECS
from twbr_common.params import ParamSpec, markdown_table
from twbr_control.controller_params import CONTROL_SPECS
from twbr_control.controller_params import NODE_SPECS as CONTROLLER_NODE_SPECS
from twbr_mujoco.model import MUJOCO_SPECS
from twbr_planner.planner_params import APF_SPECS
from twbr_planner.planner_params import NODE_SPECS as PLANNER_NODE_SPECS
from twbr_sim.command_player import PLAYER_SPECS
from twbr_sim.robot_params import ROBOT_SPECS
from twbr_sim.simulator import SIM_SPECS
from twbr_sim.torque_driver import DRIVER_SPECS
from twbr_sim.world_node import WORLD_SPECS
from twbr_tracker.tracker_node import INPUT_SPECS as TRACKER_INPUT_SPECS
from twbr_tracker.tracker_node import NODE_SPECS as TRACKER_NODE_SPECS
from twbr_view.viewer_node import VIEWER_SPECS  # (twbr_view depends on twbr_runner: not declared back)

INTRO = """\
# twbr — parameters

Generated from the specs the nodes declare (`python -m twbr_runner.parameter_docs docs/parameters.md`);
`test/test_docs.py` fails when this file and the code disagree.

Every parameter is declared with a description, unit and valid range (`ros2 param describe`); a bad
value, a wrong type or an inconsistent combination stops the node at start-up with exit code 2 and one
`FATAL` line naming the parameter and its valid range, e.g.
`refusing to start: invalid parameter 'wheel_radius' = -0.1: must be (0, 5] m`.

The files in `config/` (package `twbr_config`, installed to `share/twbr_config/config`) are keyed
`/**/<node>`, so they apply in any namespace (`-r __ns:=/robot1`). What rcl would ignore silently stops
the node the same way: a parameter the node does not declare (`unknown parameter 'pitch.kpp' ... did you
mean 'pitch.kp'?`, in a file or after `-p`), a section keyed close to one of our node names, a file with
no section for the node, a section without `ros__parameters`, a missing file or a YAML error.
`ros2 param dump` / `get` work on every node. Parameters marked "changeable at runtime" take
`ros2 param set` (or rqt_reconfigure) while the node runs: checked by the same ranges and consistency
rules, refused with the reason otherwise, applied between two steps, logged and counted in
`parameter_revision` of `controller_state` / `planner_state`; the others are read-only, and
`ros2 param describe` says why. Beyond its range, a planner's or controller's setting must be one the
robot can meet (`robot_file`, the installed robot.yaml by default; `twbr_sim.robot_limits`): speeds up to
the motors' no-load speed at the wheel, accelerations up to what the robot sustains within its fall limit
and torque, a torque limit at least what holds the body at the largest pitch reference. The refusal names
the bound and where it comes from, at start-up and at runtime (a necessary condition, not a tuning: a
torque limit just above the holding torque still leaves little to recover with).
"""

# (heading, specs, a note under the table or "")
SECTIONS: tuple[tuple[str, Sequence[ParamSpec], str], ...] = (
    (
        "Every node (`sim_node`, `world_node`, `controller_node`, `planner_node`, `command_player`, `torque_driver`,"
        " `mujoco_driver`, `viewer`, `tracker_node`)",
        PROCESS_SPECS,
        "A CPU the process may not use (outside its `taskset` or container) is refused at start-up. Once built,\n"
        "every node also freezes its start-up heap (`gc.freeze`), so a full garbage collection in the loop walks\n"
        "only what the loop made (benchmarks/README.md has the stall it prevents).",
    ),
    ("Robot (`config/robot.yaml`, node `sim_node`; defaults of docs/dynamics.md)", ROBOT_SPECS, ""),
    ("Simulator (`config/sim.yaml`, node `sim_node`)", SIM_SPECS, ""),
    ("`world_node` (`config/world.yaml`)", (*WORLD_SPECS, *INPUT_SPECS), ""),
    ("`controller_node` (`config/controller.yaml`)", (*CONTROL_SPECS, *CONTROLLER_NODE_SPECS, *INPUT_SPECS), ""),
    ("`planner_node` (`config/planner.yaml`)", (*APF_SPECS, *PLANNER_NODE_SPECS, *INPUT_SPECS), ""),
    ("`command_player` (`config/command_player.yaml`)", PLAYER_SPECS, ""),
    ("`torque_driver`", DRIVER_SPECS, ""),
    ("`mujoco_driver` (`config/mujoco_driver.yaml`)", MUJOCO_SPECS,
     "Besides these, `mujoco_driver` declares every simulator parameter above (the robot's own come from\n"
     "`robot_file`, not from parameters). `traction.friction` is there the friction coefficient of MuJoCo's\n"
     "wheel-ground contact: it decides slip instead of only reporting it."),
    ("`tracker_node` (package `twbr_tracker`, `config/tracker.yaml`)", (*TRACKER_NODE_SPECS, *TRACKER_INPUT_SPECS),
     "`axle_height` and `lidar_height` place the scanner as the robot carries it (sim_node's `wheel_radius`\n"
     "and `lidar.height`)."),
    ("`viewer` (package `twbr_view`)", VIEWER_SPECS,
     "Both servers listen on 127.0.0.1 only. Ports 0 pick free ones; the node prints the URL to open."),
)


# Every parameter each node declares besides rclpy's own: what its section(s) above document.
NODE_PARAMETERS: dict[str, tuple[ParamSpec, ...]] = {
    "sim_node": (*PROCESS_SPECS, *ROBOT_SPECS, *SIM_SPECS),
    "world_node": (*PROCESS_SPECS, *WORLD_SPECS, *INPUT_SPECS),
    "controller_node": (*PROCESS_SPECS, *CONTROL_SPECS, *CONTROLLER_NODE_SPECS, *INPUT_SPECS),
    "planner_node": (*PROCESS_SPECS, *APF_SPECS, *PLANNER_NODE_SPECS, *INPUT_SPECS),
    "command_player": (*PROCESS_SPECS, *PLAYER_SPECS),
    "torque_driver": (*PROCESS_SPECS, *DRIVER_SPECS),
    "mujoco_driver": (*PROCESS_SPECS, *SIM_SPECS, *MUJOCO_SPECS),
    "viewer": (*PROCESS_SPECS, *VIEWER_SPECS),
    "tracker_node": (*PROCESS_SPECS, *TRACKER_NODE_SPECS, *TRACKER_INPUT_SPECS),
}
RCLPY_PARAMETERS = ("use_sim_time", "start_type_description_service")


def render() -> str:
    parts = [INTRO]
    for heading, specs, note in SECTIONS:
        parts.append(f"## {heading}\n\n{markdown_table(specs)}\n")
        if note:
            parts.append(note + "\n")
    return "\n".join(parts)


def main(argv: Sequence[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else list(argv)
    text = render()
    if not args:
        sys.stdout.write(text)
    else:
        Path(args[0]).write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
