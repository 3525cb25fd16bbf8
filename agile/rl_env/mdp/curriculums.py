"""Curriculum terms: called every env step with the mask of resetting envs; return a value to log."""

from __future__ import annotations

import math

import torch

from agile.rl_env.managers import ManagerTermBase


class update_reward_weight_step(ManagerTermBase):  # noqa: N801 (AGILE's name)
    """Ramp a reward weight from its configured value to `terminal_weight` over `num_steps` env steps,
    starting at `start_step`; linearly, or linearly in log|w| (same sign at both ends)."""

    def __init__(self, cfg, env):
        super().__init__(cfg, env)
        self.start_weight = env.reward_manager.get_term_cfg(cfg.params["reward_name"]).weight
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
