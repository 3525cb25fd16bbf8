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
        names = list(self.term_cfgs)
        self._row = {name: i for i, name in enumerate(names)}
        n, t = env.num_envs, len(names)
        # the per-step work is done on (terms, envs) tensors, a few kernels for all terms; the dicts below hold
        # row views of them. Live weights are device scalars, so a curriculum can change them inside a captured
        # step; terms configured with weight 0 are not computed at all
        self._weights = torch.tensor([float(c.weight) for c in self.term_cfgs.values()], device=env.device)
        self.weights = {name: self._weights[i] for i, name in enumerate(names) if self.term_cfgs[name].weight != 0.0}
        self.reward_buf = torch.zeros(n, device=env.device)
        self._episode_sums = torch.zeros(t, n, device=env.device)
        self.episode_sums = {name: self._episode_sums[i] for i, name in enumerate(names)}
        self._step_reward = torch.zeros(t, n, device=env.device)
        self.step_reward = {name: self._step_reward[i] for i, name in enumerate(names)}
        """Each term's weighted contribution of the last step (before dt), for debugging and GUIs."""
        self._nonfinite_count = torch.zeros(t, dtype=torch.long, device=env.device)
        self.nonfinite_count = {name: self._nonfinite_count[i] for i, name in enumerate(names)}
        """Per term, how many env-steps it returned NaN or an infinity (counted as 0 in the reward), since the
        start: logged as `Reward_NonFinite/<term>`."""

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
        for name in self.weights:
            self._step_reward[self._row[name]].copy_(self.funcs[name](self.env, **self.term_cfgs[name].params))
        values = self._step_reward * self._weights.unsqueeze(1)  # rows of weight-0 terms stay 0
        if active is not None:
            values = torch.where(active, values, 0.0)
        finite = torch.isfinite(values)
        self._nonfinite_count += (~finite).sum(dim=1)
        values = torch.where(finite, values, 0.0)
        self._step_reward.copy_(values)
        torch.sum(values, dim=0, out=self.reward_buf)
        self.reward_buf *= dt
        self._episode_sums += values * dt
        return self.reward_buf

    def reset(self, env_mask: torch.Tensor) -> dict[str, torch.Tensor]:
        """Zero the sums of finished episodes; return their per-second means (over the finished envs)."""
        count = env_mask.sum().clamp(min=1)
        max_len_s = self.env.max_episode_length_s
        means = (self._episode_sums * env_mask).sum(dim=1) / count / max_len_s
        self._episode_sums.masked_fill_(env_mask, 0.0)
        log = {}
        for name, i in self._row.items():
            log[f"Episode_Reward/{name}"] = means[i]
            log[f"Reward_NonFinite/{name}"] = self.nonfinite_count[name]
        for func in self.funcs.values():
            reset_term(func, env_mask)
        return log
