"""Observations of motion tracking (BeyondMimic, AGILE `MotionTracking-G1-v0`): the reference against the robot."""

from __future__ import annotations

import torch

from agile.tasks.motion_tracking.mdp.reference import first_two_columns, motion_command
from agile.utils.math import quat_conjugate, quat_mul, quat_rotate_inverse

__all__ = ["motion_anchor_ori_b", "motion_anchor_pos_b", "robot_body_ori_b", "robot_body_pos_b"]


def motion_anchor_pos_b(env, command_name: str) -> torch.Tensor:
    """(N, 3) the reference anchor's position in the robot anchor's frame [m]."""
    cmd = motion_command(env, command_name)
    return quat_rotate_inverse(cmd.robot_anchor_quat_w, cmd.anchor_pos_w - cmd.robot_anchor_pos_w)


def motion_anchor_ori_b(env, command_name: str) -> torch.Tensor:
    """(N, 6) the reference anchor's orientation in the robot anchor's frame (two rotation-matrix columns)."""
    cmd = motion_command(env, command_name)
    return first_two_columns(quat_mul(quat_conjugate(cmd.robot_anchor_quat_w), cmd.anchor_quat_w))


def robot_body_pos_b(env, command_name: str) -> torch.Tensor:
    """(N, 3B) the robot's tracked bodies in its anchor's frame [m]."""
    cmd = motion_command(env, command_name)
    anchor_quat = cmd.robot_anchor_quat_w.unsqueeze(1).expand(-1, len(cmd.body_names), -1)
    offsets = cmd.robot_body_pos_w - cmd.robot_anchor_pos_w.unsqueeze(1)
    return quat_rotate_inverse(anchor_quat, offsets).flatten(1)


def robot_body_ori_b(env, command_name: str) -> torch.Tensor:
    """(N, 6B) the robot's tracked body orientations in its anchor's frame (two rotation-matrix columns each)."""
    cmd = motion_command(env, command_name)
    anchor_quat = cmd.robot_anchor_quat_w.unsqueeze(1).expand(-1, len(cmd.body_names), -1)
    return first_two_columns(quat_mul(quat_conjugate(anchor_quat), cmd.robot_body_quat_w)).flatten(1)
