"""Terminations of pick-and-place tracking: the robot too far from the reference."""

from __future__ import annotations

import torch

from agile.tasks.motion_tracking.mdp.reference import quat_error_magnitude
from agile.tasks.pick_place.mdp.palm import reference_command

__all__ = ["bad_base_pose", "bad_base_rotation", "bad_joint_pos"]


def bad_base_pose(env, command_name: str, threshold_m: float) -> torch.Tensor:
    """The anchor body is farther than `threshold_m` from its reference position."""
    reference = reference_command(env, command_name)
    return torch.linalg.norm(reference.anchor_pos_w - reference.robot_anchor_pos_w, dim=-1) > threshold_m


def bad_base_rotation(env, command_name: str, threshold_rad: float) -> torch.Tensor:
    """The anchor body is turned more than `threshold_rad` from its reference orientation."""
    reference = reference_command(env, command_name)
    return quat_error_magnitude(reference.anchor_quat_w, reference.robot_anchor_quat_w) > threshold_rad


def bad_joint_pos(env, command_name: str, threshold_rad: float) -> torch.Tensor:
    """The tracked joints are farther than `threshold_rad` (Euclidean norm) from their reference."""
    reference = reference_command(env, command_name)
    return torch.linalg.norm(reference.joint_pos - reference.robot_joint_pos, dim=-1) > threshold_rad
