"""AGILE's reward normalisation for rsl-rl's PPO (rsl-rl 5.5.1 has none): rewards scaled towards unit-variance returns.

What AGILE documents (`ReturnVarianceNormalization`, its docs/algorithms.md), written here: the rewards of every env
step are divided by

    scale = sigma * gamma_factor * return_correction + epsilon,    gamma_factor = 1 / sqrt(1 - gamma^2),

where sigma is the standard deviation of one step's rewards across the envs, tracked by an exponential moving
average (`decay`, ~700 steps' half-life at 0.999), so that it follows the curricula. For independent rewards the
discounted return's variance is sigma^2 / (1 - gamma^2), so the scaled returns have about unit variance; rewards are
correlated in time (a fallen robot's many low rewards), so once per rollout `return_correction` moves towards what
makes the measured returns' standard deviation 1 (the GAE returns of the rollout, already scaled: `correction *
std`; `return_scale_decay`, None: no correction). Rewards further than `outlier_threshold` standard deviations from
the running mean are clipped before they update the statistics and in the scaled output (None: no clipping).

The critic then learns returns of about unit scale whatever a task's reward weights and curricula do to the raw
ones; the logs keep the raw rewards (the runner gives the logger its own). The statistics are saved in checkpoints
(`reward_normalizer_state_dict`) and restored on resume; a checkpoint without them (trained before) starts them afresh.
Each GPU of a multi-GPU run keeps its own statistics. Everything stays on the device (no host synchronisation).

Switch it on with the PPO config's `reward_normalization=RewardNormalizationCfg(...)`; `agile.rl.extensions` puts
`RewardNormalization` in front of the PPO class.
"""

from __future__ import annotations

import math

import torch
from torch import nn

from agile.rl.configs import RewardNormalizationCfg
from agile.utils.config import ConfigError, checked_cfg

STATE_KEY = "reward_normalizer_state_dict"


class ReturnVarianceNormalizer(nn.Module):
    """The running statistics and the scaling (see the module); one scalar each, on the rewards' device."""

    def __init__(self, cfg: RewardNormalizationCfg, gamma: float):
        super().__init__()
        if not 0.0 <= gamma < 1.0:
            raise ConfigError(f"reward_normalization needs a discount gamma in [0, 1), got {gamma}")
        self.cfg = cfg
        self.gamma_factor = 1.0 / math.sqrt(1.0 - gamma ** 2)
        self.register_buffer("mean", torch.zeros(()))
        self.register_buffer("var", torch.ones(()))
        self.register_buffer("return_correction", torch.ones(()))

    def scale(self) -> torch.Tensor:
        return self.var.sqrt() * self.gamma_factor * self.return_correction + self.cfg.epsilon

    def forward(self, rewards: torch.Tensor) -> torch.Tensor:
        """(N,) one env step's rewards, scaled; the statistics learn them first."""
        self.update(rewards)
        scale = self.scale()
        scaled = rewards / scale
        threshold = self.cfg.outlier_threshold
        if threshold is not None:
            scaled_mean = self.mean / scale
            scaled = torch.clamp(scaled, scaled_mean - threshold, scaled_mean + threshold)
        return scaled

    def update(self, rewards: torch.Tensor) -> None:
        rewards = rewards.float()
        threshold = self.cfg.outlier_threshold
        if threshold is not None:
            spread = threshold * (self.var.sqrt() + self.cfg.epsilon)
            rewards = torch.clamp(rewards, self.mean - spread, self.mean + spread)
        alpha = 1.0 - self.cfg.decay
        self.mean.mul_(self.cfg.decay).add_(alpha * rewards.mean())
        self.var.mul_(self.cfg.decay).add_(alpha * rewards.var(unbiased=False))

    def update_return_scale(self, scaled_returns: torch.Tensor) -> None:
        """Once per rollout, with its GAE returns (computed from scaled rewards): the correction moves towards the
        one under which those returns' standard deviation would have been 1 (`correction x std` stays what the raw
        returns' spread asks for as the correction changes: no oscillation)."""
        decay = self.cfg.return_scale_decay
        if decay is None:
            return
        ideal = scaled_returns.float().std().clamp(min=1e-6) * self.return_correction
        self.return_correction.mul_(decay).add_((1.0 - decay) * ideal)


class RewardNormalization:
    """PPO whose stored rewards are scaled by a `ReturnVarianceNormalizer` (see the module). A mixin: in front of a
    PPO class in the bases."""

    def __init__(self, *args, reward_normalization: dict | None = None, **kwargs):
        super().__init__(*args, **kwargs)
        cfg = checked_cfg(RewardNormalizationCfg, reward_normalization or {}, "reward_normalization")
        self.reward_normalizer = ReturnVarianceNormalizer(cfg, self.gamma).to(self.device)

    def process_env_step(self, obs, rewards, dones, extras) -> None:
        super().process_env_step(obs, self.reward_normalizer(rewards.to(self.device)), dones, extras)

    def compute_returns(self, obs) -> None:
        super().compute_returns(obs)
        self.reward_normalizer.update_return_scale(self.storage.returns)

    def save(self) -> dict:
        saved = super().save()
        saved[STATE_KEY] = self.reward_normalizer.state_dict()
        return saved

    def load(self, loaded_dict: dict, load_cfg: dict | None, strict: bool) -> bool:
        resumed = super().load(loaded_dict, load_cfg, strict)
        if STATE_KEY in loaded_dict:  # else (trained without) they start afresh: `starts_normalizing`
            self.reward_normalizer.load_state_dict(loaded_dict[STATE_KEY])
        return resumed


def starts_normalizing(agent_cfg, checkpoint: dict | None) -> bool:
    """Whether a run resumes with reward normalisation from a checkpoint trained without it: its critic learned
    returns of another scale, so its first advantages are noise (`critic_warmup_iterations` then applies, as for a
    fresh critic)."""
    normalizes = getattr(getattr(agent_cfg, "algorithm", None), "reward_normalization", None) is not None
    return checkpoint is not None and normalizes and STATE_KEY not in checkpoint
