"""Event manager: 'startup' (once), 'reset' (masked, at every reset) and 'interval' (per-env timers)."""

from __future__ import annotations

import torch

from agile.rl_env.managers.manager_base import collect_terms, prepare_term, reset_term
from agile.rl_env.managers.term_cfg import EventTerm, ManagerTermBase
from agile.utils.config import ConfigError, check_range

MODES = ("startup", "reset", "interval")


class EventManager:
    def __init__(self, cfg, env):
        self.env = env
        self.term_cfgs = collect_terms(cfg, EventTerm)
        self.funcs = {}
        self.time_left_s: dict[str, torch.Tensor] = {}
        for name, term in self.term_cfgs.items():
            if term.mode not in MODES:
                raise ConfigError(f"task '{env.task_name}', event term '{name}': mode '{term.mode}' not in {MODES}")
            if term.mode == "interval":
                if term.interval_range_s is None:
                    raise ConfigError(f"task '{env.task_name}', event term '{name}': interval mode needs interval_range_s")
                try:
                    check_range("interval_range_s", term.interval_range_s, minimum=0.0)
                except ValueError as err:
                    raise ConfigError(f"task '{env.task_name}', event term '{name}': {err}") from None
                self.time_left_s[name] = self._sample_interval(term, env.num_envs)
            self.funcs[name] = prepare_term(env, "event", name, term, skip_first=2)

    def _sample_interval(self, term: EventTerm, n: int) -> torch.Tensor:
        low, high = term.interval_range_s
        return torch.rand(n, device=self.env.device) * (high - low) + low

    def get_term(self, name: str):
        """The event term `name` as built: a class term's instance (e.g. to hand it a dataset), else its function."""
        if name not in self.funcs:
            raise KeyError(f"no event term '{name}'; the event terms: {sorted(self.funcs)}")
        return self.funcs[name]

    def terms(self, mode: str) -> list[str]:
        return [n for n, t in self.term_cfgs.items() if t.mode == mode]

    def apply(self, mode: str, env_mask: torch.Tensor | None = None, dt: float | None = None) -> None:
        for name in self.terms(mode):
            cfg = self.term_cfgs[name]
            if mode == "interval":
                time_left = self.time_left_s[name]
                time_left -= dt
                mask = time_left <= 0.0
                time_left.copy_(torch.where(mask, self._sample_interval(cfg, self.env.num_envs), time_left))
            else:
                mask = env_mask
            if mode != "startup":
                self.funcs[name](self.env, mask, **cfg.params)
                continue
            try:  # the first call of a startup term is where it finds a param outside its domain
                self.funcs[name](self.env, mask, **cfg.params)
            except ValueError as err:
                raise ConfigError(f"task '{self.env.task_name}', event term '{name}': {err}") from None

    def prepare_terms(self) -> None:
        """`ManagerTermBase.prepare` of every class term, in the config's order."""
        for func in self.funcs.values():
            if isinstance(func, ManagerTermBase):
                func.prepare(self.env)

    def reset(self, env_mask: torch.Tensor) -> dict:
        for func in self.funcs.values():
            reset_term(func, env_mask)
        return {}
