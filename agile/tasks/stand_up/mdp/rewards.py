"""Reward terms of the stand-up tasks (AGILE StandUp-T1): rewards that only count once the robot stands
(AGILE's `if_standing` gate: the root higher than `min_height_m` above the terrain), and a reward that reads
which termination terms ended the episode."""

from __future__ import annotations

import torch

from agile.rl_env.managers import ROBOT, SceneEntityCfg
from agile.rl_env.mdp.observations import base_height_above_ground
from agile.rl_env.mdp.rewards import (
    feet_distance_from_ref,
    feet_yaw_mean_vs_base,
    joint_deviation_l1,
    joint_deviation_l2,
)

__all__ = ["feet_distance_from_ref_if_standing", "feet_yaw_mean_vs_base_if_standing", 
           "joint_deviation_if_standing", "moving_if_standing", "standing"]

JOINT_DEVIATION_NORMS = ("l1", "l2")


def standing(env, min_height_m: float, sensor_name: str | None = None,
             asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """(N,) bool: the root is more than `min_height_m` above the terrain (under the height scanner
    `sensor_name`, above z=0 without one; see `base_height_above_ground`). AGILE's `if_standing`."""
    return base_height_above_ground(env, asset_cfg, sensor_name) > min_height_m


def joint_deviation_if_standing(env, min_height_m: float, asset_cfg: SceneEntityCfg, norm: str = "l1",
                                sensor_name: str | None = None) -> torch.Tensor:
    """While standing: Σ |q - q_default| [rad] (norm "l1") or Σ (q - q_default)² [rad²] (norm "l2") over the
    selected joints; 0 while not standing. AGILE: once up, return to the default pose; on the ground any pose
    that helps getting up is free."""
    if norm == "l1":
        deviation = joint_deviation_l1(env, asset_cfg)
    elif norm == "l2":
        deviation = joint_deviation_l2(env, asset_cfg)
    else:
        raise ValueError(f"joint_deviation_if_standing: norm must be one of {JOINT_DEVIATION_NORMS}, got {norm!r}")
    return deviation * standing(env, min_height_m, sensor_name, asset_cfg)


def moving_if_standing(env, min_height_m: float, sensor_name: str | None = None,
                       asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """While standing: |v_b|² + |ω_b|², the root's linear [m/s] and angular [rad/s] velocity in the root frame
    (AGILE `moving`, a penalty: a robot that is up should stand still); 0 while not standing, since getting up
    needs the base to move."""
    robot = env.scene[asset_cfg.name]
    moving = torch.sum(torch.square(robot.root_lin_vel_b), dim=1) + torch.sum(torch.square(robot.root_ang_vel_b), dim=1)
    return moving * standing(env, min_height_m, sensor_name, asset_cfg)


def feet_distance_from_ref_if_standing(env, min_height_m: float, ref_distance_m: float, asset_cfg: SceneEntityCfg,
                                       sensor_name: str | None = None) -> torch.Tensor:
    """`feet_distance_from_ref` (|lateral distance between the two selected feet - ref_distance_m| [m]) while
    standing, else 0 (AGILE: the stance width only matters once up). The height is that of asset_cfg's root."""
    return feet_distance_from_ref(env, ref_distance_m, asset_cfg) * standing(env, min_height_m, sensor_name,
                                                                             asset_cfg)


def feet_yaw_mean_vs_base_if_standing(env, min_height_m: float, feet_asset_cfg: SceneEntityCfg,
                                      base_body_cfg: SceneEntityCfg, sensor_name: str | None = None) -> torch.Tensor:
    """`feet_yaw_mean_vs_base` (Σ_feet squared yaw of each foot in the base body's frame [rad²]) while standing,
    else 0 (AGILE: feet pointing forward once up). The height is that of feet_asset_cfg's root."""
    yaw_cost = feet_yaw_mean_vs_base(env, feet_asset_cfg, base_body_cfg)
    return yaw_cost * standing(env, min_height_m, sensor_name, feet_asset_cfg)
