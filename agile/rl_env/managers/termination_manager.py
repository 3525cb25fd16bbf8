"""Termination manager: failures and time-outs, kept apart."""

from __future__ import annotations

import torch

from agile.rl_env.managers.manager_base import collect_terms, prepare_term, reset_term
from agile.rl_env.managers.term_cfg import DoneTerm


class TerminationManager:
    def __init__(self, cfg, env):
        self.env = env
        self.term_cfgs = collect_terms(cfg, DoneTerm)
        self.funcs = {n: prepare_term(env, "termination", n, t) for n, t in self.term_cfgs.items()}
        n = env.num_envs
        self.terminated = torch.zeros(n, dtype=torch.bool, device=env.device)
        self.time_outs = torch.zeros(n, dtype=torch.bool, device=env.device)
        self.term_dones = {name: torch.zeros(n, dtype=torch.bool, device=env.device) for name in self.term_cfgs}

    @property
    def active_terms(self) -> list[str]:
        return list(self.term_cfgs)

    @property
    def dones(self) -> torch.Tensor:
        return self.terminated | self.time_outs

    def compute(self) -> torch.Tensor:
        self.terminated.zero_()
        self.time_outs.zero_()
        for name, cfg in self.term_cfgs.items():
            value = self.funcs[name](self.env, **cfg.params).bool()
            self.term_dones[name][:] = value
            if cfg.time_out:
                self.time_outs |= value
            else:
                self.terminated |= value
        return self.dones

    def reset(self, env_mask: torch.Tensor) -> dict[str, torch.Tensor]:
        """Share of the finished episodes that each term ended."""
        count = env_mask.sum().clamp(min=1)
        log = {f"Episode_Termination/{name}": (done & env_mask).sum() / count
               for name, done in self.term_dones.items()}
        for func in self.funcs.values():
            reset_term(func, env_mask)
        return log
