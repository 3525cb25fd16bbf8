"""Command manager: command terms (classes) resampled on timers and at resets."""

from __future__ import annotations

import torch

from agile.rl_env.managers.manager_base import build_class_terms
from agile.utils.config import check_range


class CommandTerm:
    """Base of command terms: keeps a per-env resampling timer; subclasses define `command` and `_resample`."""

    def __init__(self, cfg, env):
        self.cfg = cfg
        self.env = env
        check_range("resampling_time_range_s", cfg.resampling_time_range_s, minimum=0.0)
        self.time_left_s = torch.zeros(env.num_envs, device=env.device)

    @property
    def command(self) -> torch.Tensor:
        raise NotImplementedError

    def _resample(self, env_mask: torch.Tensor) -> None:
        raise NotImplementedError

    def _update_command(self) -> None:
        """Per-step update after resampling (e.g. heading control)."""

    def _draw_time_left(self, env_mask: torch.Tensor) -> None:
        low, high = self.cfg.resampling_time_range_s
        draw = torch.rand(self.env.num_envs, device=self.env.device) * (high - low) + low
        self.time_left_s.copy_(torch.where(env_mask, draw, self.time_left_s))

    def compute(self, dt: float) -> None:
        self.time_left_s -= dt
        mask = self.time_left_s <= 0.0
        self._draw_time_left(mask)
        self._resample(mask)
        self._update_command()

    def reset(self, env_mask: torch.Tensor) -> dict:
        self._draw_time_left(env_mask)
        self._resample(env_mask)
        self._update_command()
        return {}


class CommandManager:
    def __init__(self, cfg, env):
        self.env = env
        self.terms: dict[str, CommandTerm] = build_class_terms(cfg, env, "command")

    @property
    def active_terms(self) -> list[str]:
        return list(self.terms)

    def get_term(self, name: str) -> CommandTerm:
        if name not in self.terms:
            raise KeyError(f"no command term '{name}'. Terms: {self.active_terms}")
        return self.terms[name]

    def get_command(self, name: str) -> torch.Tensor:
        return self.get_term(name).command

    def compute(self, dt: float) -> None:
        for term in self.terms.values():
            term.compute(dt)

    def reset(self, env_mask: torch.Tensor) -> dict:
        for term in self.terms.values():
            term.reset(env_mask)
        return {}
