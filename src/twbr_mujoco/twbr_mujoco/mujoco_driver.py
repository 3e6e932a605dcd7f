"""mujoco_driver: the robot simulated by MuJoCo, on the same topics as sim_node (and a real robot's driver).

    ros2 run twbr_mujoco mujoco_driver --ros-args --params-file config/mujoco_driver.yaml

The multibody model is built from `robot_file` (robot.yaml, as sim_node's physics); the stepping (lockstep
or realtime), the command guard, the sensors' noise and the world are sim_node's (`SimNode`), so the
controller, planner and world_node cannot tell the two apart but by the physics. With `mujoco.video` set
and an OpenGL backend, the run is rendered offscreen into a video when the node stops.
"""

from __future__ import annotations

from twbr_common.ros_params import run_node
from twbr_mujoco.model import MUJOCO_SPECS
from twbr_mujoco.physics import MujocoSimulator
from twbr_sim.robot_params import robot_from_file
from twbr_sim.scenario import Scenario
from twbr_sim.sim_node import SimNode
from twbr_sim.simulator import SIM_SPECS

DRIVER_SPECS = (*SIM_SPECS, *MUJOCO_SPECS)


class MujocoDriver(SimNode):
    SPECS = DRIVER_SPECS
    ENGINE = f"MuJoCo {__import__('mujoco').__version__}"

    def __init__(self) -> None:
        super().__init__("mujoco_driver")
        self.recording = None
        if self.cfg["mujoco.video"]:
            from twbr_mujoco.video import Recording

            cfg = self.cfg
            self.recording = Recording(self.sim, cfg["mujoco.video"], cfg["mujoco.video_rate"],
                                       cfg["mujoco.video_speed"], self.get_logger())

    def robot_parameters(self, cfg: dict) -> dict:
        return robot_from_file(cfg["robot_file"])

    def new_simulator(self, robot: dict, cfg: dict, scenario: Scenario | None, seed: int) -> MujocoSimulator:
        return MujocoSimulator(robot, cfg, scenario, seed)

    def state_telemetry(self) -> list[tuple]:
        if self.recording is not None:
            self.recording.capture()  # the state the telemetry describes, before the next step
        return super().state_telemetry()

    def run(self) -> None:
        try:
            super().run()
        finally:
            if self.recording is not None:
                self.recording.close()


def main(args: list[str] | None = None) -> int:
    return run_node("mujoco_driver", MujocoDriver, args)


if __name__ == "__main__":
    raise SystemExit(main())
