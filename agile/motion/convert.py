"""Retargeted motion CSV -> motion file (`agile.motion.motion_file`): joint remapping by name, resampling to the
control rate, velocities by finite differences, body poses and velocities by the robot model's forward kinematics.

The CSV layout is that of the public "AMASS retargeted for G1" data: one row per frame, no header, columns
root position x, y, z [m], root quaternion x, y, z, w, then one angle [rad] per joint in the CSV's joint order
(`G1_CSV_JOINT_NAMES` for that data), at a fixed frame rate given by the caller.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import newton
import numpy as np
from scipy.interpolate import CubicSpline
from scipy.spatial.transform import Rotation, RotationSpline

from agile.motion.motion_file import MotionData
from agile.assets.unitree_g1_joints import G1_JOINT_ORDER
from agile.sim import ArticulationCfg
from agile.sim.entities.model_import import build_articulation

G1_CSV_JOINT_NAMES = list(G1_JOINT_ORDER)
"""Joint order of the public retargeted G1 CSVs (the 29-DoF G1 URDF's order)."""
ROOT_COLUMNS = 7  # position (3), quaternion xyzw (4)


@dataclass
class RootAndJoints:
    """A motion as generalised coordinates: root pose and joint angles per frame, at `fps`."""

    fps: float
    joint_names: list[str]
    root_pos_w: np.ndarray  # (T, 3) [m]
    root_quat_w: np.ndarray  # (T, 4) xyzw
    joint_pos: np.ndarray  # (T, J) [rad]


def read_motion_csv(path: str | Path, fps: float, joint_names: list[str] = G1_CSV_JOINT_NAMES) -> RootAndJoints:
    """Read a CSV in the public retargeted layout whose joint columns follow `joint_names`."""
    rows = np.loadtxt(path, delimiter=",", ndmin=2)
    expected = ROOT_COLUMNS + len(joint_names)
    if rows.shape[1] != expected:
        raise ValueError(f"'{path}': {rows.shape[1]} columns; the layout is root position (3), root quaternion "
                         f"xyzw (4) and {len(joint_names)} joint angles = {expected} columns")
    quat = rows[:, 3:7] / np.linalg.norm(rows[:, 3:7], axis=1, keepdims=True)
    return RootAndJoints(fps=float(fps), joint_names=list(joint_names), root_pos_w=rows[:, :3], root_quat_w=quat,
                         joint_pos=rows[:, ROOT_COLUMNS:])


def write_motion_csv(path: str | Path, motion: RootAndJoints) -> None:
    """Write `motion` in the public retargeted layout (joint columns in `motion.joint_names` order)."""
    rows = np.concatenate([motion.root_pos_w, motion.root_quat_w, motion.joint_pos], axis=1)
    Path(path).parent.mkdir(parents=True, exist_ok=True)
    np.savetxt(path, rows, delimiter=",", fmt="%.6f")


def remap_joints(motion: RootAndJoints, robot_joint_names: list[str]) -> RootAndJoints:
    """The motion with its joint columns in the robot's joint order (matched by name)."""
    missing = [n for n in robot_joint_names if n not in motion.joint_names]
    if missing:
        raise ValueError(f"the motion's joint names lack the robot's joints {missing}. "
                         f"Motion joints: {motion.joint_names}")
    columns = [motion.joint_names.index(n) for n in robot_joint_names]
    return RootAndJoints(motion.fps, list(robot_joint_names), motion.root_pos_w, motion.root_quat_w,
                         motion.joint_pos[:, columns])


def resample(motion: RootAndJoints, fps: float) -> RootAndJoints:
    """The motion at `fps` over the same duration: cubic splines through positions, angles and the root
    orientation (smooth velocities; the last frame is the last one the duration holds)."""
    times = np.arange(motion.joint_pos.shape[0]) / motion.fps
    count = int(np.floor(times[-1] * fps + 1e-9)) + 1
    new_times = np.arange(count) / fps
    root_pos = CubicSpline(times, motion.root_pos_w, axis=0)(new_times)
    joint_pos = CubicSpline(times, motion.joint_pos, axis=0)(new_times)
    root_quat = RotationSpline(times, Rotation.from_quat(motion.root_quat_w))(new_times).as_quat()
    return RootAndJoints(float(fps), motion.joint_names, root_pos, root_quat, joint_pos)


def finite_difference(values: np.ndarray, dt_s: float) -> np.ndarray:
    """d(values)/dt along the frames: central differences inside, one-sided at both ends."""
    return np.gradient(values, dt_s, axis=0)


def angular_velocity_w(quat_xyzw: np.ndarray, dt_s: float) -> np.ndarray:
    """World-frame angular velocity [rad/s] of an orientation sequence, by central differences of rotations
    (the rotation from frame t-1 to t+1 over 2·dt; one-sided at both ends)."""
    rotations = Rotation.from_quat(quat_xyzw)
    ahead = np.r_[1:len(rotations), len(rotations) - 1]
    behind = np.r_[0, 0:len(rotations) - 1]
    steps = (ahead - behind) * dt_s
    return (rotations[ahead] * rotations[behind].inv()).as_rotvec() / steps[:, None]


class RobotKinematics:
    """The robot model of an `ArticulationCfg` (the task's robot, as the simulator builds it), for forward
    kinematics of whole motions on the CPU."""

    def __init__(self, robot_cfg: ArticulationCfg):
        builder, self.joint_names, self.body_names = build_articulation(robot_cfg, gravity_mps2=-9.81)
        self.model = builder.finalize(device="cpu")
        self.state = self.model.state()
        if self.model.joint_coord_count != ROOT_COLUMNS + len(self.joint_names):
            raise ValueError("forward kinematics of motions needs a floating-base robot with hinge joints")
        self.root_com_b = self.model.body_com.numpy()[0].astype(np.float64)

    def body_states(self, root_pos_w, root_quat_w, root_lin_vel_w, root_ang_vel_w, joint_pos, joint_vel):
        """Body poses (T, B, 7: position, quaternion xyzw) and velocities (T, B, 6: COM linear, angular; world
        frame) of every frame; `root_lin_vel_w` is the velocity of the root frame's origin."""
        frames = joint_pos.shape[0]
        # the free joint's velocity is that of the root body's centre of mass (Newton's convention)
        root_com_w = Rotation.from_quat(root_quat_w).apply(self.root_com_b)
        root_com_vel_w = root_lin_vel_w + np.cross(root_ang_vel_w, root_com_w)
        joint_q = np.concatenate([root_pos_w, root_quat_w, joint_pos], axis=1).astype(np.float32)
        joint_qd = np.concatenate([root_com_vel_w, root_ang_vel_w, joint_vel], axis=1).astype(np.float32)
        poses = np.zeros((frames, self.model.body_count, 7), dtype=np.float32)
        velocities = np.zeros((frames, self.model.body_count, 6), dtype=np.float32)
        for t in range(frames):
            self.state.joint_q.assign(joint_q[t])
            self.state.joint_qd.assign(joint_qd[t])
            newton.eval_fk(self.model, self.state.joint_q, self.state.joint_qd, self.state)
            poses[t] = self.state.body_q.numpy()
            velocities[t] = self.state.body_qd.numpy()
        return poses, velocities


def motion_from_coordinates(motion: RootAndJoints, kinematics: RobotKinematics) -> MotionData:
    """The motion file's content of a motion already at its final rate and in the robot's joint order."""
    if motion.joint_names != kinematics.joint_names:
        raise ValueError(f"the motion's joints {motion.joint_names} are not in the robot's order "
                         f"{kinematics.joint_names}: remap_joints first")
    dt_s = 1.0 / motion.fps
    joint_vel = finite_difference(motion.joint_pos, dt_s)
    root_lin_vel_w = finite_difference(motion.root_pos_w, dt_s)
    root_ang_vel_w = angular_velocity_w(motion.root_quat_w, dt_s)
    poses, velocities = kinematics.body_states(motion.root_pos_w, motion.root_quat_w, root_lin_vel_w,
                                               root_ang_vel_w, motion.joint_pos, joint_vel)
    return MotionData(fps=motion.fps, joint_names=list(kinematics.joint_names), body_names=list(kinematics.body_names),
                      joint_pos=motion.joint_pos.astype(np.float32), joint_vel=joint_vel.astype(np.float32),
                      body_pos_w=poses[..., :3], body_quat_w=poses[..., 3:], body_lin_vel_w=velocities[..., :3],
                      body_ang_vel_w=velocities[..., 3:])


def convert_csv(csv_path: str | Path, input_fps: float, output_fps: float, robot_cfg: ArticulationCfg,
                csv_joint_names: list[str] = G1_CSV_JOINT_NAMES,
                frame_range: tuple[int, int] | None = None) -> MotionData:
    """Read a retargeted CSV, keep the frames `frame_range` (first, last; inclusive, counted from 0 at the input
    rate; None: all), put its joints in the robot's order, resample it to `output_fps` and add velocities and
    body states."""
    motion = read_motion_csv(csv_path, input_fps, csv_joint_names)
    if frame_range is not None:
        first, last = frame_range
        if not 0 <= first < last < motion.joint_pos.shape[0]:
            raise ValueError(f"frame_range {frame_range}: need 0 <= first < last < {motion.joint_pos.shape[0]} "
                             f"(the CSV's frame count)")
        keep = slice(first, last + 1)
        motion = RootAndJoints(motion.fps, motion.joint_names, motion.root_pos_w[keep], motion.root_quat_w[keep],
                               motion.joint_pos[keep])
    kinematics = RobotKinematics(robot_cfg)
    motion = resample(remap_joints(motion, kinematics.joint_names), output_fps)
    return motion_from_coordinates(motion, kinematics)
