"""Uniform base-velocity command with a share of standing envs (AGILE `UniformNullVelocityCommand`)."""

from __future__ import annotations

from dataclasses import field

import torch

from agile.rl_env.managers import CommandTerm
from agile.rl_env.managers.command_manager import VELOCITY_FIELDS
from agile.utils.config import check_range, configclass


class UniformNullVelocityCommand(CommandTerm):
    """Command (vx, vy, wz) in the base yaw frame [m/s, m/s, rad/s], drawn uniformly at each resampling.

    A share `rel_standing_envs` of draws is exactly zero, and any draw whose norm is below
    `min_vel_norm` is zeroed too, so that "stand still" is a well-defined command.
    """

    command_fields = VELOCITY_FIELDS

    def __init__(self, cfg: UniformNullVelocityCommandCfg, env):
        super().__init__(cfg, env)
        r = cfg.ranges
        for name in ("lin_vel_x", "lin_vel_y", "ang_vel_z"):
            check_range(f"ranges.{name}", getattr(r, name))
        if not 0.0 <= cfg.rel_standing_envs <= 1.0:
            raise ValueError(f"rel_standing_envs is a share of the envs, within [0, 1], got {cfg.rel_standing_envs}")
        self.low = torch.tensor([r.lin_vel_x[0], r.lin_vel_y[0], r.ang_vel_z[0]], device=env.device)
        self.high = torch.tensor([r.lin_vel_x[1], r.lin_vel_y[1], r.ang_vel_z[1]], device=env.device)
        self.vel_command_b = torch.zeros(env.num_envs, 3, device=env.device)
        self.is_standing_env = torch.zeros(env.num_envs, dtype=torch.bool, device=env.device)

    @property
    def command(self) -> torch.Tensor:
        return self.vel_command_b

    def _resample(self, env_mask: torch.Tensor) -> None:
        n = self.env.num_envs
        draw = torch.rand(n, 3, device=self.env.device) * (self.high - self.low) + self.low
        standing = torch.rand(n, device=self.env.device) < self.cfg.rel_standing_envs
        standing |= torch.linalg.norm(draw, dim=1) < self.cfg.min_vel_norm
        draw = torch.where(standing.unsqueeze(-1), 0.0, draw)
        self.vel_command_b.copy_(torch.where(env_mask.unsqueeze(-1), draw, self.vel_command_b))
        self.is_standing_env.copy_(torch.where(env_mask, standing, self.is_standing_env))


@configclass
class VelocityRangesCfg:
    lin_vel_x: tuple[float, float] = (-0.5, 0.5)  # [m/s]
    lin_vel_y: tuple[float, float] = (-0.5, 0.5)  # [m/s]
    ang_vel_z: tuple[float, float] = (-1.0, 1.0)  # [rad/s]


@configclass
class UniformNullVelocityCommandCfg:
    class_type: type = UniformNullVelocityCommand
    resampling_time_range_s: tuple[float, float] = (8.0, 12.0)
    rel_standing_envs: float = 0.25
    min_vel_norm: float = 0.1
    ranges: VelocityRangesCfg = field(default_factory=VelocityRangesCfg)
