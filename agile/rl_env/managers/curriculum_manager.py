"""Curriculum manager: terms called at every env step with the mask of envs being reset."""

from __future__ import annotations

import torch

from agile.rl_env.managers.manager_base import collect_terms, prepare_term
from agile.rl_env.managers.term_cfg import CurrTerm


class CurriculumManager:
    def __init__(self, cfg, env):
        self.env = env
        self.term_cfgs = collect_terms(cfg, CurrTerm)
        self.funcs = {n: prepare_term(env, "curriculum", n, t, skip_first=2) for n, t in self.term_cfgs.items()}
        self.state: dict[str, float | torch.Tensor] = {}

    @property
    def active_terms(self) -> list[str]:
        return list(self.term_cfgs)

    def compute(self, env_mask: torch.Tensor) -> dict:
        for name, cfg in self.term_cfgs.items():
            value = self.funcs[name](self.env, env_mask, **cfg.params)
            if value is not None:
                self.state[name] = value
        return {f"Curriculum/{name}": value for name, value in self.state.items()}
