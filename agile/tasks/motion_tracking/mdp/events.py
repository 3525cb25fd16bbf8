"""Events of motion tracking: the joint-offset randomisation."""

from __future__ import annotations

import torch

from agile.rl_env.managers import ROBOT, SceneEntityCfg

__all__ = ["randomize_joint_default_pos"]


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
