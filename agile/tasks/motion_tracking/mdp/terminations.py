"""Terminations of motion tracking: the robot too far from the reference."""

from __future__ import annotations

import torch

from agile.rl_env.managers import ROBOT, SceneEntityCfg
from agile.tasks.motion_tracking.mdp.reference import body_columns, motion_command
from agile.utils.math import quat_rotate_inverse

__all__ = ["bad_anchor_ori", "bad_anchor_pos_z_only", "bad_motion_body_pos_z_only"]


def bad_anchor_pos_z_only(env, command_name: str, threshold_m: float) -> torch.Tensor:
    """The robot anchor's height is more than threshold_m from the reference anchor's."""
    cmd = motion_command(env, command_name)
    return torch.abs(cmd.anchor_pos_w[:, 2] - cmd.robot_anchor_pos_w[:, 2]) > threshold_m


def bad_anchor_ori(env, command_name: str, threshold: float, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """The z components of gravity in the reference anchor's frame and in the robot anchor's differ by more than
    `threshold` (0: same tilt; 2: upside down against upright)."""
    cmd = motion_command(env, command_name)
    gravity_w = env.scene[asset_cfg.name].gravity_dir_w
    motion_gravity_z = quat_rotate_inverse(cmd.anchor_quat_w, gravity_w)[:, 2]
    robot_gravity_z = quat_rotate_inverse(cmd.robot_anchor_quat_w, gravity_w)[:, 2]
    return torch.abs(motion_gravity_z - robot_gravity_z) > threshold


def bad_motion_body_pos_z_only(env, command_name: str, threshold_m: float,
                               body_names: list[str] | None = None) -> torch.Tensor:
    """One of the bodies is more than threshold_m above or below its anchor-relative target."""
    cmd = motion_command(env, command_name)
    cols = body_columns(cmd, body_names)
    error = torch.abs(cmd.body_pos_relative_w[:, cols, 2] - cmd.robot_body_pos_w[:, cols, 2])
    return torch.any(error > threshold_m, dim=-1)
