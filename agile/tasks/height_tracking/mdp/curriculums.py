"""Curriculum terms of the sit-down / stand-up task (AGILE V1.3 HeightTracking-G1): the lift fades as the height
command is tracked, envs move to rougher terrain rows only once the lift is gone, and penalties are raised once
the terrain is mastered. Device tensors and masked math only: no host sync."""

from __future__ import annotations

import torch

from agile.rl_env.managers import ManagerTermBase
from agile.rl_env.mdp.curriculums import OUTCOME_STATE_ATTRS, EpisodeOutcomeCounter

__all__ = ["adaptive_force_decay", "terrain_levels_tracking_at_timeout", "update_reward_weight_after_curriculum"]


class adaptive_force_decay(ManagerTermBase):  # noqa: N801 (AGILE's name)
    """AGILE `adaptive_force_decay` with the height-error metric, decaying when it is below the threshold: on
    every env step with ending episodes, the metric is the mean over them of the command's
    `metrics["height_error_m"]`; its exponential moving average (weight `ema_alpha` on the new value; it starts
    at 1 m, far above any threshold, so nothing decays before episodes have ended well) drives the action's
    scale:
    - EMA < `threshold_m`: scale ×= `decay` (AGILE: 0.9999, about 6,900 such steps to halve);
    - a scale below `disable_below` becomes 0, for good (the scale never rises).
    A step without ending episodes changes nothing. The scale goes to the action (`scale_forces`) on every call;
    returns it."""

    training_state_attrs = ("error_ema_m", "scale")  # restored on resume (ManagerTermBase)

    def __init__(self, cfg, env):
        super().__init__(cfg, env)
        params = cfg.params
        self.action = env.action_manager.get_term(params["action_name"])
        self.command = env.command_manager.get_term(params["command_name"])
        if not 0.0 < params.get("ema_alpha", 0.05) <= 1.0:
            raise ValueError(f"adaptive_force_decay: ema_alpha must be in (0, 1], got {params['ema_alpha']}")
        if not 0.0 < params.get("decay", 0.9999) <= 1.0:
            raise ValueError(f"adaptive_force_decay: decay is a factor per step, within (0, 1], got {params['decay']}")
        self.error_ema_m = torch.ones((), device=env.device)
        self.scale = torch.ones((), device=env.device)

    def __call__(self, env, env_mask, action_name: str, command_name: str, threshold_m: float = 0.1,
                 ema_alpha: float = 0.05, decay: float = 0.9999, disable_below: float = 0.01) -> torch.Tensor:
        num_ended = env_mask.sum()
        any_ended = num_ended > 0
        error_m = (self.command.metrics["height_error_m"] * env_mask).sum() / num_ended.clamp(min=1)
        ema = (1.0 - ema_alpha) * self.error_ema_m + ema_alpha * error_m
        self.error_ema_m.copy_(torch.where(any_ended, ema, self.error_ema_m))
        scale = torch.where(self.error_ema_m < threshold_m, self.scale * decay, self.scale)
        scale = torch.where(scale < disable_below, 0.0, scale)
        self.scale.copy_(torch.where(any_ended, scale, self.scale))
        self.action.scale_forces(self.scale)
        return self.scale.clone()


class terrain_levels_tracking_at_timeout(ManagerTermBase):  # noqa: N801 (AGILE's name)
    """AGILE `terrain_levels_tracking_at_timeout`: an ending episode is a success when it ended by time-out with
    the command's `metrics["height_error_m"]` below `error_threshold_m`, else a failure; an env moves one row
    up after `n_successes` successes, down after `n_failures` failures (each move clears both counts). Only once
    the lift action `lift_action_name` has a scale at or below `max_lift_scale` (AGILE: its prerequisite, the lift
    curriculum below 0.01): until then episodes are not counted and every env stays on its row. Returns the mean
    terrain level."""

    training_state_attrs = OUTCOME_STATE_ATTRS  # restored on resume (ManagerTermBase)

    def __init__(self, cfg, env):
        super().__init__(cfg, env)
        if env.sim.terrain is None:
            raise ValueError("terrain_levels_tracking_at_timeout needs a terrain (SimCfg.terrain)")
        self.command = env.command_manager.get_term(cfg.params["command_name"])
        self.lift = env.action_manager.get_term(cfg.params.get("lift_action_name", "lift"))
        self.outcomes = EpisodeOutcomeCounter(env.num_envs, env.device)

    def __call__(self, env, env_mask, command_name: str, error_threshold_m: float = 0.1, n_successes: int = 5,
                 n_failures: int = 5, lift_action_name: str = "lift", max_lift_scale: float = 0.01) -> torch.Tensor:
        counted = env_mask & (self.lift.scale <= max_lift_scale)
        succeeded = env.termination_manager.time_outs & (self.command.metrics["height_error_m"] < error_threshold_m)
        move_up, move_down = self.outcomes.count(counted, succeeded, ~succeeded, n_successes, n_failures)
        env.sim.update_terrain_levels(move_up, move_down)
        return env.sim.terrain_levels.float().mean()


class update_reward_weight_after_curriculum(ManagerTermBase):  # noqa: N801 (AGILE's name)
    """AGILE `update_reward_weight_after_curriculum`: once the value of the curriculum term
    `prerequisite_curriculum` (what it returned last) first reaches `prerequisite_threshold`, wait `delay_steps`
    env steps, then ramp the reward's weight linearly from its configured value to `terminal_weight` over
    `num_steps` env steps. Returns the weight. The trigger step is a device tensor (-1: not yet)."""

    training_state_attrs = ("trigger_step",)  # restored on resume (ManagerTermBase)

    def __init__(self, cfg, env):
        super().__init__(cfg, env)
        reward_name = cfg.params["reward_name"]
        self.start_weight = env.reward_manager.get_term_cfg(reward_name).weight
        if reward_name not in env.reward_manager.weights:
            raise ValueError(f"reward term '{reward_name}' has weight 0 in the config and is not computed; give it a "
                             f"non-zero weight to ramp it")
        self.trigger_step = torch.full((), -1, dtype=torch.long, device=env.device)

    def __call__(self, env, env_mask, reward_name: str, prerequisite_curriculum: str, prerequisite_threshold: float,
                 delay_steps: int, num_steps: int, terminal_weight: float) -> torch.Tensor:
        steps = torch.as_tensor(env.common_step_counter, device=env.device).long()
        if prerequisite_curriculum not in env.curriculum_manager.term_cfgs:
            raise ValueError(f"update_reward_weight_after_curriculum '{reward_name}': no curriculum term "
                             f"'{prerequisite_curriculum}'; terms: {env.curriculum_manager.active_terms}")
        value = env.curriculum_manager.state.get(prerequisite_curriculum)
        if value is not None:  # known once the prerequisite term has run (a dict lookup, not a tensor value)
            met = torch.as_tensor(value, device=env.device) >= prerequisite_threshold
            self.trigger_step.copy_(torch.where((self.trigger_step < 0) & met, steps, self.trigger_step))
        progress = ((steps - self.trigger_step - delay_steps).float() / max(num_steps, 1)).clamp(0.0, 1.0)
        progress = torch.where(self.trigger_step >= 0, progress, 0.0)
        weight = self.start_weight + progress * (terminal_weight - self.start_weight)
        env.reward_manager.set_term_weight(reward_name, weight)
        return weight
