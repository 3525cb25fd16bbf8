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
        self.fixed_command: torch.Tensor | None = None
        """(N, D) values that replace the drawn command of every env while set (`set_fixed_command`): evaluation
        at chosen commands, a different one per env if wished."""

    @property
    def command(self) -> torch.Tensor:
        raise NotImplementedError

    def _resample(self, env_mask: torch.Tensor) -> None:
        raise NotImplementedError

    def _update_command(self) -> None:
        """Per-step update after resampling (e.g. heading control)."""

    def set_fixed_command(self, values: torch.Tensor | None) -> None:
        """Hold every env's command at `values` ((N, D) or (D,), the command's layout) from now on; None goes
        back to drawing. The term keeps its timers and internal state (e.g. a smoothed height), overwritten.
        Call it before the env's first step: on the GPU that step is captured as a CUDA graph, with or without
        the overwrite."""
        if values is None:
            self.fixed_command = None
            return
        values = torch.as_tensor(values, dtype=torch.float32, device=self.env.device)
        shape = tuple(self.command.shape)
        if values.shape not in (shape, shape[1:]):
            raise ValueError(f"fixed command of shape {tuple(values.shape)}; this command is {shape} (envs, values) "
                             f"or {shape[1:]}")
        self.fixed_command = values.expand(shape).clone()
        self.command.copy_(self.fixed_command)

    def _hold_fixed_command(self) -> None:
        if self.fixed_command is not None:
            self.command.copy_(self.fixed_command)

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
        self._hold_fixed_command()

    def _start_episodes(self, env_mask: torch.Tensor) -> None:
        """What a new episode of the masked envs needs after its first command (e.g. no smoothing ramp from the
        last episode's command)."""

    def reset(self, env_mask: torch.Tensor) -> dict:
        self._draw_time_left(env_mask)
        self._resample(env_mask)
        self._update_command()
        self._start_episodes(env_mask)
        self._hold_fixed_command()
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
