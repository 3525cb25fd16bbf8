"""Random joint-position targets for joints the policy does not control (AGILE `RandomActionCfg`).

Training-only: the term has action dimension 0, so it is not part of the policy's action vector and the
policy export leaves it out. Every `sample_range_s` a new target, uniform within the joint limits, is reached
through a trapezoidal velocity profile (accelerate, cruise, decelerate), from rest to rest.

Differences from AGILE, so that the commanded target never jumps in position or velocity: a motion always
runs to its end (a new target waits for the current one to be reached, where AGILE restarts mid-motion), and
the profile is evaluated in closed form per joint with that joint's own acceleration.
"""

from __future__ import annotations

from dataclasses import field

import torch

from agile.rl_env.managers import ActionTerm, ActionTermCfg
from agile.sim.names import resolve_names
from agile.utils.config import configclass

TIME_SCALING_METHODS = ("max_time",)


@configclass
class TrapezoidalVelocityProfileCfg:
    acceleration_range: tuple[float, float] = (0.5, 2.0)
    """Acceleration and deceleration [rad/s²], drawn per joint for every motion."""
    max_velocity_range: tuple[float, float] = (0.5, 2.0)
    """Cruise velocity bound [rad/s], drawn per joint for every motion; also bounded by the joint's limit."""
    min_cruise_ratio: float = 0.1
    """Minimum fraction of a motion's duration spent cruising (0: triangular profiles allowed)."""
    synchronize_joints: bool = True
    """All joints of an env start and arrive together."""
    time_scaling_method: str = "max_time"
    """How synchronized joints share a duration: 'max_time' (the slowest joint's minimum time)."""


class TrapezoidalProfile:
    """Rest-to-rest point-to-point motions of (num_envs, num_joints) joints, planned and evaluated in closed form.

    For a distance d, acceleration a and cruise velocity v, a motion of duration T satisfies d = v·T − v²/a
    and spends t_a = v/a accelerating and decelerating. A joint's minimum time uses the largest v allowed by
    its velocity bound and by the minimum cruise ratio (2·t_a <= (1 − r)·T  <=>  v <= √(a·d·(1 − r)/(1 + r)));
    a longer, synchronized T then takes the smaller root v = (a·T − √(a²T² − 4·a·d))/2, which stays below
    that bound, so velocity and acceleration limits hold for every joint.
    """

    def __init__(self, cfg: TrapezoidalVelocityProfileCfg, velocity_limit_rad_s: torch.Tensor):
        if cfg.time_scaling_method not in TIME_SCALING_METHODS:
            raise ValueError(f"time_scaling_method '{cfg.time_scaling_method}' not in {TIME_SCALING_METHODS}")
        if cfg.acceleration_range[0] <= 0.0 or cfg.max_velocity_range[0] <= 0.0:
            raise ValueError("acceleration_range and max_velocity_range must be positive")
        if not 0.0 <= cfg.min_cruise_ratio < 1.0:
            raise ValueError(f"min_cruise_ratio must be in [0, 1), got {cfg.min_cruise_ratio}")
        self.cfg = cfg
        self.velocity_limit_rad_s = velocity_limit_rad_s
        zeros = torch.zeros_like(velocity_limit_rad_s)
        self.start = zeros.clone()
        self.distance = zeros.clone()  # signed [rad]
        self.acceleration = torch.ones_like(zeros)
        self.cruise_velocity = zeros.clone()  # unsigned [rad/s]
        self.duration_s = zeros.clone()
        self.elapsed_s = zeros[:, 0].clone()

    def _uniform(self, low_high: tuple[float, float]) -> torch.Tensor:
        low, high = low_high
        return torch.rand_like(self.start) * (high - low) + low

    @property
    def done(self) -> torch.Tensor:
        """(num_envs,) True where every joint has arrived."""
        return (self.elapsed_s.unsqueeze(-1) >= self.duration_s).all(dim=-1)

    def plan(self, start: torch.Tensor, target: torch.Tensor, mask: torch.Tensor) -> None:
        """Start new motions from rest at `start` to `target` (num_envs, num_joints) where mask (num_envs,) is True."""
        r = self.cfg.min_cruise_ratio
        d = (target - start).abs()
        a = self._uniform(self.cfg.acceleration_range)
        v_bound = torch.minimum(self._uniform(self.cfg.max_velocity_range), self.velocity_limit_rad_s)
        v_best = torch.minimum(v_bound, torch.sqrt(a * d * (1.0 - r) / (1.0 + r)))
        moving = v_best > 0.0
        min_time_s = torch.where(moving, d / torch.where(moving, v_best, 1.0) + v_best / a, 0.0)
        if self.cfg.synchronize_joints:
            duration_s = min_time_s.amax(dim=-1, keepdim=True).expand_as(min_time_s)
        else:
            duration_s = min_time_s
        v = 0.5 * (a * duration_s - torch.sqrt((a * a * duration_s * duration_s - 4.0 * a * d).clamp(min=0.0)))
        m = mask.unsqueeze(-1)
        self.start.copy_(torch.where(m, start, self.start))
        self.distance.copy_(torch.where(m, target - start, self.distance))
        self.acceleration.copy_(torch.where(m, a, self.acceleration))
        self.cruise_velocity.copy_(torch.where(m, v, self.cruise_velocity))
        self.duration_s.copy_(torch.where(m, duration_s, self.duration_s))
        self.elapsed_s.masked_fill_(mask, 0.0)

    def advance(self, dt_s: float) -> None:
        self.elapsed_s += dt_s

    def position(self) -> torch.Tensor:
        """(num_envs, num_joints) positions at the elapsed time."""
        a, v, d, T = self.acceleration, self.cruise_velocity, self.distance.abs(), self.duration_s
        t = torch.minimum(self.elapsed_s.unsqueeze(-1), T)
        t_acc = v / a
        travelled = torch.where(t < t_acc, 0.5 * a * t * t,
                                torch.where(t <= T - t_acc, v * t - 0.5 * v * v / a, d - 0.5 * a * (T - t) ** 2))
        return self.start + torch.sign(self.distance) * travelled


class RandomPositionAction(ActionTerm):
    """Random position targets through a trapezoidal profile on joints outside the policy (training only)."""

    def __init__(self, cfg: RandomActionCfg, env):
        super().__init__(cfg, env)
        robot = env.scene[cfg.asset_name]
        self.robot = robot
        if (cfg.joint_names is None) == (cfg.joint_names_exclude is None):
            raise ValueError("set exactly one of joint_names and joint_names_exclude")
        if cfg.joint_names is not None:
            joint_ids, self.joint_names = robot.find_joints(cfg.joint_names)
        else:
            excluded = robot.find_joints(cfg.joint_names_exclude)[0] if cfg.joint_names_exclude else []
            joint_ids = [i for i in range(robot.num_joints) if i not in excluded]
            self.joint_names = [robot.joint_names[i] for i in joint_ids]
        if not joint_ids:
            raise ValueError("no joints left for random actions")
        self.joint_ids = torch.tensor(joint_ids, dtype=torch.long, device=env.device)
        self.offset = robot.default_joint_pos[:, self.joint_ids].clone()
        self.pos_limits = robot.joint_pos_limits[:, self.joint_ids].clone()  # (N, J, 2) [rad]
        for expr, (low, high) in cfg.joint_pos_limits.items():
            ids, _ = resolve_names(expr, self.joint_names)
            self.pos_limits[:, ids, 0] = float(low)
            self.pos_limits[:, ids, 1] = float(high)
        self.profile = TrapezoidalProfile(cfg.velocity_profile_cfg, robot.joint_vel_limit[:, self.joint_ids].clone())
        self.processed_actions = self.offset.clone()
        """Commanded position targets [rad] of the term's joints."""
        self.time_left_s = self._sample_interval()
        self.profile.plan(self.offset, self.offset, torch.ones(env.num_envs, dtype=torch.bool, device=env.device))

    def _sample_interval(self) -> torch.Tensor:
        low, high = self.cfg.sample_range_s
        return torch.rand(self.env.num_envs, device=self.env.device) * (high - low) + low

    @property
    def action_dim(self) -> int:
        return 0

    def process_actions(self, actions: torch.Tensor) -> None:
        step_dt_s = self.env.step_dt
        self.time_left_s -= step_dt_s
        resample = (self.time_left_s <= 0.0) & self.profile.done
        low, high = self.pos_limits[..., 0], self.pos_limits[..., 1]
        target = torch.rand_like(low) * (high - low) + low
        if self.cfg.no_random_when_walking:
            # AGILE: an env told to walk moves these joints back to their defaults (after the running motion)
            walking = (self.env.command_manager.get_command(self.cfg.command_name)[:, :3] != 0.0).any(dim=1)
            target = torch.where(walking.unsqueeze(-1), self.offset, target)
        self.profile.plan(self.processed_actions, target, resample)
        self.time_left_s.copy_(torch.where(resample, self._sample_interval(), self.time_left_s))
        self.profile.advance(step_dt_s)
        self.processed_actions.copy_(self.profile.position())

    def apply_actions(self) -> None:
        self.robot.joint_pos_target[:, self.joint_ids] = self.processed_actions

    def reset(self, env_mask: torch.Tensor) -> None:
        self.processed_actions.copy_(torch.where(env_mask.unsqueeze(-1), self.offset, self.processed_actions))
        self.profile.plan(self.offset, self.offset, env_mask)
        self.time_left_s.copy_(torch.where(env_mask, self._sample_interval(), self.time_left_s))


@configclass
class RandomActionCfg(ActionTermCfg):
    """AGILE `RandomActionCfg` with a trapezoidal velocity profile. Select joints by `joint_names` or by
    `joint_names_exclude` (every joint not matched), not both."""

    class_type: type = RandomPositionAction
    joint_names: list[str] | None = None
    joint_names_exclude: list[str] | None = None
    sample_range_s: tuple[float, float] = (0.1, 2.5)
    """Time between new targets [s], drawn per env (a running motion finishes first)."""
    velocity_profile_cfg: TrapezoidalVelocityProfileCfg = TrapezoidalVelocityProfileCfg()
    joint_pos_limits: dict[str, tuple[float, float]] = field(default_factory=dict)
    """{joint regex: (low, high)} [rad] replacing the model's limits for target sampling."""
    no_random_when_walking: bool = False
    """Targets are the default positions while the velocity command `command_name` is not zero."""
    command_name: str = "base_velocity"
