"""Event terms: functions (env, env_mask, **params) that write the simulation where env_mask (N,) is True."""

from __future__ import annotations

import functools

import torch

from agile.rl_env.managers import SceneEntityCfg
from agile.utils.math import quat_from_euler_xyz, quat_mul

ROBOT = SceneEntityCfg("robot")
AXES = ("x", "y", "z", "roll", "pitch", "yaw")


@functools.lru_cache(maxsize=256)
def _bounds(items: tuple, device) -> tuple[torch.Tensor, torch.Tensor]:
    ranges = dict(items)
    unknown = set(ranges) - set(AXES)
    if unknown:
        raise ValueError(f"unknown range keys {sorted(unknown)}; expected a subset of {AXES}")
    low = torch.tensor([float(ranges.get(a, (0.0, 0.0))[0]) for a in AXES], device=device)
    high = torch.tensor([float(ranges.get(a, (0.0, 0.0))[1]) for a in AXES], device=device)
    return low, high


def _sample_ranges(ranges: dict[str, tuple[float, float]], n: int, device) -> torch.Tensor:
    """(n, 6) uniform samples for x, y, z, roll, pitch, yaw; missing axes are 0. The bounds are made once
    per distinct range dict, so a step makes no host-to-device copy."""
    low, high = _bounds(tuple(sorted((k, tuple(v)) for k, v in ranges.items())), device)
    return torch.rand(n, 6, device=device) * (high - low) + low


def reset_root_state_uniform(env, env_mask: torch.Tensor, pose_range: dict, velocity_range: dict,
                             asset_cfg: SceneEntityCfg = ROBOT) -> None:
    """Root at default pose + env origin + uniform offsets; root velocity uniform (world frame)."""
    robot = env.scene[asset_cfg.name]
    n = env.num_envs
    pose_delta = _sample_ranges(pose_range, n, env.device)
    pose = robot.default_root_pose.clone()
    pose[:, :3] += env.env_origins + pose_delta[:, :3]
    pose[:, 3:7] = quat_mul(quat_from_euler_xyz(pose_delta[:, 3], pose_delta[:, 4], pose_delta[:, 5]), pose[:, 3:7])
    velocity = _sample_ranges(velocity_range, n, env.device)
    robot.write_root_state(pose, velocity, env_mask)


def reset_joints_by_scale(env, env_mask: torch.Tensor, position_range: tuple[float, float],
                          velocity_range: tuple[float, float], asset_cfg: SceneEntityCfg = ROBOT) -> None:
    """Joint positions = default × U(position_range) and velocities = default × U(velocity_range),
    clamped to the position limits."""
    robot = env.scene[asset_cfg.name]
    pos = robot.default_joint_pos * (torch.rand_like(robot.joint_pos) * (position_range[1] - position_range[0])
                                     + position_range[0])
    vel = robot.default_joint_vel * (torch.rand_like(robot.joint_vel) * (velocity_range[1] - velocity_range[0])
                                     + velocity_range[0])
    pos = torch.clamp(pos, robot.joint_pos_limits[..., 0], robot.joint_pos_limits[..., 1])
    if asset_cfg.joint_ids != slice(None):
        keep = torch.ones(robot.num_joints, dtype=torch.bool, device=env.device)
        keep[asset_cfg.joint_ids] = False
        pos = torch.where(keep, robot.joint_pos, pos)
        vel = torch.where(keep, robot.joint_vel, vel)
    robot.write_joint_state(pos, vel, env_mask)


def push_by_setting_velocity(env, env_mask: torch.Tensor, velocity_range: dict,
                             asset_cfg: SceneEntityCfg = ROBOT) -> None:
    """Add a uniform random velocity (x, y, z, roll, pitch, yaw; world frame) to the root."""
    robot = env.scene[asset_cfg.name]
    velocity = robot.root_com_vel_w + _sample_ranges(velocity_range, env.num_envs, env.device)
    robot.write_root_state(robot.root_pose_w, velocity, env_mask)
