"""Reward terms of the velocity-and-height tasks (AGILE `task_rewards.py`, `aestetic_rewards.py`,
`regularization_rewards.py`): tracking in the base yaw frame, height tracking, and what a robot told to stand
still should do (`*_if_null_cmd`: the command's velocity part is exactly 0)."""

from __future__ import annotations

import math

import torch

from agile.rl_env.managers import ROBOT, SceneEntityCfg
from agile.rl_env.mdp.observations import base_height_above_ground
from agile.rl_env.mdp.rewards import equal_foot_force
from agile.utils.math import world_to_heading_frame_xy

__all__ = ["base_height_in_threshold", "equal_foot_force_if_null_cmd", "flat_orientation_if_null_cmd",
           "no_undesired_base_velocity_exp", "no_undesired_base_velocity_exp_if_null_cmd",
           "null_command", "relax_if_null_cmd", "relax_if_null_cmd_exp", "stand_with_both_feet_if_null_cmd",
           "track_ang_vel_z_world_exp", "track_base_height_exp_smooth", "track_lin_vel_xy_yaw_frame_exp",
           "track_lin_vel_xy_yaw_frame_exp_weighted"]

MIN_WEIGHTED_SPEED_MPS = 0.01
"""AGILE: the tracking weight rises from 1 at this commanded speed to 2 at the fastest command."""


def null_command(env, command_name: str) -> torch.Tensor:
    """(N,) bool: the command's velocity part (vx, vy, wz) is exactly zero: stand still."""
    return (env.command_manager.get_command(command_name)[:, :3] == 0.0).all(dim=1)


def _lin_vel_yaw_frame(robot) -> torch.Tensor:
    """(N, 2) root linear velocity in the yaw frame (the base heading, gravity-aligned) [m/s]."""
    return world_to_heading_frame_xy(robot.heading_w, robot.root_lin_vel_w)


# -- tracking ------------------------------------------------------------------------------------------

def track_lin_vel_xy_yaw_frame_exp(env, std: float, command_name: str,
                                   asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """exp(-|v_cmd,xy - v_xy|² / std²), v the root velocity in the yaw frame (heading, gravity-aligned)."""
    command_xy = env.command_manager.get_command(command_name)[:, :2]
    error = torch.sum(torch.square(command_xy - _lin_vel_yaw_frame(env.scene[asset_cfg.name])), dim=1)
    return torch.exp(-error / std**2)


def track_lin_vel_xy_yaw_frame_exp_weighted(env, std: float, command_name: str,
                                            asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """w · exp(-|v_cmd,xy - v_xy|² / std²), v in the yaw frame; w rises linearly from 1 at a commanded speed of
    0.01 m/s to 2 at the fastest command (|(vx_max, vy_max)| of the command's ranges): fast commands count more."""
    command_term = env.command_manager.get_term(command_name)
    ranges = command_term.cfg.ranges
    fastest = math.hypot(ranges.lin_vel_x[1], ranges.lin_vel_y[1])
    command_xy = command_term.command[:, :2]
    error = torch.sum(torch.square(command_xy - _lin_vel_yaw_frame(env.scene[asset_cfg.name])), dim=1)
    speed = torch.norm(command_xy, dim=1).clamp(MIN_WEIGHTED_SPEED_MPS, fastest)
    weight = 1.0 + (speed - MIN_WEIGHTED_SPEED_MPS) / max(fastest - MIN_WEIGHTED_SPEED_MPS, 1e-6)
    return weight * torch.exp(-error / std**2)


def track_ang_vel_z_world_exp(env, std: float, command_name: str, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """exp(-(w_cmd,z - w_z)² / std²) with w_z the root's yaw rate about the world z axis."""
    command = env.command_manager.get_command(command_name)
    error = torch.square(command[:, 2] - env.scene[asset_cfg.name].root_ang_vel_w[:, 2])
    return torch.exp(-error / std**2)


def track_base_height_exp_smooth(env, std: float, command_name: str, sensor_name: str | None = None,
                                 asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """exp(-(h - h_cmd)² / std²): h the root height above the terrain under the height scanner `sensor_name`,
    h_cmd the (smoothed) height command, column 3 of the command."""
    height = base_height_above_ground(env, asset_cfg, sensor_name)
    target = env.command_manager.get_command(command_name)[:, 3]
    return torch.exp(-torch.square(height - target) / std**2)


def base_height_in_threshold(env, threshold_m: float, command_name: str, sensor_name: str | None = None,
                             asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """1 while |h - h_cmd| < threshold_m (h as in `track_base_height_exp_smooth`)."""
    height = base_height_above_ground(env, asset_cfg, sensor_name)
    target = env.command_manager.get_command(command_name)[:, 3]
    return (torch.abs(height - target) < threshold_m).float()


# -- standing still ------------------------------------------------------------------------------------

NULL_COMMAND_LIN_VEL_Z_WEIGHT = 0.1
"""AGILE: a robot told to stand still may move vertically (crouch, rise) at a tenth of the cost."""


def no_undesired_base_velocity_exp(env, std: float, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """exp(-(v_z² + ω_x² + ω_y²) / std²), root frame: no bouncing, rolling or pitching."""
    robot = env.scene[asset_cfg.name]
    cost = torch.square(robot.root_lin_vel_b[:, 2]) + torch.sum(torch.square(robot.root_ang_vel_b[:, :2]), dim=1)
    return torch.exp(-cost / std**2)


def no_undesired_base_velocity_exp_if_null_cmd(env, std: float, command_name: str,
                                               asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """exp(-(w·v_z² + ω_x² + ω_y²) / std²), root frame; w = 0.1 under a null command, else 1 (AGILE
    `no_undersired_base_velocity_exp_if_null_cmd`: rewarded under every command, only v_z's weight changes)."""
    robot = env.scene[asset_cfg.name]
    weight = torch.where(null_command(env, command_name), NULL_COMMAND_LIN_VEL_Z_WEIGHT, 1.0)
    cost = weight * torch.square(robot.root_lin_vel_b[:, 2])
    cost = cost + torch.sum(torch.square(robot.root_ang_vel_b[:, :2]), dim=1)
    return torch.exp(-cost / std**2)


def equal_foot_force_if_null_cmd(env, command_name: str, sensor_cfg: SceneEntityCfg) -> torch.Tensor:
    """`equal_foot_force` under a null command, else 0."""
    return equal_foot_force(env, sensor_cfg) * null_command(env, command_name)


def stand_with_both_feet_if_null_cmd(env, threshold_n: float, command_name: str,
                                     sensor_cfg: SceneEntityCfg) -> torch.Tensor:
    """Under a null command: `equal_foot_force` if every selected foot pushes with |F_z| > threshold_n, else -1;
    0 under any other command."""
    feet_z = env.scene[sensor_cfg.name].net_forces_w[:, sensor_cfg.body_ids, 2].abs()
    both_down = (feet_z > threshold_n).all(dim=1)
    reward = torch.where(both_down, equal_foot_force(env, sensor_cfg), -1.0)
    return torch.where(null_command(env, command_name), reward, 0.0)


def relax_if_null_cmd(env, command_name: str, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """Σ τ² of the selected joints [N²·m²] under a null command, else 0 (a penalty)."""
    torque = env.scene[asset_cfg.name].applied_torque[:, asset_cfg.joint_ids]
    return torch.sum(torch.square(torque), dim=1) * null_command(env, command_name)


def relax_if_null_cmd_exp(env, std: float, command_name: str, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """exp(-(rms_j(τ_j / τ_max,j) / std)²) under a null command, else 0: 1 with no effort, lower the more of
    the joints' effort limits a standing robot spends."""
    robot = env.scene[asset_cfg.name]
    ids = asset_cfg.joint_ids
    normalised = robot.applied_torque[:, ids] / (robot.joint_effort_limit[:, ids] + 1e-6)
    rms = torch.sqrt(torch.mean(torch.square(normalised), dim=1))
    return torch.exp(-torch.square(rms / std)) * null_command(env, command_name)


def flat_orientation_if_null_cmd(env, command_name: str, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """|g_xy|² of the root's projected gravity under a null command, else 0 (a penalty)."""
    gravity_xy = env.scene[asset_cfg.name].projected_gravity_b[:, :2]
    return torch.sum(torch.square(gravity_xy), dim=1) * null_command(env, command_name)


# -- joints --------------------------------------------------------------------------------------------
