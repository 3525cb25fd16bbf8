"""Termination terms: functions (env, **params) -> (N,) bool tensors."""

from __future__ import annotations

import torch

from agile.rl_env.managers import SceneEntityCfg
from agile.rl_env.mdp.observations import base_height_above_ground
from agile.rl_env.mdp.rewards import _body_projected_gravity

ROBOT = SceneEntityCfg("robot")


def time_out(env) -> torch.Tensor:
    return env.episode_length_buf >= env.max_episode_length


def bad_orientation(env, limit_angle_rad: float, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """Any selected body (root if none) tilted more than limit_angle_rad from upright."""
    gravity_z = _body_projected_gravity(env, asset_cfg)[..., 2]
    tilt = torch.acos((-gravity_z).clamp(-1.0, 1.0))
    return (tilt > limit_angle_rad).any(dim=1)


def root_height_below_minimum(env, minimum_height_m: float, asset_cfg: SceneEntityCfg = ROBOT,
                              sensor_name: str | None = None) -> torch.Tensor:
    """Root below minimum_height_m above the ground (AGILE `illegal_base_height`; terrain-relative with the
    height scanner `sensor_name`, see `base_height_above_ground`)."""
    return base_height_above_ground(env, asset_cfg, sensor_name) < minimum_height_m


def illegal_ground_contact(env, force_threshold_n: float, min_height_m: float, sensor_cfg: SceneEntityCfg,
                           asset_cfg: SceneEntityCfg) -> torch.Tensor:
    """A selected sensor body had a recent contact force above the threshold [N] while the lowest of the
    selected robot bodies is below min_height_m (world z): a fall, not a brush against an edge at full height."""
    history = env.scene[sensor_cfg.name].net_forces_w_history[:, :, sensor_cfg.body_ids]
    in_contact = (torch.norm(history, dim=-1).amax(dim=1) > force_threshold_n).any(dim=1)
    lowest_m = env.scene[asset_cfg.name].body_pose_w[:, asset_cfg.body_ids, 2].amin(dim=1)
    return in_contact & (lowest_m < min_height_m)


def link_distance(env, min_distance_m: float, max_distance_m: float | None = None,
                  asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """The two selected bodies' origins are closer than min_distance_m or (if set) farther than max_distance_m
    (AGILE: feet crossing or splitting, knees colliding)."""
    pos = env.scene[asset_cfg.name].body_pose_w[:, asset_cfg.body_ids, :3]
    if pos.shape[1] != 2:
        raise ValueError(f"link_distance needs exactly two bodies, got {pos.shape[1]} for {asset_cfg.body_names}")
    distance_m = torch.norm(pos[:, 0] - pos[:, 1], dim=1)
    too_close = distance_m < min_distance_m
    if max_distance_m is None:
        return too_close
    return too_close | (distance_m > max_distance_m)
