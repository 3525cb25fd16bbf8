"""AGILE's entropy-coefficient annealing for rsl-rl's PPO (rsl-rl 5.5.1 has none).

Once the run is past `start_iteration` and the episodes that ended during the iteration's rollout lasted on
average more than `min_episode_length_share` of the longest episode, every iteration multiplies the entropy
coefficient by `decay_per_iteration`, down to `min_entropy_coef`. AGILE gates it the same way (training progress
and mean episode length) to let a policy that already succeeds shrink its action noise, so that the behaviour it is
trained on comes closer to the mean action it is evaluated and deployed with. PickPlace-G1 (AGILE: from 10% of its
20,000 iterations once the episodes last 30% of their length, x0.9998 per iteration) needs it: with a delta-position
action the noise std grew to 1.24 without it.

The coefficient is saved in checkpoints and restored on resume; a checkpoint without one (trained before) resumes
at the configured coefficient. Switch it on with the PPO config's `entropy_annealing=EntropyAnnealingCfg(...)`
(`agile.rl.extensions` puts the `EntropyAnnealing` mixin in front of the PPO class).
"""

from __future__ import annotations

import torch

from agile.rl.configs import EntropyAnnealingCfg
from agile.utils.config import checked_cfg


class EntropyAnnealing:
    """PPO with the entropy coefficient annealed (see the module); the iteration's mean ended-episode length and
    the coefficient are logged as Loss/mean_episode_length_steps and Loss/entropy_coef."""

    def __init__(self, *args, entropy_annealing: dict | None = None, max_episode_length: int | None = None,
                 **kwargs):
        super().__init__(*args, **kwargs)
        self.annealing = checked_cfg(EntropyAnnealingCfg, entropy_annealing or {}, "entropy_annealing")
        if max_episode_length is None or max_episode_length < 1:
            raise ValueError(f"max_episode_length: {max_episode_length}; the env's episode length in steps")
        self.max_episode_length = int(max_episode_length)
        self.iteration = 0
        """The iteration the next update belongs to (the runner's, restored from a checkpoint)."""
        num_envs = self.storage.num_envs
        self._episode_steps = torch.zeros(num_envs, device=self.device)
        self._ended = torch.zeros(2, device=self.device)  # summed lengths [steps] and count of the ended episodes

    @classmethod
    def construct_algorithm(cls, obs, env, cfg: dict, device: str):
        """rsl-rl's construction, with the env's episode length passed to the algorithm."""
        cfg["algorithm"]["max_episode_length"] = int(env.max_episode_length)
        return super().construct_algorithm(obs, env, cfg, device)

    def process_env_step(self, obs, rewards, dones, extras) -> None:
        super().process_env_step(obs, rewards, dones, extras)
        ended = dones.to(self._episode_steps.device).bool()
        self._episode_steps.add_(1.0)
        self._ended[0].add_((self._episode_steps * ended).sum())
        self._ended[1].add_(ended.sum())
        self._episode_steps.masked_fill_(ended, 0.0)

    def update(self) -> dict:
        losses = super().update()
        ended = self._ended.clone()
        self._ended.zero_()
        if self.is_multi_gpu:  # every rank anneals alike
            torch.distributed.all_reduce(ended)
        total_steps, count = ended.tolist()  # one host read per iteration
        mean_length = total_steps / count if count > 0 else None
        cfg = self.annealing
        if (self.iteration >= cfg.start_iteration and mean_length is not None
                and mean_length > cfg.min_episode_length_share * self.max_episode_length):
            self.entropy_coef = max(self.entropy_coef * cfg.decay_per_iteration, cfg.min_entropy_coef)
        self.iteration += 1
        losses["entropy_coef"] = self.entropy_coef
        if mean_length is not None:
            losses["mean_episode_length_steps"] = mean_length
        return losses

    def save(self) -> dict:
        saved = super().save()
        saved["entropy_coef"] = self.entropy_coef
        return saved

    def load(self, loaded_dict: dict, load_cfg: dict | None, strict: bool) -> bool:
        load_iteration = super().load(loaded_dict, load_cfg, strict)
        if load_iteration:  # a resumed run: where it was, at the coefficient it had (if it annealed)
            self.iteration = int(loaded_dict["iter"]) + 1
            self.entropy_coef = float(loaded_dict.get("entropy_coef", self.entropy_coef))
        return load_iteration
