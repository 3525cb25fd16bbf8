"""Observations of pick-and-place tracking (AGILE `PickPlace-G1-v0`): the reference against the robot and the object."""

from __future__ import annotations

import torch

from agile.rl_env.managers import ROBOT, SceneEntityCfg
from agile.tasks.pick_place.mdp.palm import OBJECT, palm_pose_w, reference_command
from agile.utils.math import quat_rotate_inverse

__all__ = ["motion_joint_pos_delta", "object_pos_error", "object_to_hand_pos_b", "trajectory_progress"]


def motion_joint_pos_delta(env, command_name: str) -> torch.Tensor:
    """(N, J) the tracked joints' reference minus their positions [rad]."""
    reference = reference_command(env, command_name)
    return reference.joint_pos - reference.robot_joint_pos


def object_to_hand_pos_b(env, palm_cfg: SceneEntityCfg, offset_m: tuple[float, float, float],
                         object_cfg: SceneEntityCfg = OBJECT) -> torch.Tensor:
    """(N, 3) the object's position in the palm frame [m]."""
    palm_pos, palm_quat = palm_pose_w(env, palm_cfg, offset_m)
    return quat_rotate_inverse(palm_quat, env.scene[object_cfg.name].root_pos_w - palm_pos)


def object_pos_error(env, command_name: str, object_cfg: SceneEntityCfg = OBJECT,
                     asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """(N, 3) the object's reference position minus its position, in the robot's root frame [m]."""
    robot = env.scene[asset_cfg.name]
    error_w = reference_command(env, command_name).object_pos_w - env.scene[object_cfg.name].root_pos_w
    return quat_rotate_inverse(robot.root_quat_w, error_w)


def trajectory_progress(env, command_name: str) -> torch.Tensor:
    """(N, 1) the reference's progress, 0 at its start and 1 at its end."""
    return reference_command(env, command_name).progress.unsqueeze(-1)
