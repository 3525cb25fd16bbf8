"""The robots `agile deploy` drives: each one's motor order (its SDK's), its MJCF (joint limits) and the robot files
its bundles name; a LEAPP bundle read and checked against one, before anything talks to the robot."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import yaml

from agile.assets.unitree_g1_joints import G1_JOINT_ORDER
from agile.errors import AgileError


class DeployError(AgileError):
    """Input `agile deploy` / `agile sim_robot` refuse: a bundle, a robot, an interface, an option."""


G1_MOTOR_JOINTS = G1_JOINT_ORDER
"""The 29-DoF G1's motor index order (unitree_sdk2 `G1JointIndex`: legs, waist, arms), also the Menagerie MJCF's."""

T1_MOTOR_JOINTS = (
    "AAHead_yaw", "Head_pitch",
    "Left_Shoulder_Pitch", "Left_Shoulder_Roll", "Left_Elbow_Pitch", "Left_Elbow_Yaw",
    "Right_Shoulder_Pitch", "Right_Shoulder_Roll", "Right_Elbow_Pitch", "Right_Elbow_Yaw",
    "Waist",
    "Left_Hip_Pitch", "Left_Hip_Roll", "Left_Hip_Yaw", "Left_Knee_Pitch", "Left_Ankle_Pitch", "Left_Ankle_Roll",
    "Right_Hip_Pitch", "Right_Hip_Roll", "Right_Hip_Yaw", "Right_Knee_Pitch", "Right_Ankle_Pitch", "Right_Ankle_Roll",
)
"""The T1's 23 joints in the Booster SDK's `JointIndex` order (kHeadYaw 0 ... kCrankDownRight 22 = right ankle
roll), also the Menagerie MJCF's."""


@dataclass(frozen=True)
class RobotSpec:
    name: str
    motor_joints: tuple[str, ...]
    mjcf: str
    """The MJCF under the asset package's Menagerie folder."""
    model_files: tuple[str, ...]
    """The `robot_model_file` a bundle of this robot names."""
    motor_slots: int
    """Motor entries in the SDK's command message (the G1's LowCmd_ has 35 for 29 motors)."""

    def joint_limits(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper joint limits [rad] in motor order, from the MJCF."""
        import mujoco

        from agile.assets import asset_file

        model = mujoco.MjModel.from_xml_path(asset_file(self.mjcf))
        ranges = np.array([model.joint(name).range for name in self.motor_joints], dtype=np.float64)
        return ranges[:, 0].copy(), ranges[:, 1].copy()


ROBOTS = {
    "g1": RobotSpec("g1", G1_MOTOR_JOINTS, "unitree_g1/g1_mjx.xml", ("g1_mjx.xml", "g1.xml"), 35),
    "t1": RobotSpec("t1", T1_MOTOR_JOINTS, "booster_t1/t1.xml", ("t1.xml",), 23),
}


def robot_spec(name: str) -> RobotSpec:
    if name not in ROBOTS:
        raise DeployError(f"--robot: '{name}' is not a robot deploy drives; valid: {', '.join(ROBOTS)}")
    return ROBOTS[name]


# raw inputs a robot's SDK gives (joint encoders, the IMU); `root_lin_vel_b` needs a state estimator
SENSED_INPUTS = ("joint_pos", "joint_vel", "root_quat_w", "root_ang_vel_b", "command")


@dataclass(frozen=True)
class ExportedPolicy:
    """What deploy runs: a LEAPP bundle (`agile export --format leapp`), or an IO descriptor with its policy.pt or
    policy.onnx (`agile export`)."""

    path: str
    """The bundle's YAML, or the io_descriptor.yaml."""
    task: str
    robot: dict
    """The robot config: joint names, default pose, gains, limits, control_dt_s."""
    commands: dict
    inputs: tuple[str, ...]
    """The raw inputs the policy reads (SENSED_INPUTS' names)."""
    command_elements: tuple[str, ...]
    """The command input, element by element (lin_vel_x, lin_vel_y, ang_vel_z[, base_height])."""
    policy_file: str | None = None
    """policy.pt or policy.onnx beside an IO descriptor; None for a bundle."""

    @property
    def control_dt_s(self) -> float:
        return float(self.robot["control_dt_s"])

    @property
    def command_size(self) -> int:
        return len(self.command_elements)


def _check_robot(flag: str, path: str, task: str, robot_cfg: dict, inputs, robot: RobotSpec) -> None:
    """What a bundle and a descriptor are both checked for: the robot file and joints, sensed inputs only, a rate."""
    if robot_cfg.get("robot_model_file") not in robot.model_files:
        raise DeployError(f"{flag}: {path} is a policy of {task} for robot file '{robot_cfg.get('robot_model_file')}'"
                          f", not the {robot.name}'s ({', '.join(robot.model_files)}): pass its robot's --robot")
    if sorted(robot_cfg["joint_names"]) != sorted(robot.motor_joints):
        missing = sorted(set(robot.motor_joints) - set(robot_cfg["joint_names"]))
        raise DeployError(f"{flag}: {path}: its joints are not the {robot.name}'s {len(robot.motor_joints)} motors "
                          f"(missing: {missing})")
    unsensed = [name for name in inputs if name not in SENSED_INPUTS]
    if unsensed:
        raise DeployError(f"{flag}: {path} reads {unsensed}, which the robot's SDK does not measure; a policy for "
                          f"deploy reads only {', '.join(SENSED_INPUTS)}")
    dt = robot_cfg.get("control_dt_s")
    if not isinstance(dt, (int, float)) or not math.isfinite(dt) or dt <= 0:
        raise DeployError(f"{flag}: {path}: its robot config has no positive control_dt_s (found {dt!r})")


def read_deploy_bundle(path: str, robot: RobotSpec) -> ExportedPolicy:
    """The LEAPP bundle at `path` (its YAML, `agile export --format leapp`), checked to drive `robot`: its robot
    file, its joints, and raw inputs the robot's sensors give. Raises DeployError naming what is wrong."""
    file = Path(path)
    if not file.is_file():
        raise DeployError(f"--bundle: no file {path} (give the bundle's <Task>.yaml written by agile export "
                          f"--format leapp)")
    try:
        bundle = yaml.safe_load(file.read_text())
        configs = bundle["pipeline"]["configs"]
        task, robot_cfg = configs["task"], configs["robot"]
        inputs = tuple(bundle["pipeline"]["inputs"][task])
        commands = configs["commands"]
        model = bundle["models"][task]
        onnx = file.parent / model["parameters"]["model_path"]
        command_elements = tuple(next((i["element_names"][-1] for i in model["inputs"] if i["name"] == "command"),
                                      ()))
    except (yaml.YAMLError, KeyError, TypeError, UnicodeDecodeError):
        raise DeployError(f"--bundle: {path} is not a LEAPP bundle written by agile export --format leapp (no "
                          f"pipeline configs with a task and a robot)") from None
    _check_robot("--bundle", path, task, robot_cfg, inputs, robot)
    if not onnx.is_file():
        raise DeployError(f"--bundle: {path}: its graph {onnx.name} is not next to it (a bundle is the folder agile "
                          f"export --format leapp writes: the YAML, the ONNX file, the initial values)")
    return ExportedPolicy(str(file), task, robot_cfg, commands, inputs, command_elements)


ROBOT_CONFIG_KEYS = ("robot_model_file", "joint_names", "default_joint_pos", "stiffness", "damping",
                     "velocity_limit", "control_dt_s")
"""The IO descriptor's keys deploy reads as the robot config (a bundle's pipeline config has the same)."""


def read_deploy_descriptor(io_path: str, policy_path: str, robot: RobotSpec) -> ExportedPolicy:
    """The IO descriptor at `io_path` and its policy file (`agile export`), checked to drive `robot` as a bundle
    is, and to set joint position targets. Raises DeployError naming what is wrong."""
    from agile.deploy.mujoco_policy import Observer
    from agile.rl_env.io_descriptor_file import COMMAND_ELEMENTS, IO_DESCRIPTOR_VERSION

    if not Path(io_path).is_file():
        raise DeployError(f"--io: no file {io_path} (give the io_descriptor.yaml written by agile export)")
    if not Path(policy_path).is_file() or Path(policy_path).suffix not in (".pt", ".onnx"):
        raise DeployError(f"--policy: {policy_path} is not a policy.pt or policy.onnx file (agile export writes both "
                          f"beside the IO descriptor)")
    try:
        descriptor = yaml.safe_load(Path(io_path).read_text())
        version, task = descriptor.get("version"), descriptor["task"]
        robot_cfg = {key: descriptor[key] for key in ROBOT_CONFIG_KEYS}
        commands = descriptor["commands"]
        actions = descriptor["actions"]
    except (yaml.YAMLError, KeyError, TypeError, AttributeError, UnicodeDecodeError):
        raise DeployError(f"--io: {io_path} is not an IO descriptor written by agile export (no task, robot config, "
                          f"commands and actions)") from None
    if version != IO_DESCRIPTOR_VERSION:
        raise DeployError(f"--io: {io_path} is an IO descriptor of version {version}; deploy reads version "
                          f"{IO_DESCRIPTOR_VERSION}: export the policy again with agile export")
    not_targets = [f"{a['name']} ({a['type']})" for a in actions if "offset" not in a]
    if not_targets:
        raise DeployError(f"--io: {io_path}: deploy runs policies whose actions are joint position targets; these "
                          f"action terms are not: {not_targets}")
    try:
        inputs = Observer(descriptor).inputs
    except ValueError as err:
        raise DeployError(f"--io: {io_path}: {err}") from None
    _check_robot("--io", io_path, task, robot_cfg, inputs, robot)
    command_dim = next((t["dim"] for g in descriptor["observation_groups"] for t in descriptor["observations"][g]
                        if t["func"] == "generated_commands"), 0)
    return ExportedPolicy(io_path, task, robot_cfg, commands, inputs, COMMAND_ELEMENTS[:command_dim],
                          policy_file=policy_path)
