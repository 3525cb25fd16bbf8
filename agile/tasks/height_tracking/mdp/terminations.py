"""Termination of the sit-down / stand-up task (AGILE V1.3 `invalid_state`): end episodes whose simulation state
is no longer physical, rather than any fall (falling and lying are part of the task)."""

from __future__ import annotations

import torch

from agile.rl_env.managers import SceneEntityCfg

__all__ = ["invalid_state"]


def invalid_state(env, max_joint_vel_rad_s: float = 100.0, max_root_height_m: float = 5.0,
                  max_root_xy_distance_m: float = 200.0, max_lin_vel_mps: float = 20.0, max_ang_vel_rad_s: float = 50.0,
                  asset_cfg: SceneEntityCfg = SceneEntityCfg("robot")) -> torch.Tensor:
    """(N,) bool: any joint faster than `max_joint_vel_rad_s`, the root higher than `max_root_height_m` above or
    below its env origin, farther than `max_root_xy_distance_m` from it horizontally, moving faster than
    `max_lin_vel_mps` or turning faster than `max_ang_vel_rad_s`, or any of these not finite (a blown-up world)."""
    robot = env.scene[asset_cfg.name]
    root_offset_m = robot.root_pos_w - env.env_origins
    magnitudes = torch.stack((
        robot.joint_vel.abs().amax(dim=1) / max_joint_vel_rad_s,
        root_offset_m[:, 2].abs() / max_root_height_m,
        torch.norm(root_offset_m[:, :2], dim=1) / max_root_xy_distance_m,
        torch.norm(robot.root_lin_vel_w, dim=1) / max_lin_vel_mps,
        torch.norm(robot.root_ang_vel_w, dim=1) / max_ang_vel_rad_s), dim=1)
    # a NaN compares False: count it as invalid explicitly
    return ((magnitudes > 1.0) | ~torch.isfinite(magnitudes)).any(dim=1)
