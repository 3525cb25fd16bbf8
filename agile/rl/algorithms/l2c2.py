"""AGILE's L2C2 regularisation for PPO (Lipschitz-constrained continuity; rsl-rl 5.5.1 has none).

What AGILE documents (its docs/algorithms.md), written here: the policy and the value should change little between
two consecutive observations of an episode. Each mini-batch step takes as many consecutive pairs (s_t, s_t+1) of the
rollout as the mini-batch has samples, each at a random point s~ = s_t + u (s_t+1 - s_t), u ~ U(0, 1), and adds

    lambda_actor * MSE(mu(s~), mu(s_t)) + lambda_critic * MSE(V(s~), V(s_t))

(mean over the pairs and the entries; mu the action mean, V the value) to the PPO loss. Pairs across an episode's end
(the step's `done`: the next observation is after a reset) count zero. Drawn on the device (no host synchronisation,
and capturable: the captured update replays it with new draws). Logged as `Loss/l2c2`. Under the bf16 autocast of
`use_mixed_precision` the outputs, and so their small differences, carry bf16's rounding; AGILE trains in float32.

It needs the update's mini-batch step to take an extra loss term (`SyncFreeUpdate.regularization_loss`), so it needs
`sync_free_update` or `captured_update` switched on (rsl-rl's own update has no place for it; `agile.rl.extensions`
refuses the pair); feed-forward models only. Switch it on with the PPO config's `l2c2=L2C2Cfg(...)`.
"""

from __future__ import annotations

import torch

from agile.rl.configs import L2C2Cfg
from agile.utils.config import checked_cfg


class L2C2:
    """The sync-free (or captured) update with the L2C2 term in its loss (see the module). A mixin: in front of
    theirs."""

    regularization_name = "l2c2"

    def __init__(self, *args, l2c2: dict | None = None, **kwargs):
        super().__init__(*args, **kwargs)
        self.l2c2 = checked_cfg(L2C2Cfg, l2c2 or {}, "l2c2")

    def regularization_loss(self, batch) -> torch.Tensor:
        storage = self.storage
        steps, num_envs = storage.num_transitions_per_env, storage.num_envs
        pairs = (steps - 1) * num_envs  # (t, t + 1) within the rollout, env by env
        count = batch.observations.batch_size[0]
        index = torch.randint(0, pairs, (count,), device=self.device)
        now = storage.observations[:-1].flatten(0, 1)[index]
        after = storage.observations[1:].flatten(0, 1)[index]
        same_episode = (storage.dones[:-1].flatten(0, 1)[index].squeeze(-1) == 0).float()
        u = torch.rand(count, 1, device=self.device)
        between = now.apply(lambda a, b: a + u.to(a.dtype) * (b - a), after)
        action_change = (self.actor(between) - self.actor(now)).pow(2).mean(dim=-1)
        value_change = (self.critic(between) - self.critic(now)).pow(2).mean(dim=-1)
        weight = same_episode / same_episode.sum().clamp(min=1.0)
        return (weight * (self.l2c2.lambda_actor * action_change + self.l2c2.lambda_critic * value_change)).sum()
