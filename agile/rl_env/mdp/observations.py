"""Observation terms: functions (env, **params) -> (N, D) tensors."""

from __future__ import annotations

import torch

from agile.rl_env.managers import SceneEntityCfg

ROBOT = SceneEntityCfg("robot")


def base_lin_vel(env, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """Root linear velocity in the root frame [m/s]."""
    return env.scene[asset_cfg.name].root_lin_vel_b


def base_ang_vel(env, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """Root angular velocity in the root frame [rad/s]."""
    return env.scene[asset_cfg.name].root_ang_vel_b


def projected_gravity(env, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """Unit gravity direction in the root frame."""
    return env.scene[asset_cfg.name].projected_gravity_b


def generated_commands(env, command_name: str) -> torch.Tensor:
    return env.command_manager.get_command(command_name)


def joint_pos_rel(env, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """Joint positions relative to the default pose [rad]."""
    robot = env.scene[asset_cfg.name]
    return robot.joint_pos[:, asset_cfg.joint_ids] - robot.default_joint_pos[:, asset_cfg.joint_ids]


def joint_pos(env, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    return env.scene[asset_cfg.name].joint_pos[:, asset_cfg.joint_ids]


def joint_vel_rel(env, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    robot = env.scene[asset_cfg.name]
    return robot.joint_vel[:, asset_cfg.joint_ids] - robot.default_joint_vel[:, asset_cfg.joint_ids]


def last_action(env, action_name: str | None = None) -> torch.Tensor:
    """The last policy action (all terms, or one action term's slice)."""
    manager = env.action_manager
    if action_name is None:
        return manager.action
    start = 0
    for name, term in manager.terms.items():
        if name == action_name:
            return manager.action[:, start:start + term.action_dim]
        start += term.action_dim
    raise KeyError(f"no action term '{action_name}'. Terms: {manager.active_terms}")
