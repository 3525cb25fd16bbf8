"""Reward terms: functions (env, **params) -> (N,) tensors. The weight sets the sign; penalties return costs."""

from __future__ import annotations

import torch

from agile.rl_env.managers import SceneEntityCfg
from agile.utils.math import quat_rotate_inverse, wrap_to_pi, yaw_from_quat

ROBOT = SceneEntityCfg("robot")


# -- task -----------------------------------------------------------------------------------------

def is_terminated(env) -> torch.Tensor:
    """1 for episodes that ended by a failure (not a time-out)."""
    return env.termination_manager.terminated.float()


def track_lin_vel_xy_exp(env, std: float, command_name: str, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """exp(-|v_cmd,xy - v_xy|² / std²), velocities in the root frame."""
    robot = env.scene[asset_cfg.name]
    command = env.command_manager.get_command(command_name)
    error = torch.sum(torch.square(command[:, :2] - robot.root_lin_vel_b[:, :2]), dim=1)
    return torch.exp(-error / std**2)


def track_ang_vel_z_exp(env, std: float, command_name: str, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """exp(-(w_cmd,z - w_z)² / std²), root frame."""
    robot = env.scene[asset_cfg.name]
    command = env.command_manager.get_command(command_name)
    error = torch.square(command[:, 2] - robot.root_ang_vel_b[:, 2])
    return torch.exp(-error / std**2)


def base_height_exp(env, target_height_m: float, std: float, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """exp(-(h - h_target)² / std²) with h the root height above the flat ground."""
    height = env.scene[asset_cfg.name].root_pos_w[:, 2]
    return torch.exp(-torch.square(height - target_height_m) / std**2)


# -- orientation and base motion --------------------------------------------------------------------

def _body_projected_gravity(env, asset_cfg: SceneEntityCfg) -> torch.Tensor:
    """(N, B, 3) gravity direction in the frames of the selected bodies (root if none selected)."""
    robot = env.scene[asset_cfg.name]
    if asset_cfg.body_names is None:
        return robot.projected_gravity_b.unsqueeze(1)
    quat = robot.body_pose_w[:, asset_cfg.body_ids, 3:7]
    gravity = robot.gravity_dir_w.unsqueeze(1).expand(-1, quat.shape[1], -1)
    return quat_rotate_inverse(quat, gravity)


def flat_orientation_l2(env, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """Squared xy of the gravity direction in the body frame (0 when upright), summed over bodies."""
    return torch.sum(torch.square(_body_projected_gravity(env, asset_cfg)[..., :2]), dim=(1, 2))


def flat_body_orientation_exp(env, std_rad: float, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """exp(-|g_xy|² / std²) averaged over bodies; |g_xy| ≈ tilt angle for small tilts."""
    g_xy = _body_projected_gravity(env, asset_cfg)[..., :2]
    return torch.exp(-torch.sum(torch.square(g_xy), dim=-1) / std_rad**2).mean(dim=1)


def lin_vel_z_l2(env, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    return torch.square(env.scene[asset_cfg.name].root_lin_vel_b[:, 2])


def ang_vel_xy_l2(env, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    return torch.sum(torch.square(env.scene[asset_cfg.name].root_ang_vel_b[:, :2]), dim=1)


# -- joint regularisation ---------------------------------------------------------------------------

def joint_torques_l2(env, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    return torch.sum(torch.square(env.scene[asset_cfg.name].applied_torque[:, asset_cfg.joint_ids]), dim=1)


def joint_vel_l2(env, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    return torch.sum(torch.square(env.scene[asset_cfg.name].joint_vel[:, asset_cfg.joint_ids]), dim=1)


def joint_acc_l2(env, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    return torch.sum(torch.square(env.scene[asset_cfg.name].joint_acc[:, asset_cfg.joint_ids]), dim=1)


def joint_deviation_l1(env, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    robot = env.scene[asset_cfg.name]
    ids = asset_cfg.joint_ids
    return torch.sum(torch.abs(robot.joint_pos[:, ids] - robot.default_joint_pos[:, ids]), dim=1)


def joint_pos_limits(env, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """Sum of how far joints are outside their position limits [rad]."""
    robot = env.scene[asset_cfg.name]
    ids = asset_cfg.joint_ids
    pos = robot.joint_pos[:, ids]
    limits = robot.joint_pos_limits[:, ids]
    below = (limits[..., 0] - pos).clamp(min=0.0)
    above = (pos - limits[..., 1]).clamp(min=0.0)
    return torch.sum(below + above, dim=1)


def joint_vel_limits(env, soft_ratio: float, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """Sum over joints of the speed above soft_ratio·limit, each clipped to 1 rad/s (Isaac Lab)."""
    robot = env.scene[asset_cfg.name]
    ids = asset_cfg.joint_ids
    excess = robot.joint_vel[:, ids].abs() - robot.joint_vel_limit[:, ids] * soft_ratio
    return torch.sum(excess.clamp(min=0.0, max=1.0), dim=1)


def applied_torque_limits(env, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """Sum of |computed - applied| torque: how much the effort limits clip the actuators [N·m]."""
    robot = env.scene[asset_cfg.name]
    ids = asset_cfg.joint_ids
    return torch.sum(torch.abs(robot.computed_torque[:, ids] - robot.applied_torque[:, ids]), dim=1)


# -- actions ----------------------------------------------------------------------------------------

def action_rate_l2(env) -> torch.Tensor:
    manager = env.action_manager
    return torch.sum(torch.square(manager.action - manager.prev_action), dim=1)


def action_rate_rate_l2(env) -> torch.Tensor:
    """Squared second difference of the actions."""
    manager = env.action_manager
    return torch.sum(torch.square(manager.action - 2.0 * manager.prev_action + manager.prev_prev_action), dim=1)


# -- feet (poses only; contact-based foot terms need the contact sensor) ----------------------------

def _feet_rpy(env, asset_cfg: SceneEntityCfg) -> tuple[torch.Tensor, torch.Tensor]:
    """(roll, yaw) of the selected bodies, (N, 2) each; roll about the foot's own x axis."""
    quat = env.scene[asset_cfg.name].body_pose_w[:, asset_cfg.body_ids, 3:7]
    x, y, z, w = quat.unbind(-1)
    roll = torch.atan2(2.0 * (w * x + y * z), 1.0 - 2.0 * (x * x + y * y))
    return roll, yaw_from_quat(quat)


def feet_roll_l2(env, asset_cfg: SceneEntityCfg) -> torch.Tensor:
    roll, _ = _feet_rpy(env, asset_cfg)
    return torch.sum(torch.square(roll), dim=1)


def feet_yaw_diff_l2(env, asset_cfg: SceneEntityCfg) -> torch.Tensor:
    """Squared yaw difference between the two feet."""
    _, yaw = _feet_rpy(env, asset_cfg)
    return torch.square(wrap_to_pi(yaw[:, 1] - yaw[:, 0]))


def feet_yaw_mean_vs_base(env, asset_cfg: SceneEntityCfg) -> torch.Tensor:
    """Squared yaw of the feet's mean heading relative to the base heading."""
    robot = env.scene[asset_cfg.name]
    _, yaw = _feet_rpy(env, asset_cfg)
    mean_yaw = yaw[:, 0] + 0.5 * wrap_to_pi(yaw[:, 1] - yaw[:, 0])
    return torch.square(wrap_to_pi(mean_yaw - robot.heading_w))


def feet_distance_from_ref(env, ref_distance_m: float, asset_cfg: SceneEntityCfg) -> torch.Tensor:
    """|lateral distance between the feet in the base yaw frame - reference| [m]."""
    robot = env.scene[asset_cfg.name]
    feet_pos = robot.body_pose_w[:, asset_cfg.body_ids, :3]
    delta_w = feet_pos[:, 0] - feet_pos[:, 1]
    heading = robot.heading_w
    lateral = -torch.sin(heading) * delta_w[:, 0] + torch.cos(heading) * delta_w[:, 1]
    return torch.abs(lateral.abs() - ref_distance_m)
