"""Curriculum terms: called every env step with the mask of resetting envs; return a value to log."""

from __future__ import annotations

import math

import torch

from agile.rl_env.managers import ManagerTermBase


__all__ = ["EpisodeOutcomeCounter", "OUTCOME_STATE_ATTRS", "pushing_curriculum", "remove_harness",
           "terrain_levels_vel", "update_reward_weight_step", "velocity_command_levels"]

class EpisodeOutcomeCounter:
    """AGILE's terrain-row rule, shared by the terrain curricula: per env, the successful and failed episodes since
    the last move; a move up after `n_successes` successes, down after `n_failures` failures, each move clearing
    both counts. A term holding one as `outcomes` lists `OUTCOME_STATE_ATTRS` in its `training_state_attrs`: a
    resumed training keeps the counts (afresh, no env could move up for its first `n_successes` episodes, ~200
    iterations of a flat terrain curve after every resume)."""

    def __init__(self, num_envs: int, device):
        self.num_successes = torch.zeros(num_envs, dtype=torch.long, device=device)
        self.num_failures = torch.zeros(num_envs, dtype=torch.long, device=device)

    def count(self, env_mask: torch.Tensor, succeeded: torch.Tensor, failed: torch.Tensor, n_successes: int,
              n_failures: int) -> tuple[torch.Tensor, torch.Tensor]:
        """Count the episodes ending where env_mask is True; (move_up, move_down) masks (no host sync)."""
        self.num_successes.add_((env_mask & succeeded).long())
        self.num_failures.add_((env_mask & failed).long())
        move_up = env_mask & (self.num_successes >= n_successes)
        move_down = env_mask & (self.num_failures >= n_failures)
        moved = move_up | move_down
        self.num_successes.masked_fill_(moved, 0)
        self.num_failures.masked_fill_(moved, 0)
        return move_up, move_down


OUTCOME_STATE_ATTRS = ("outcomes.num_successes", "outcomes.num_failures")
"""The `training_state_attrs` of a curriculum term's `outcomes` (an `EpisodeOutcomeCounter`)."""


class update_reward_weight_step(ManagerTermBase):  # noqa: N801 (AGILE's name)
    """Ramp a reward weight from its configured value to `terminal_weight` over `num_steps` env steps,
    starting at `start_step`; linearly, or linearly in log|w| (same sign at both ends)."""

    def __init__(self, cfg, env):
        super().__init__(cfg, env)
        reward_name = cfg.params["reward_name"]
        self.start_weight = env.reward_manager.get_term_cfg(reward_name).weight
        if reward_name not in env.reward_manager.weights:  # found here, not at the first step
            raise ValueError(f"reward term '{reward_name}' has weight 0 in the config and is not computed; give it a "
                             f"non-zero weight to ramp it")
        if cfg.params.get("use_log_space", False):
            terminal = cfg.params["terminal_weight"]
            if self.start_weight * terminal <= 0.0:
                raise ValueError("log-space ramps need start and terminal weights of the same sign, non-zero")

    def __call__(self, env, env_mask, reward_name: str, start_step: int, num_steps: int, terminal_weight: float,
                 use_log_space: bool = False) -> torch.Tensor:
        # the step counter is a device tensor: the ramp runs inside a captured step without host syncs
        steps = torch.as_tensor(env.common_step_counter, dtype=torch.float32, device=env.device)
        progress = ((steps - start_step) / max(num_steps, 1)).clamp(0.0, 1.0)
        if use_log_space:
            log_w = (1 - progress) * math.log(abs(self.start_weight)) + progress * math.log(abs(terminal_weight))
            weight = torch.exp(log_w) * math.copysign(1.0, terminal_weight)
        else:
            weight = self.start_weight + progress * (terminal_weight - self.start_weight)
        env.reward_manager.set_term_weight(reward_name, weight)
        return weight


class terrain_levels_vel(ManagerTermBase):  # noqa: N801 (Isaac Lab's name)
    """AGILE `terrain_levels_vel_curriculum`: an env moves one terrain row up after `n_successes` episodes
    that ended more than `move_up_distance_m` from where they started, and one row down after `n_failures`
    episodes that ended less than `move_down_distance_m` away; each move clears both counts. On top, an
    ending episode moves up with probability `p_random_move_up` (unless it moves down) and down with
    `p_random_move_down` (unless it moves up). Returns the mean terrain level.

    The distance is AGILE's `traveled_distance`: the straight-line displacement summed over the pieces
    between command changes, so turning back on a new command still counts as walking.
    """

    training_state_attrs = OUTCOME_STATE_ATTRS  # restored on resume (ManagerTermBase)

    def __init__(self, cfg, env):
        super().__init__(cfg, env)
        if env.sim.terrain is None:
            raise ValueError("terrain_levels_vel needs a terrain (SimCfg.terrain)")
        n = env.num_envs
        self.outcomes = EpisodeOutcomeCounter(n, env.device)
        self.traveled_distance_m = torch.zeros(n, device=env.device)
        """Displacement of the finished command pieces of the current episode."""
        self.piece_start_xy_w = torch.zeros(n, 2, device=env.device)
        self.last_command = None
        self.restart = torch.ones(n, dtype=torch.bool, device=env.device)
        """Envs whose episode started since the last call: their start point is the current position."""

    def __call__(self, env, env_mask, command_name: str = "base_velocity", move_up_distance_m: float = 4.0,
                 move_down_distance_m: float = 2.0, n_successes: int = 4, n_failures: int = 10,
                 p_random_move_up: float = 0.0, p_random_move_down: float = 0.0) -> torch.Tensor:
        pos_xy = env.scene["robot"].root_pos_w[:, :2]
        command = env.command_manager.get_command(command_name)
        if self.last_command is None:  # first call only, before any capture
            self.last_command = command.clone()
        # an episode starts after the reset of the previous call, one env step late (20 ms of walking lost)
        restart = self.restart.unsqueeze(1)
        self.piece_start_xy_w.copy_(torch.where(restart, pos_xy, self.piece_start_xy_w))
        self.traveled_distance_m.masked_fill_(self.restart, 0.0)
        piece_m = torch.norm(pos_xy - self.piece_start_xy_w, dim=1)
        changed = (command != self.last_command).any(dim=1) & ~self.restart
        self.traveled_distance_m.add_(torch.where(changed, piece_m, 0.0))
        self.piece_start_xy_w.copy_(torch.where(changed.unsqueeze(1), pos_xy, self.piece_start_xy_w))
        self.last_command.copy_(command)
        distance_m = self.traveled_distance_m + torch.norm(pos_xy - self.piece_start_xy_w, dim=1)

        move_up, move_down = self.outcomes.count(env_mask, distance_m > move_up_distance_m,
                                                 distance_m < move_down_distance_m, n_successes, n_failures)
        if p_random_move_up > 0.0:
            move_up = move_up | (env_mask & ~move_down
                                 & (torch.rand(env.num_envs, device=env.device) < p_random_move_up))
        if p_random_move_down > 0.0:
            move_down = move_down | (env_mask & ~move_up
                                     & (torch.rand(env.num_envs, device=env.device) < p_random_move_down))
        env.sim.update_terrain_levels(move_up, move_down)
        self.restart.copy_(env_mask)
        return env.sim.terrain_levels.float().mean()


class velocity_command_levels(ManagerTermBase):  # noqa: N801 (curriculum terms are named as functions)
    """Velocity command ranges that widen as the robot learns to track them (legged_gym's command curriculum,
    Isaac Lab's `command_levels_vel`; not AGILE's, and off unless `start_fraction` < 1). Every range of the
    command term starts at `start_fraction` of its configured one and widens by `step_fraction` of it (up to all of
    it) at each checked step (every `interval_steps` env steps) where the episodes ending then tracked every reward
    of `reward_names` well: the mean over those episodes of the term's episode sum / (its weight x the episode's
    seconds), i.e. the mean value of its tracking kernel in (0, 1], above `threshold`. Why: AGILE's tracking kernels
    are narrow (std 0.2), so a policy that does not yet turn scores ~0 on most yaw commands of +-1 rad/s and gets
    little gradient from them. Device tensors only (runs inside a captured step). Returns the fraction."""

    training_state_attrs = ("fraction",)  # restored on resume (ManagerTermBase)

    def __init__(self, cfg, env):
        super().__init__(cfg, env)
        params = cfg.params
        start = float(params.get("start_fraction", 1.0))
        step, threshold = params.get("step_fraction", 0.1), params.get("threshold", 0.5)
        interval = params.get("interval_steps", 1000)
        for name, value, ok, rule in (("start_fraction", start, 0.0 < start <= 1.0, "within (0, 1]"),
                                      ("step_fraction", step, step > 0.0, "> 0"),
                                      ("threshold", threshold, 0.0 < threshold < 1.0, "within (0, 1)"),
                                      ("interval_steps", interval, interval >= 1, ">= 1")):
            if not ok:
                raise ValueError(f"velocity_command_levels: {name} must be {rule}, got {value}")
        for name in params["reward_names"]:
            if name not in env.reward_manager.weights:
                raise ValueError(f"velocity_command_levels: no reward term '{name}' with a non-zero weight; terms: "
                                 f"{sorted(env.reward_manager.weights)}")
        command_name = params.get("command_name", "base_velocity")
        self.command = env.command_manager.get_term(command_name)
        if not (isinstance(getattr(self.command, "low", None), torch.Tensor)
                and isinstance(getattr(self.command, "high", None), torch.Tensor)):
            raise ValueError(f"velocity_command_levels: command '{command_name}' ({type(self.command).__name__}) "
                             f"draws from no `low` / `high` range tensors (UniformNullVelocityCommand does)")
        self.full_low, self.full_high = self.command.low.clone(), self.command.high.clone()
        self.fraction = torch.full((), start, device=env.device)
        self.active = start < 1.0
        """Off (start_fraction 1): no kernel at all, the configured ranges untouched."""
        self.set_ranges()

    def set_ranges(self) -> None:
        self.command.low.copy_(self.full_low * self.fraction)
        self.command.high.copy_(self.full_high * self.fraction)

    def __call__(self, env, env_mask, reward_names: list[str], command_name: str = "base_velocity",
                 start_fraction: float = 1.0, step_fraction: float = 0.1, threshold: float = 0.5,
                 interval_steps: int = 1000) -> torch.Tensor:
        if not self.active:
            return self.fraction
        rewards = env.reward_manager
        length_s = env.episode_length_buf.float().clamp(min=1.0) * env.step_dt
        ended = env_mask.float()
        count = ended.sum()
        tracked = count > 0
        for name in reward_names:
            kernel_mean = rewards.episode_sums[name] / (rewards.weights[name] * length_s)
            tracked = tracked & ((kernel_mean * ended).sum() > threshold * count)
        checked = torch.remainder(env.common_step_counter, interval_steps) == 0
        widened = (self.fraction + step_fraction).clamp(max=1.0)
        self.fraction.copy_(torch.where(checked & tracked, widened, self.fraction))
        self.set_ranges()  # also after a resume restored the fraction
        return self.fraction


def remove_harness(env, env_mask, harness_action_name: str, start_step: int, num_steps: int) -> torch.Tensor:
    """AGILE `remove_harness` (linear): the harness strength falls from 1 at `start_step` to 0 after
    `num_steps` more env steps, then stays 0. Returns the strength."""
    steps = torch.as_tensor(env.common_step_counter, dtype=torch.float32, device=env.device)
    scale = 1.0 - ((steps - start_step) / max(num_steps, 1)).clamp(0.0, 1.0)
    env.action_manager.get_term(harness_action_name).scale_forces(scale)
    return scale


class pushing_curriculum(ManagerTermBase):  # noqa: N801 (AGILE's name)
    """AGILE `pushing_curriculum`: the push event's velocity ranges grow ×`growth` per env step while the share
    of finishing episodes that fell (ended other than by time-out) is below the lower of
    `fall_ratio_thresholds`, and shrink ×(2 - `growth`) (AGILE: 1.0001 and 0.9999) while it is above the upper
    one; each axis's half-width stays within [min_vel, max_vel] (ranges are symmetric about 0; an axis not in
    max_vel does not change). Steps
    without a finishing episode change nothing. Returns the x range's upper bound [m/s].

    The ranges live on the device as a per-axis scale of the event's configured `velocity_range`, which the
    event (`push_by_setting_velocity`, param `velocity_scale`) multiplies its draws by: no host sync, so it
    runs inside a captured step.
    """

    training_state_attrs = ("scale",)  # restored on resume (ManagerTermBase)

    AXES = ("x", "y", "z", "roll", "pitch", "yaw")

    def __init__(self, cfg, env):
        super().__init__(cfg, env)
        event_name = cfg.params.get("event_name", "push_robot")
        event = env.event_manager.term_cfgs.get(event_name)
        if event is None:
            raise ValueError(f"pushing_curriculum: no event term '{event_name}'")
        ranges = event.params["velocity_range"]
        base = [max(abs(ranges.get(a, (0.0, 0.0))[0]), abs(ranges.get(a, (0.0, 0.0))[1])) for a in self.AXES]
        self.base_mps = torch.tensor(base, device=env.device)
        """Half-width of each axis's configured range [m/s, rad/s]."""
        safe = self.base_mps.clamp(min=1e-9)
        max_vel, min_vel = cfg.params["max_vel"], cfg.params["min_vel"]
        self.max_scale = torch.tensor([max_vel.get(a, b) for a, b in zip(self.AXES, base)], device=env.device) / safe
        # as AGILE, an axis without a max_vel keeps its configured range
        self.min_scale = torch.tensor([min_vel.get(a, 0.0) if a in max_vel else b for a, b in zip(self.AXES, base)],
                                      device=env.device) / safe
        self.scale = torch.ones(6, device=env.device)
        event.params["velocity_scale"] = self.scale

    def __call__(self, env, env_mask, max_vel: dict[str, float], min_vel: dict[str, float],
                 fall_ratio_thresholds: tuple[float, float], growth: float = 1.0001,
                 event_name: str = "push_robot") -> torch.Tensor:
        finished = env_mask.sum()
        fallen = (env_mask & ~env.termination_manager.time_outs).sum()
        ratio = fallen / finished.clamp(min=1)
        grow = (finished > 0) & (ratio < min(fall_ratio_thresholds))
        shrink = (finished > 0) & (ratio > max(fall_ratio_thresholds))
        factor = torch.where(grow, growth, torch.where(shrink, 2.0 - growth, 1.0))
        self.scale.copy_(torch.minimum(torch.maximum(self.scale * factor, self.min_scale), self.max_scale))
        return self.base_mps[0] * self.scale[0]
