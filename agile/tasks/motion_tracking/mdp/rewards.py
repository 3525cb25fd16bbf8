"""Rewards of motion tracking (BeyondMimic): exp(-error / std²) with the error a squared distance, anchor terms in the
world frame, body terms averaged over the tracked bodies (positions and orientations against the anchor-relative
targets; velocities in the world frame)."""

from __future__ import annotations

import torch

from agile.tasks.motion_tracking.mdp.reference import body_columns, motion_command, quat_error_magnitude

__all__ = ["motion_global_anchor_orientation_error_exp", "motion_global_anchor_position_error_exp",
           "motion_global_body_angular_velocity_error_exp", "motion_global_body_linear_velocity_error_exp",
           "motion_relative_body_orientation_error_exp", "motion_relative_body_position_error_exp"]


def motion_global_anchor_position_error_exp(env, command_name: str, std: float) -> torch.Tensor:
    cmd = motion_command(env, command_name)
    error = torch.sum(torch.square(cmd.anchor_pos_w - cmd.robot_anchor_pos_w), dim=-1)
    return torch.exp(-error / std**2)


def motion_global_anchor_orientation_error_exp(env, command_name: str, std: float) -> torch.Tensor:
    cmd = motion_command(env, command_name)
    error = quat_error_magnitude(cmd.anchor_quat_w, cmd.robot_anchor_quat_w) ** 2
    return torch.exp(-error / std**2)


def motion_relative_body_position_error_exp(env, command_name: str, std: float,
                                            body_names: list[str] | None = None) -> torch.Tensor:
    cmd = motion_command(env, command_name)
    cols = body_columns(cmd, body_names)
    error = torch.sum(torch.square(cmd.body_pos_relative_w[:, cols] - cmd.robot_body_pos_w[:, cols]), dim=-1)
    return torch.exp(-error.mean(-1) / std**2)


def motion_relative_body_orientation_error_exp(env, command_name: str, std: float,
                                               body_names: list[str] | None = None) -> torch.Tensor:
    cmd = motion_command(env, command_name)
    cols = body_columns(cmd, body_names)
    error = quat_error_magnitude(cmd.body_quat_relative_w[:, cols], cmd.robot_body_quat_w[:, cols]) ** 2
    return torch.exp(-error.mean(-1) / std**2)


def motion_global_body_linear_velocity_error_exp(env, command_name: str, std: float,
                                                 body_names: list[str] | None = None) -> torch.Tensor:
    cmd = motion_command(env, command_name)
    cols = body_columns(cmd, body_names)
    error = torch.sum(torch.square(cmd.body_lin_vel_w[:, cols] - cmd.robot_body_lin_vel_w[:, cols]), dim=-1)
    return torch.exp(-error.mean(-1) / std**2)


def motion_global_body_angular_velocity_error_exp(env, command_name: str, std: float,
                                                  body_names: list[str] | None = None) -> torch.Tensor:
    cmd = motion_command(env, command_name)
    cols = body_columns(cmd, body_names)
    error = torch.sum(torch.square(cmd.body_ang_vel_w[:, cols] - cmd.robot_body_ang_vel_w[:, cols]), dim=-1)
    return torch.exp(-error.mean(-1) / std**2)
