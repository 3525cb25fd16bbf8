"""Base velocity and base height command (AGILE `UniformVelocityBaseHeightCommand`): walk at (vx, vy, wz), or
stand still at a height between a crouch and full stance."""

from __future__ import annotations

import math
from dataclasses import field

import torch

from agile.rl_env.managers import CommandTerm
from agile.rl_env.managers.command_manager import VELOCITY_FIELDS
from agile.utils.config import check_range, configclass
from agile.utils.math import wrap_to_pi


class UniformVelocityBaseHeightCommand(CommandTerm):
    """Command (N, 4): vx, vy [m/s] and wz [rad/s] in the base yaw frame, then the base height [m] above the
    terrain.

    At each resampling:
    - the velocity is drawn uniformly; a share `rel_standing_envs` of the draws, and any draw whose norm is
      below `min_vel_norm`, stand still (velocity exactly 0, so that rewards can test `command[:, :3] == 0`);
    - a standing env draws its height uniformly in `ranges.base_height_m` (it may crouch);
    - a walking env walks at `default_height_m`, or with `random_height_during_walking` at a uniform height
      of at least `min_walk_height_m` (a crouched walk is not asked for).
    The height command then moves towards its new target by the fraction `ema_smoothing` per env step, so a
    change of height (crouch to stand) is a ramp, not a step; at an episode start it is the target at once.
    With `heading_command`, a share `rel_heading_envs` of walking envs get wz from a heading target instead:
    wz = clip(heading_control_stiffness · wrap(heading_target - heading), ranges.ang_vel_z).
    """

    command_fields = (*VELOCITY_FIELDS, "base_height_m")

    def __init__(self, cfg: UniformVelocityBaseHeightCommandCfg, env):
        super().__init__(cfg, env)
        r = cfg.ranges
        for name in ("lin_vel_x", "lin_vel_y", "ang_vel_z", "heading_rad"):
            check_range(f"ranges.{name}", getattr(r, name))
        check_range("ranges.base_height_m", r.base_height_m, minimum=0.0)
        if not 0.0 <= cfg.rel_standing_envs <= 1.0:
            raise ValueError(f"rel_standing_envs is a share of the envs, within [0, 1], got {cfg.rel_standing_envs}")
        if not 0.0 <= cfg.rel_heading_envs <= 1.0:
            raise ValueError(f"rel_heading_envs is a share of the envs, within [0, 1], got {cfg.rel_heading_envs}")
        if not 0.0 < cfg.ema_smoothing <= 1.0:
            raise ValueError(f"ema_smoothing is the fraction of the way to the target per step, within (0, 1], "
                             f"got {cfg.ema_smoothing}")
        if not r.base_height_m[0] <= cfg.min_walk_height_m <= r.base_height_m[1]:
            raise ValueError(f"min_walk_height_m {cfg.min_walk_height_m} must lie within ranges.base_height_m "
                             f"{tuple(r.base_height_m)}")
        if not cfg.min_walk_height_m <= cfg.default_height_m <= r.base_height_m[1]:
            raise ValueError(f"default_height_m {cfg.default_height_m} must lie within [min_walk_height_m, "
                             f"ranges.base_height_m[1]] = [{cfg.min_walk_height_m}, {r.base_height_m[1]}]")
        n, device = env.num_envs, env.device
        self.robot = env.scene[cfg.asset_name]
        self.vel_low = torch.tensor([r.lin_vel_x[0], r.lin_vel_y[0], r.ang_vel_z[0]], device=device)
        self.vel_high = torch.tensor([r.lin_vel_x[1], r.lin_vel_y[1], r.ang_vel_z[1]], device=device)
        self.command_buf = torch.zeros(n, 4, device=device)
        self.vel_command_b = self.command_buf[:, :3]
        """(N, 3) view: vx, vy, wz."""
        self.height_command_m = self.command_buf[:, 3]
        """(N,) view: the smoothed height command."""
        self.height_target_m = torch.full((n,), cfg.default_height_m, device=device)
        """(N,) the height drawn at the last resampling, which the command moves towards."""
        self.height_command_m.fill_(cfg.default_height_m)
        self.is_standing_env = torch.zeros(n, dtype=torch.bool, device=device)
        self.is_heading_env = torch.zeros(n, dtype=torch.bool, device=device)
        self.heading_target_rad = torch.zeros(n, device=device)

    @property
    def command(self) -> torch.Tensor:
        return self.command_buf

    def _uniform(self, low_high: tuple[float, float]) -> torch.Tensor:
        low, high = low_high
        return torch.rand(self.env.num_envs, device=self.env.device) * (high - low) + low

    def _resample(self, env_mask: torch.Tensor) -> None:
        cfg, n, device = self.cfg, self.env.num_envs, self.env.device
        draw = torch.rand(n, 3, device=device) * (self.vel_high - self.vel_low) + self.vel_low
        standing = torch.rand(n, device=device) < cfg.rel_standing_envs
        standing |= torch.linalg.norm(draw, dim=1) < cfg.min_vel_norm
        draw = torch.where(standing.unsqueeze(-1), 0.0, draw)
        if cfg.random_height_during_walking:
            walk_height = self._uniform((cfg.min_walk_height_m, cfg.ranges.base_height_m[1]))
        else:
            walk_height = torch.full((n,), cfg.default_height_m, device=device)
        height = torch.where(standing, self._uniform(cfg.ranges.base_height_m), walk_height)
        heading_share = cfg.rel_heading_envs if cfg.heading_command else 0.0
        heading = torch.rand(n, device=device) < heading_share
        m = env_mask.unsqueeze(-1)
        self.vel_command_b.copy_(torch.where(m, draw, self.vel_command_b))
        self.height_target_m.copy_(torch.where(env_mask, height, self.height_target_m))
        self.is_standing_env.copy_(torch.where(env_mask, standing, self.is_standing_env))
        self.is_heading_env.copy_(torch.where(env_mask, heading, self.is_heading_env))
        self.heading_target_rad.copy_(torch.where(env_mask, self._uniform(cfg.ranges.heading_rad),
                                                  self.heading_target_rad))

    def _update_command(self) -> None:
        cfg = self.cfg
        if cfg.heading_command:
            error = wrap_to_pi(self.heading_target_rad - self.robot.heading_w)
            wz = (cfg.heading_control_stiffness * error).clamp(cfg.ranges.ang_vel_z[0], cfg.ranges.ang_vel_z[1])
            follow = self.is_heading_env & ~self.is_standing_env
            self.vel_command_b[:, 2] = torch.where(follow, wz, self.vel_command_b[:, 2])
        alpha = cfg.ema_smoothing
        self.height_command_m.mul_(1.0 - alpha).add_(alpha * self.height_target_m)

    def _start_episodes(self, env_mask: torch.Tensor) -> None:
        # a new episode starts at its drawn height, not on a ramp from the last episode's
        self.height_command_m.copy_(torch.where(env_mask, self.height_target_m, self.height_command_m))


@configclass
class VelocityHeightRangesCfg:
    lin_vel_x: tuple[float, float] = (-0.5, 0.5)  # [m/s]
    lin_vel_y: tuple[float, float] = (-0.5, 0.5)  # [m/s]
    ang_vel_z: tuple[float, float] = (-1.0, 1.0)  # [rad/s]
    heading_rad: tuple[float, float] = (-math.pi, math.pi)
    base_height_m: tuple[float, float] = (0.4, 0.72)


@configclass
class UniformVelocityBaseHeightCommandCfg:
    class_type: type = UniformVelocityBaseHeightCommand
    asset_name: str = "robot"
    resampling_time_range_s: tuple[float, float] = (7.5, 10.0)
    rel_standing_envs: float = 0.1
    min_vel_norm: float = 0.1
    ema_smoothing: float = 0.5
    """Fraction of the way from the height command to its target covered per env step (1: no smoothing)."""
    default_height_m: float = 0.72
    """The walking height when `random_height_during_walking` is off (G1's nominal pelvis height)."""
    min_walk_height_m: float = 0.5
    random_height_during_walking: bool = False
    height_sensor_name: str | None = None
    """The height scanner under the base that measures the height this command asks for (rewards and evaluation
    read the height above the terrain through it); None: above z = 0."""
    heading_command: bool = False
    rel_heading_envs: float = 1.0
    heading_control_stiffness: float = 0.5
    ranges: VelocityHeightRangesCfg = field(default_factory=VelocityHeightRangesCfg)
