"""Termination terms: functions (env, **params) -> (N,) bool tensors."""

from __future__ import annotations

import math

import torch

from agile.rl_env.managers import ManagerTermBase, ROBOT, SceneEntityCfg
from agile.rl_env.mdp.observations import base_height_above_ground
from agile.rl_env.mdp.rewards import body_projected_gravity, filtered_contact

__all__ = ["bad_orientation", "illegal_ground_contact", "link_distance", "no_height_progress", "out_of_bound",
           "root_height_below_minimum", "time_out"]



def time_out(env) -> torch.Tensor:
    return env.episode_length_buf >= env.max_episode_length


def bad_orientation(env, limit_angle_rad: float, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """Any selected body (root if none) tilted more than limit_angle_rad from upright."""
    gravity_z = body_projected_gravity(env, asset_cfg)[..., 2]
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
    selected robot bodies is below min_height_m (world z): a fall, not a brush against an edge at full height.
    The force is the net one over the sensor's history, or, for a sensor with a filter entity, the filter's alone at
    the last physics step ('ground': the terrain's, so that in a scene of several robots a touch of another robot
    is not a fall)."""
    sensor = env.scene[sensor_cfg.name]
    if sensor.force_matrix_w is None:
        history = sensor.net_forces_w_history[:, :, sensor_cfg.body_ids]
        in_contact = (torch.norm(history, dim=-1).amax(dim=1) > force_threshold_n).any(dim=1)
    else:
        in_contact = filtered_contact(env, sensor_cfg, force_threshold_n).bool()
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


class no_height_progress(ManagerTermBase):  # noqa: N801 (AGILE's name)
    """AGILE stand-up: the episode ends when the root height above the terrain has not risen by at least
    `min_height_gain_m` (AGILE: 0.2 m) within `time_window_s` (AGILE: 10 s) of the episode's start.

    The height (`base_height_above_ground`, terrain-relative under the height scanner `sensor_name`) is recorded
    at the episode's first step, and its maximum since. From the step where the episode time
    (episode_length_buf · step_dt) reaches `time_window_s` on, an env ends while max - start < min_height_gain_m
    and its current height is below `standing_height_m`: a robot that starts standing (and so cannot rise)
    is not ended for staying up. Free of host syncs, so it runs inside a captured step.
    """

    def __init__(self, cfg, env):
        super().__init__(cfg, env)
        params = cfg.params
        if not params.get("time_window_s", 10.0) > 0.0:
            raise ValueError(f"no_height_progress: time_window_s must be positive, got {params['time_window_s']}")
        if not params.get("min_height_gain_m", 0.2) > 0.0:
            raise ValueError(f"no_height_progress: min_height_gain_m must be positive, got "
                             f"{params['min_height_gain_m']}")
        n = env.num_envs
        self.start_height_m = torch.zeros(n, device=env.device)
        """Root height above the terrain at the episode's first step."""
        self.max_height_m = torch.zeros(n, device=env.device)
        """Highest root height above the terrain since the episode's first step."""
        self.restart = torch.ones(n, dtype=torch.bool, device=env.device)
        """Envs reset since the last call: the termination manager resets terms before the robot is put back,
        so the new episode's start height is read at its first step, the next call."""

    def reset(self, env_mask) -> None:
        self.restart |= env_mask

    def __call__(self, env, standing_height_m: float, min_height_gain_m: float = 0.2, time_window_s: float = 10.0,
                 sensor_name: str | None = None, asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
        height_m = base_height_above_ground(env, asset_cfg, sensor_name)
        self.start_height_m.copy_(torch.where(self.restart, height_m, self.start_height_m))
        self.max_height_m.copy_(torch.where(self.restart, height_m, torch.maximum(self.max_height_m, height_m)))
        self.restart.zero_()
        # whole steps, so that the window ends at an exact step (10 s / 0.02 s is 500 steps, not 500.0000001)
        window_steps = math.ceil(time_window_s / env.step_dt - 1e-6)
        window_over = env.episode_length_buf >= window_steps
        no_progress = self.max_height_m - self.start_height_m < min_height_gain_m
        return window_over & no_progress & (height_m < standing_height_m)


def out_of_bound(env, z_range_m: tuple[float, float], asset_cfg: SceneEntityCfg = ROBOT) -> torch.Tensor:
    """The entity's root height above its env origin is outside `z_range_m`."""
    z = env.scene[asset_cfg.name].root_pos_env[:, 2]
    return (z < z_range_m[0]) | (z > z_range_m[1])
