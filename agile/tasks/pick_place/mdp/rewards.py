"""Rewards of pick-and-place tracking: exp(-error / std²) with the error a squared distance [m², rad²]. The anchor terms
of motion tracking read the same attributes of a TrackingCommand and are used as they are."""

from __future__ import annotations

import torch

from agile.rl_env.managers import ROBOT, SceneEntityCfg
from agile.tasks.pick_place.mdp.palm import OBJECT, palm_pose_w, reference_command

__all__ = ["hand_object_distance_tracking_exp", "motion_object_position_error_exp",
           "motion_tracked_joint_pos_error_exp", "nominal_posture_at_end_exp", "palm_object_distance_exp",
           "static_at_goal_exp"]


def motion_tracked_joint_pos_error_exp(env, command_name: str, std: float) -> torch.Tensor:
    reference = reference_command(env, command_name)
    error = torch.sum(torch.square(reference.joint_pos - reference.robot_joint_pos), dim=-1)
    return torch.exp(-error / std**2)


def motion_object_position_error_exp(env, command_name: str, std: float,
                                     object_cfg: SceneEntityCfg = OBJECT) -> torch.Tensor:
    error_w = reference_command(env, command_name).object_pos_w - env.scene[object_cfg.name].root_pos_w
    return torch.exp(-torch.sum(torch.square(error_w), dim=-1) / std**2)


def hand_object_distance_tracking_exp(env, command_name: str, std: float, release_decay_steps: int,
                                      palm_cfg: SceneEntityCfg, offset_m: tuple[float, float, float],
                                      object_cfg: SceneEntityCfg = OBJECT) -> torch.Tensor:
    """exp(-|palm - object|² / std²) while the reference holds the object (grasp and carry), fading linearly to 0
    over `release_decay_steps` env steps after it lets go; 0 before the grasp."""
    reference = reference_command(env, command_name)
    fade = (1.0 - reference.steps_since_release / release_decay_steps).clamp(min=0.0)
    weight = torch.where(reference.in_hand, 1.0, torch.where(reference.released, fade, 0.0))
    return weight * palm_object_distance_exp(env, std, palm_cfg, offset_m, object_cfg)


def palm_object_distance_exp(env, std_m: float, palm_cfg: SceneEntityCfg, offset_m: tuple[float, float, float],
                             object_cfg: SceneEntityCfg = OBJECT) -> torch.Tensor:
    """exp(-|palm - object|² / std²): the palm reaching the object, whatever the reference (the debug task)."""
    palm_pos, _ = palm_pose_w(env, palm_cfg, offset_m)
    distance_sq = torch.sum(torch.square(env.scene[object_cfg.name].root_pos_w - palm_pos), dim=-1)
    return torch.exp(-distance_sq / std_m**2)


def static_at_goal_exp(env, command_name: str, progress_threshold: float, joint_vel_std: float,
                       root_vel_std: float, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """exp(-|tracked joint velocities|² / σj²) · exp(-|root velocity|² / σr²), ramped in from 0 at
    `progress_threshold` to 1 at the reference's end: be still once the task is done."""
    reference = reference_command(env, command_name)
    robot = env.scene[asset_cfg.name]
    joint_vel_sq = torch.sum(torch.square(robot.joint_vel[:, reference.joint_ids]), dim=-1)
    root_vel_sq = torch.sum(torch.square(robot.root_lin_vel_w), dim=-1) + torch.sum(
        torch.square(robot.root_ang_vel_w), dim=-1)
    ramp = ((reference.progress - progress_threshold) / (1.0 - progress_threshold)).clamp(0.0, 1.0)
    return ramp * torch.exp(-joint_vel_sq / joint_vel_std**2) * torch.exp(-root_vel_sq / root_vel_std**2)


def nominal_posture_at_end_exp(env, command_name: str, progress_threshold: float, std: float) -> torch.Tensor:
    """exp(-|tracked joints - the reference's last frame|² / std²) once the progress passes the threshold."""
    reference = reference_command(env, command_name)
    error = torch.sum(torch.square(reference.final_joint_pos - reference.robot_joint_pos), dim=-1)
    return (reference.progress > progress_threshold).float() * torch.exp(-error / std**2)
