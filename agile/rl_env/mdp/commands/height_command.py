"""Height command of the sit-down / stand-up task (AGILE V1.3 `SmoothHeightCommand`): a target height above the
terrain for one point of the robot, which it must reach and hold, from lying relaxed to standing.

What the numbers of HeightTracking-G1 mean: the tracked point is 0.2 m above the origin of `torso_link` along
the torso's own z axis (roughly the chest; the torso origin sits at the waist joint, 0.044 m above the pelvis).
The top of the range, 0.92 m, is "stand" (AGILE: its pelvis height 0.72 m + 0.2 m); measured, G1 in its default
pose reads 1.00 m (its pelvis 0.76 m up), an upright crouch with the pelvis at 0.68 m reads 0.92 m, and a lying
robot 0.04-0.19 m (docs/height_tracking.md). The range reaches down to -0.5 m,
a height no point of the robot can be at: a negative command is not a height to track but a request to lie down
and relax, the more negative the more relaxed (`relaxation_intensity`, which `relaxation_penalty` scales by);
the height rewards then pull the point as low as it can go. Commands from 0 to 0.92 m ask for a sitting, kneeling
or crouching height in between.
"""

from __future__ import annotations

from dataclasses import field

import torch

from agile.rl_env.managers import CommandTerm
from agile.rl_env.managers.command_manager import CommandError
from agile.utils.config import check_range, configclass
from agile.utils.math import quat_rotate

__all__ = ["SmoothHeightCommand", "SmoothHeightCommandCfg", "SmoothHeightRangesCfg"]

HEIGHT_ERROR_BIN_EDGES_M = (0.2, 0.4, 0.6, 0.8, 0.9)
"""Bins of the commanded height for evaluation: sitting low to crouching, then standing (0.92 m for G1)."""


class SmoothHeightCommand(CommandTerm):
    """Command (N, 1): the target height [m] of the tracked point (`body_name` origin + `offset_b_m` in the body's
    frame) above the mean terrain height under the height scanner `height_sensor`.

    At each resampling (every `resampling_time_range_s`), per env, one uniform draw u:
    - u < standing_ratio: the top of `ranges.height_m` (stand);
    - standing_ratio <= u < standing_ratio + flat_ratio: the bottom (lie relaxed);
    - otherwise a uniform height in the range.
    The command moves towards the drawn target at a speed drawn in `ramp_speed_range_mps` at the same resampling
    (AGILE's HeightTracking-G1: 1000 m/s, i.e. it jumps there at the next step). A new episode's command starts at
    the point's measured height (clamped to the range), so the first target is approached from where the robot is.

    `settled`: more than `settle_time_s` since the last resampling. `metrics["height_error_m"]` (AGILE's
    `height_error` metric, which `adaptive_force_decay` reads when episodes end): the mean over the episode's
    steps that are settled and whose command is >= 0 (a relaxation command is not a height to reach) of
    |measured - command|; 0 for an episode without such a step. It is counted in `compute`, on the settle clock, as
    AGILE does: an episode's last state does not count (nor its reset state, unless settle_time_s is 0).
    """

    def __init__(self, cfg: SmoothHeightCommandCfg, env):
        super().__init__(cfg, env)
        check_range("ranges.height_m", cfg.ranges.height_m)
        check_range("ramp_speed_range_mps", cfg.ramp_speed_range_mps)
        if cfg.ramp_speed_range_mps[0] <= 0.0:
            raise ValueError(f"ramp_speed_range_mps must be positive (a command that never moves), got "
                             f"{tuple(cfg.ramp_speed_range_mps)}")
        for name in ("standing_ratio", "flat_ratio"):
            if not 0.0 <= getattr(cfg, name) <= 1.0:
                raise ValueError(f"{name} is a share of the resamplings, within [0, 1], got {getattr(cfg, name)}")
        if cfg.standing_ratio + cfg.flat_ratio > 1.0:
            raise ValueError(f"standing_ratio + flat_ratio must not exceed 1, got {cfg.standing_ratio} + "
                             f"{cfg.flat_ratio}")
        if cfg.settle_time_s < 0.0:
            raise ValueError(f"settle_time_s must be >= 0, got {cfg.settle_time_s}")
        if cfg.error_weighted_bands < 0:
            raise ValueError(f"error_weighted_bands must be >= 0 (0: AGILE's uniform draws), got {cfg.error_weighted_bands}")
        if not 0.0 < cfg.band_error_ema_alpha <= 1.0:
            raise ValueError(f"band_error_ema_alpha must be within (0, 1], got {cfg.band_error_ema_alpha}")
        if cfg.error_weighted_bands and cfg.ranges.height_m[1] <= 0.0:
            raise ValueError(f"error_weighted_bands needs heights above 0 m in ranges.height_m, got "
                             f"{tuple(cfg.ranges.height_m)}")
        self.robot = env.scene[cfg.asset_name]
        ids, names = self.robot.find_bodies(cfg.body_name)
        if len(ids) != 1:
            raise ValueError(f"height command body_name '{cfg.body_name}' must match one body, matched {names}; "
                             f"bodies: {self.robot.body_names}")
        self.body_id = ids[0]
        self.scanner = env.scene[cfg.height_sensor]
        n, device = env.num_envs, env.device
        self.offset_b_m = torch.tensor(cfg.offset_b_m, dtype=torch.float32, device=device).expand(n, 3)
        self.command_buf = torch.zeros(n, 1, device=device)
        self.target_height_m = self.command_buf[:, 0]
        """(N,) view: the current height command [m] (what the rewards and the lift track)."""
        self.drawn_height_m = torch.zeros(n, device=device)
        """(N,) the height drawn at the last resampling, which the command moves towards [m]."""
        self.ramp_speed_mps = torch.zeros(n, device=device)
        self.steps_since_resample = torch.zeros(n, dtype=torch.long, device=device)
        self.settle_steps = int(cfg.settle_time_s / env.step_dt)
        self._height_error = self._episode_mean("height_error_m")
        bands = cfg.error_weighted_bands
        low_m, high_m = cfg.ranges.height_m
        self.band_edges_m = torch.linspace(max(low_m, 0.0), high_m, bands + 1, device=device) if bands else None
        """(N bands + 1,) the bands' edges [m] (with `error_weighted_bands`)."""
        self.band_inner_edges_m = self.band_edges_m[1:-1].contiguous() if bands else None
        self.band_error_ema_m = torch.full((bands,), 0.1, device=device) if bands else None
        """(N bands,) each band's running height error [m] over the settled steps whose command is in it."""

    @property
    def command(self) -> torch.Tensor:
        return self.command_buf

    def tracked_point_pos_w(self) -> torch.Tensor:
        """(N, 3) world position of the tracked point [m]."""
        pose = self.robot.body_pose_w[:, self.body_id]
        return pose[:, :3] + quat_rotate(pose[:, 3:7], self.offset_b_m)

    @property
    def measured_height_m(self) -> torch.Tensor:
        """(N,) the tracked point's height above the mean terrain height under the scanner [m]."""
        return self.tracked_point_pos_w()[:, 2] - self.scanner.hit_z_m.mean(dim=1)

    @property
    def settled(self) -> torch.Tensor:
        """(N,) bool: more than settle_time_s since the last resampling."""
        return self.steps_since_resample > self.settle_steps

    @property
    def relaxation_intensity(self) -> torch.Tensor:
        """(N,) in [0, 1]: 0 for a command >= 0, rising linearly to 1 at the bottom of the range (if negative)."""
        lowest_m = self.cfg.ranges.height_m[0]
        if lowest_m >= 0.0:  # a config value: no negative commands, nothing to relax
            return torch.zeros_like(self.target_height_m)
        return (self.target_height_m / lowest_m).clamp(0.0, 1.0)

    def command_error(self) -> CommandError:
        """|measured - commanded| on the steps the `height_error_m` metric counts (settled, a command >= 0)."""
        measured = self.measured_height_m
        return CommandError("height_error_m", "height_m", self.target_height_m, (measured - self.target_height_m).abs(),
                            measured, self.settled & (self.target_height_m >= 0.0), HEIGHT_ERROR_BIN_EDGES_M)

    def _resample(self, env_mask: torch.Tensor) -> None:
        cfg, n, device = self.cfg, self.env.num_envs, self.env.device
        low_m, high_m = cfg.ranges.height_m
        u = torch.rand(n, device=device)
        uniform_m = torch.rand(n, device=device) * (high_m - low_m) + low_m
        if cfg.error_weighted_bands:
            uniform_m = torch.where(uniform_m >= 0.0, self._draw_from_bands(n), uniform_m)
        height_m = torch.where(u < cfg.standing_ratio, high_m,
                               torch.where(u < cfg.standing_ratio + cfg.flat_ratio, low_m, uniform_m))
        low_speed, high_speed = cfg.ramp_speed_range_mps
        speed = torch.rand(n, device=device) * (high_speed - low_speed) + low_speed
        self.drawn_height_m.copy_(torch.where(env_mask, height_m, self.drawn_height_m))
        self.ramp_speed_mps.copy_(torch.where(env_mask, speed, self.ramp_speed_mps))
        self.steps_since_resample.masked_fill_(env_mask, 0)

    def _update_command(self) -> None:
        max_step_m = self.ramp_speed_mps * self.env.step_dt
        step_m = torch.clamp(self.drawn_height_m - self.target_height_m, -max_step_m, max_step_m)
        self.target_height_m.add_(step_m)

    def compute(self, dt: float) -> None:
        # the settle clock and the height error before the resampling (AGILE's order)
        self.steps_since_resample.add_(1)
        step = self.command_error()  # the one definition of the error, shared with evaluation's bins
        self._height_error.add(step.error, counted=step.counted)
        if self.cfg.error_weighted_bands:
            self._update_band_errors(step.error, step.counted)
        super().compute(dt)

    def _update_band_errors(self, error_m: torch.Tensor, counted: torch.Tensor) -> None:
        """One env step of each band's running error: the mean over the counted envs whose command is in it."""
        counted = counted & torch.isfinite(error_m)
        band = torch.bucketize(self.target_height_m, self.band_inner_edges_m)
        sums = torch.zeros_like(self.band_error_ema_m).scatter_add_(0, band, torch.where(counted, error_m, 0.0))
        counts = torch.zeros_like(self.band_error_ema_m).scatter_add_(0, band, counted.float())
        alpha = self.cfg.band_error_ema_alpha
        updated = (1.0 - alpha) * self.band_error_ema_m + alpha * sums / counts.clamp(min=1.0)
        self.band_error_ema_m.copy_(torch.where(counts > 0, updated, self.band_error_ema_m))

    def band_probabilities(self) -> torch.Tensor:
        """(N bands,) how likely a draw at or above 0 m falls in each band: half uniform, half by running error."""
        ema = self.band_error_ema_m
        return 0.5 / len(ema) + 0.5 * ema / ema.sum().clamp(min=1e-9)

    def _draw_from_bands(self, n: int) -> torch.Tensor:
        """(n,) heights [m]: a band by `band_probabilities`, then uniform within it (on the device: no host sync)."""
        cdf = torch.cumsum(self.band_probabilities(), dim=0)
        u = torch.rand(n, device=cdf.device) * cdf[-1]
        band = torch.searchsorted(cdf, u).clamp(max=len(cdf) - 1)
        width_m = self.band_edges_m[1] - self.band_edges_m[0]
        return self.band_edges_m[band] + torch.rand(n, device=cdf.device) * width_m

    def _start_episodes(self, env_mask: torch.Tensor) -> None:
        low_m, high_m = self.cfg.ranges.height_m
        start_m = self.measured_height_m.clamp(low_m, high_m)
        self.target_height_m.copy_(torch.where(env_mask, start_m, self.target_height_m))


@configclass
class SmoothHeightRangesCfg:
    height_m: tuple[float, float] = (0.0, 0.75)
    """Range of target heights [m]; a negative bottom adds relaxation commands (see the module docstring)."""


@configclass
class SmoothHeightCommandCfg:
    class_type: type = SmoothHeightCommand
    asset_name: str = "robot"
    body_name: str = "torso_link"
    """The body whose point is tracked."""
    offset_b_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """The tracked point in the body's frame [m] (AGILE `offset.pos`)."""
    height_sensor: str = "height_measurement_sensor"
    """Height scanner whose mean hit height is the terrain height under the robot."""
    resampling_time_range_s: tuple[float, float] = (1.0, 7.0)
    ramp_speed_range_mps: tuple[float, float] = (0.05, 0.5)
    """Speed of the command towards a new target, drawn per resampling [m/s] (AGILE `velocity_range`); very large
    values (1000) make the command jump."""
    standing_ratio: float = 0.0
    """Share of resamplings that draw the top of the range."""
    flat_ratio: float = 0.0
    """Share of resamplings that draw the bottom of the range."""
    settle_time_s: float = 1.0
    """Time after a resampling before tracking counts (`settled`, the height-error metric)."""
    error_weighted_bands: int = 0
    """0 (AGILE): the uniform draws are uniform over the range. N > 0: a uniform draw at or above 0 m is replaced by
    a height in one of N equal bands of [0, top], the band picked with probability half uniform, half in proportion to
    its running height error (`band_error_ema_m`): more practice where the tracking is worst. Relaxation (negative)
    draws keep their share. The running errors start equal and are not saved with checkpoints (a resumed run
    relearns them within about 1 / `band_error_ema_alpha` env steps)."""
    band_error_ema_alpha: float = 0.01
    """Weight of one env step's mean error in a band's running error (steps where no settled env is in the band
    leave it as it is)."""
    ranges: SmoothHeightRangesCfg = field(default_factory=SmoothHeightRangesCfg)
