"""Reward manager: weighted sum of terms, times the env step dt, with per-term episode sums."""

from __future__ import annotations

import torch

from agile.rl_env.managers.manager_base import collect_terms, prepare_term, reset_term
from agile.rl_env.managers.term_cfg import RewTerm


class RewardManager:
    def __init__(self, cfg, env):
        self.env = env
        self.term_cfgs = collect_terms(cfg, RewTerm)
        self.funcs = {n: prepare_term(env, "reward", n, t) for n, t in self.term_cfgs.items()}
        # live weights are device scalars, so a curriculum can change them inside a captured step;
        # terms configured with weight 0 are not computed at all
        self.weights = {name: torch.tensor(float(t.weight), device=env.device)
                        for name, t in self.term_cfgs.items() if t.weight != 0.0}
        n = env.num_envs
        self.reward_buf = torch.zeros(n, device=env.device)
        self.episode_sums = {name: torch.zeros(n, device=env.device) for name in self.term_cfgs}
        self.step_reward = {name: torch.zeros(n, device=env.device) for name in self.term_cfgs}
        self.nonfinite_count = {name: torch.zeros((), dtype=torch.long, device=env.device) for name in self.term_cfgs}
        """Per term, how many env-steps it returned NaN or an infinity (counted as 0 in the reward), since the
        start: logged as `Reward_NonFinite/<term>`."""
        """Each term's weighted contribution of the last step (before dt), for debugging and GUIs."""

    @property
    def active_terms(self) -> list[str]:
        return list(self.term_cfgs)

    def get_term_cfg(self, name: str) -> RewTerm:
        if name not in self.term_cfgs:
            raise KeyError(f"no reward term '{name}'. Terms: {self.active_terms}")
        return self.term_cfgs[name]

    def set_term_weight(self, name: str, weight: float | torch.Tensor) -> None:
        """Set a term's live weight (the config keeps the initial one)."""
        self.get_term_cfg(name)
        if name not in self.weights:
            raise ValueError(f"reward term '{name}' has weight 0 in the config and is not computed; "
                             f"give it a non-zero initial weight to change it at run time")
        if isinstance(weight, torch.Tensor):
            self.weights[name].copy_(weight)
        else:
            self.weights[name].fill_(float(weight))

    def compute(self, dt: float, active: torch.Tensor | None = None) -> torch.Tensor:
        """Weighted terms times dt, summed; where `active` (N,) is False (a world that blew up, a multi-agent robot
        frozen after its death) every term counts 0, in the reward and the episode sums. A NaN or infinite term
        value counts 0 too, and is counted in `nonfinite_count`."""
        self.reward_buf.zero_()
        for name, weight in self.weights.items():
            cfg = self.term_cfgs[name]
            value = self.funcs[name](self.env, **cfg.params) * weight
            if active is not None:
                value = torch.where(active, value, 0.0)
            finite = torch.isfinite(value)
            self.nonfinite_count[name] += (~finite).sum()
            value = torch.where(finite, value, 0.0)
            self.step_reward[name][:] = value
            self.reward_buf += value * dt
            self.episode_sums[name] += value * dt
        return self.reward_buf

    def reset(self, env_mask: torch.Tensor) -> dict[str, torch.Tensor]:
        """Zero the sums of finished episodes; return their per-second means (over the finished envs)."""
        count = env_mask.sum().clamp(min=1)
        max_len_s = self.env.max_episode_length_s
        log = {}
        for name, sums in self.episode_sums.items():
            log[f"Episode_Reward/{name}"] = torch.where(env_mask, sums, 0.0).sum() / count / max_len_s
            sums.masked_fill_(env_mask, 0.0)
            log[f"Reward_NonFinite/{name}"] = self.nonfinite_count[name]
        for func in self.funcs.values():
            reset_term(func, env_mask)
        return log
