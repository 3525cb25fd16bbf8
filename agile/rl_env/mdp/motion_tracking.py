"""Terms of motion tracking (BeyondMimic, AGILE `MotionTracking-G1-v0`): observations, rewards and terminations
that compare the robot with the reference of a `MotionCommand`, and the joint-offset randomisation event.

Rewards are exp(-error / std²) with the error a squared distance: anchor terms in the world frame, body terms
averaged over the tracked bodies (positions and orientations against the anchor-relative targets; velocities
in the world frame).
"""

from __future__ import annotations

import functools

import torch

from agile.rl_env.managers import ROBOT, SceneEntityCfg
from agile.utils.math import quat_conjugate, quat_mul, quat_rotate, quat_rotate_inverse

__all__ = ["bad_anchor_ori", "bad_anchor_pos_z_only", "bad_motion_body_pos_z_only", "motion_anchor_ori_b",
           "motion_anchor_pos_b", "motion_global_anchor_orientation_error_exp",
           "motion_global_anchor_position_error_exp", "motion_global_body_angular_velocity_error_exp",
           "motion_global_body_linear_velocity_error_exp", "motion_relative_body_orientation_error_exp",
           "motion_relative_body_position_error_exp", "quat_error_magnitude", "randomize_joint_default_pos",
           "robot_body_ori_b", "robot_body_pos_b"]



def _motion(env, command_name: str):
    return env.command_manager.get_term(command_name)


def _body_columns(command, body_names: list[str] | None) -> torch.Tensor | slice:
    """Columns of `body_names` among the command's tracked bodies (all when None), as a device index tensor made
    once per name list: a captured step may not copy from the host."""
    if body_names is None:
        return slice(None)
    return _column_ids(tuple(command.body_names), tuple(body_names), command.body_pos_relative_w.device)


@functools.lru_cache(maxsize=64)
def _column_ids(tracked: tuple[str, ...], body_names: tuple[str, ...], device) -> torch.Tensor:
    missing = [n for n in body_names if n not in tracked]
    if missing:
        raise ValueError(f"bodies {missing} are not tracked by the motion command. Tracked: {list(tracked)}")
    return torch.tensor([tracked.index(n) for n in body_names], dtype=torch.long, device=device)


def quat_error_magnitude(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    """Angle [rad] of the rotation between unit quaternions a and b, in [0, π]."""
    diff = quat_mul(a, quat_conjugate(b))
    return 2.0 * torch.atan2(torch.linalg.norm(diff[..., :3], dim=-1), diff[..., 3].abs())


def _first_two_columns(q_xyzw: torch.Tensor) -> torch.Tensor:
    """(..., 6) the first two columns of the rotation matrix of q, row by row (BeyondMimic's 6-D orientation)."""
    x_axis = torch.zeros_like(q_xyzw[..., :3])
    x_axis[..., 0] = 1.0
    y_axis = torch.zeros_like(x_axis)
    y_axis[..., 1] = 1.0
    columns = torch.stack([quat_rotate(q_xyzw, x_axis), quat_rotate(q_xyzw, y_axis)], dim=-1)  # (..., 3, 2)
    return columns.flatten(-2)


# -- observations -------------------------------------------------------------------------------------------

def motion_anchor_pos_b(env, command_name: str) -> torch.Tensor:
    """(N, 3) the reference anchor's position in the robot anchor's frame [m]."""
    cmd = _motion(env, command_name)
    return quat_rotate_inverse(cmd.robot_anchor_quat_w, cmd.anchor_pos_w - cmd.robot_anchor_pos_w)


def motion_anchor_ori_b(env, command_name: str) -> torch.Tensor:
    """(N, 6) the reference anchor's orientation in the robot anchor's frame (two rotation-matrix columns)."""
    cmd = _motion(env, command_name)
    return _first_two_columns(quat_mul(quat_conjugate(cmd.robot_anchor_quat_w), cmd.anchor_quat_w))


def robot_body_pos_b(env, command_name: str) -> torch.Tensor:
    """(N, 3B) the robot's tracked bodies in its anchor's frame [m]."""
    cmd = _motion(env, command_name)
    anchor_quat = cmd.robot_anchor_quat_w.unsqueeze(1).expand(-1, len(cmd.body_names), -1)
    offsets = cmd.robot_body_pos_w - cmd.robot_anchor_pos_w.unsqueeze(1)
    return quat_rotate_inverse(anchor_quat, offsets).flatten(1)


def robot_body_ori_b(env, command_name: str) -> torch.Tensor:
    """(N, 6B) the robot's tracked body orientations in its anchor's frame (two rotation-matrix columns each)."""
    cmd = _motion(env, command_name)
    anchor_quat = cmd.robot_anchor_quat_w.unsqueeze(1).expand(-1, len(cmd.body_names), -1)
    return _first_two_columns(quat_mul(quat_conjugate(anchor_quat), cmd.robot_body_quat_w)).flatten(1)


# -- rewards ------------------------------------------------------------------------------------------------

def motion_global_anchor_position_error_exp(env, command_name: str, std: float) -> torch.Tensor:
    cmd = _motion(env, command_name)
    error = torch.sum(torch.square(cmd.anchor_pos_w - cmd.robot_anchor_pos_w), dim=-1)
    return torch.exp(-error / std**2)


def motion_global_anchor_orientation_error_exp(env, command_name: str, std: float) -> torch.Tensor:
    cmd = _motion(env, command_name)
    error = quat_error_magnitude(cmd.anchor_quat_w, cmd.robot_anchor_quat_w) ** 2
    return torch.exp(-error / std**2)


def motion_relative_body_position_error_exp(env, command_name: str, std: float,
                                            body_names: list[str] | None = None) -> torch.Tensor:
    cmd = _motion(env, command_name)
    cols = _body_columns(cmd, body_names)
    error = torch.sum(torch.square(cmd.body_pos_relative_w[:, cols] - cmd.robot_body_pos_w[:, cols]), dim=-1)
    return torch.exp(-error.mean(-1) / std**2)


def motion_relative_body_orientation_error_exp(env, command_name: str, std: float,
                                               body_names: list[str] | None = None) -> torch.Tensor:
    cmd = _motion(env, command_name)
    cols = _body_columns(cmd, body_names)
    error = quat_error_magnitude(cmd.body_quat_relative_w[:, cols], cmd.robot_body_quat_w[:, cols]) ** 2
    return torch.exp(-error.mean(-1) / std**2)


def motion_global_body_linear_velocity_error_exp(env, command_name: str, std: float,
                                                 body_names: list[str] | None = None) -> torch.Tensor:
    cmd = _motion(env, command_name)
    cols = _body_columns(cmd, body_names)
    error = torch.sum(torch.square(cmd.body_lin_vel_w[:, cols] - cmd.robot_body_lin_vel_w[:, cols]), dim=-1)
    return torch.exp(-error.mean(-1) / std**2)


def motion_global_body_angular_velocity_error_exp(env, command_name: str, std: float,
                                                  body_names: list[str] | None = None) -> torch.Tensor:
    cmd = _motion(env, command_name)
    cols = _body_columns(cmd, body_names)
    error = torch.sum(torch.square(cmd.body_ang_vel_w[:, cols] - cmd.robot_body_ang_vel_w[:, cols]), dim=-1)
    return torch.exp(-error.mean(-1) / std**2)


# -- terminations -------------------------------------------------------------------------------------------

def bad_anchor_pos_z_only(env, command_name: str, threshold_m: float) -> torch.Tensor:
    """The robot anchor's height is more than threshold_m from the reference anchor's."""
    cmd = _motion(env, command_name)
    return torch.abs(cmd.anchor_pos_w[:, 2] - cmd.robot_anchor_pos_w[:, 2]) > threshold_m


def bad_anchor_ori(env, command_name: str, threshold: float, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """The z components of gravity in the reference anchor's frame and in the robot anchor's differ by more than
    `threshold` (0: same tilt; 2: upside down against upright)."""
    cmd = _motion(env, command_name)
    gravity_w = env.scene[asset_cfg.name].gravity_dir_w
    motion_gravity_z = quat_rotate_inverse(cmd.anchor_quat_w, gravity_w)[:, 2]
    robot_gravity_z = quat_rotate_inverse(cmd.robot_anchor_quat_w, gravity_w)[:, 2]
    return torch.abs(motion_gravity_z - robot_gravity_z) > threshold


def bad_motion_body_pos_z_only(env, command_name: str, threshold_m: float,
                               body_names: list[str] | None = None) -> torch.Tensor:
    """One of the bodies is more than threshold_m above or below its anchor-relative target."""
    cmd = _motion(env, command_name)
    cols = _body_columns(cmd, body_names)
    error = torch.abs(cmd.body_pos_relative_w[:, cols, 2] - cmd.robot_body_pos_w[:, cols, 2])
    return torch.any(error > threshold_m, dim=-1)


# -- events -------------------------------------------------------------------------------------------------

def randomize_joint_default_pos(env, env_mask: torch.Tensor, pos_distribution_params: tuple[float, float],
                                action_name: str = "joint_pos", asset_cfg: SceneEntityCfg = ROBOT) -> None:
    """Add U(pos_distribution_params) [rad] to each selected joint's default angle, per env, and to the joint-position
    action's offset with it (BeyondMimic: a joint-encoder calibration error). A startup term: it accumulates."""
    robot = env.scene[asset_cfg.name]
    action = env.action_manager.get_term(action_name)
    low, high = pos_distribution_params
    offset = torch.rand_like(robot.default_joint_pos) * (high - low) + low
    keep = torch.ones(robot.num_joints, dtype=torch.bool, device=env.device)
    keep[asset_cfg.joint_ids] = False
    offset = torch.where(keep | ~env_mask.unsqueeze(-1), 0.0, offset)
    robot.default_joint_pos.add_(offset)
    action.offset.add_(offset[:, action.joint_ids])
