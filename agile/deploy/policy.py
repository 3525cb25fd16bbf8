"""A LEAPP bundle fed from a robot's state: the state in the SDK's motor order in, joint targets and gains in motor
order out. What the bundle reads comes from the robot's sensors only (joint encoders, the IMU) and the command."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from agile.deploy.robots import ExportedPolicy, RobotSpec
from agile.deploy.mujoco_robot import rotate_inverse


@dataclass
class RobotState:
    """One state message, in motor order."""

    q: np.ndarray
    dq: np.ndarray
    tau: np.ndarray
    quat_wxyz: np.ndarray
    """The IMU's orientation (w, x, y, z), world to body."""
    gyro_radps: np.ndarray
    """The IMU's angular velocity in the body frame."""
    tick: int
    """The robot's own counter: a state whose tick does not move is frozen."""
    received_s: float
    """time.monotonic() when the message arrived."""
    remote: bytes = field(default=b"")
    """The wireless remote's raw bytes (the G1's `wireless_remote`), empty where the SDK gives none."""

    def projected_gravity(self) -> np.ndarray:
        return rotate_inverse(self.quat_wxyz, np.array([0.0, 0.0, -1.0]))


def quat_from_rpy(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """(w, x, y, z) of the intrinsic z-y-x rotation (yaw, then pitch, then roll): an IMU's roll, pitch, yaw."""
    cr, sr = np.cos(roll / 2), np.sin(roll / 2)
    cp, sp = np.cos(pitch / 2), np.sin(pitch / 2)
    cy, sy = np.cos(yaw / 2), np.sin(yaw / 2)
    return np.array([cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy,
                     cr * sp * cy + sr * cp * sy, cr * cp * sy - sr * sp * cy])


class DeployPolicy:
    """An exported policy on RobotState: a LEAPP bundle (`BundleRuntime`, LEAPP's runtime) or an IO descriptor with
    its policy file (`DescriptorRuntime`). The joints the policy does not drive are held at their default positions
    with the robot config's gains; the driven ones get the policy's targets, and a bundle's gains where it outputs
    them."""

    def __init__(self, exported: ExportedPolicy, robot: RobotSpec):
        cfg = exported.robot
        motor = {name: i for i, name in enumerate(robot.motor_joints)}
        if exported.policy_file is None:
            from agile.deploy.leapp_runtime import BundleRuntime

            self.runtime = BundleRuntime(exported.path)
            self.runtime.check_joints(list(cfg["joint_names"]))
        else:
            import yaml

            from agile.deploy.leapp_runtime import control_loop_inference_session
            from agile.deploy.mujoco_policy import DescriptorRuntime

            descriptor = yaml.safe_load(Path(exported.path).read_text())
            self.runtime = DescriptorRuntime(descriptor, exported.policy_file, onnx_session_factory=control_loop_inference_session)
        self.from_motor = np.array([motor[n] for n in cfg["joint_names"]])  # policy joint i <- motor from_motor[i]
        self.target_ids = np.array([motor[n] for n in self.runtime.target_joints])
        self.default_q = np.zeros(len(robot.motor_joints))
        self.kp = np.zeros(len(robot.motor_joints))
        self.kd = np.zeros(len(robot.motor_joints))
        self.default_q[self.from_motor] = cfg["default_joint_pos"]
        self.kp[self.from_motor] = cfg["stiffness"]
        self.kd[self.from_motor] = cfg["damping"]

    def reset(self) -> None:
        self.runtime.reset()

    def raw_inputs(self, state: RobotState, command: np.ndarray) -> dict:
        read = {"joint_pos": lambda: state.q[self.from_motor], "joint_vel": lambda: state.dq[self.from_motor],
                "root_quat_w": lambda: state.quat_wxyz[[1, 2, 3, 0]], "root_ang_vel_b": lambda: state.gyro_radps,
                "command": lambda: command}
        return {name: read[name]() for name in self.runtime.inputs}

    def __call__(self, state: RobotState, command: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Targets [rad], kp, kd, each in motor order."""
        targets, policy_kp, policy_kd = self.runtime.targets_and_gains(self.raw_inputs(state, command))
        q, kp, kd = self.default_q.copy(), self.kp.copy(), self.kd.copy()
        q[self.target_ids] = targets
        if policy_kp is not None:
            kp[self.target_ids] = policy_kp
        if policy_kd is not None:
            kd[self.target_ids] = policy_kd
        return q, kp, kd
