"""rsl-rl's PPO with an update that never waits for the GPU: the same losses, clipping and adaptive learning rate,
kept on the device.

rsl-rl's `PPO.update` reads four numbers back to the host in every mini-batch (the KL test that adapts the learning
rate, and three losses for the log): with AGILE's 5 epochs x 4 mini-batches that is 80 points per iteration where
the CPU stops queueing work until the GPU has finished. Here the learning rate is a device tensor that the KL rule
updates in place (`torch.where`), Adam takes it as a tensor (fused Adam), and the losses are summed on the device and
read once at the end. The math is rsl-rl's: `tests/test_ppo_update.py` checks that losses, learning rate and
parameters after an update match the plain update.

Switch it on with `agent.algorithm.sync_free_update=true` (`agile.rl.extensions`; feed-forward actor and critic, no
RND: recurrent models and RND are refused).
"""

from __future__ import annotations

from itertools import chain

import torch
from torch import nn

LOSS_SUMS = 5
"""The update's losses summed on the device: value, surrogate, entropy, symmetry, the extra term
(`regularization_loss`)."""

MIN_LEARNING_RATE = 1.0e-5
MAX_LEARNING_RATE = 1.0e-2
"""rsl-rl's bounds of the adaptive learning rate."""


class SyncFreeUpdate:
    """PPO's update without a host synchronisation (see the module). A mixin: in front of rsl-rl's PPO."""

    def __init__(self, actor, critic, storage, *args, learning_rate: float = 0.001, device: str = "cpu",
                 optimizer: str = "adam", **kwargs):
        if optimizer != "adam":
            raise ValueError(f"sync_free_update updates with (fused) Adam, not '{optimizer}'; switch it off for "
                             f"another optimizer")
        super().__init__(actor, critic, storage, *args, learning_rate=learning_rate, device=device, **kwargs)
        if self.rnd is not None:
            raise ValueError("sync_free_update has no RND; switch it off to train with RND")
        if self.actor.is_recurrent or self.critic.is_recurrent:
            raise ValueError("sync_free_update updates feed-forward models; switch it off for a recurrent policy")
        self.learning_rate_t = torch.tensor(float(learning_rate), device=self.device)
        """The learning rate the optimizer reads, adapted on the device; `learning_rate` mirrors it for the log."""
        self.optimizer = torch.optim.Adam(chain(self.actor.parameters(), self.critic.parameters()),
                                          lr=self.learning_rate_t, fused=True)

    regularization_name: str | None = None
    """The name the mini-batch step's extra loss term is logged under (a mixin's, e.g. "l2c2"); None: none."""

    def regularization_loss(self, batch) -> torch.Tensor | None:
        """An extra term of the mini-batch step's loss, weighted, computed inside its autocast (a mixin's: L2C2);
        None: none."""
        return None

    def compute_returns(self, obs) -> None:
        """rsl-rl's returns and advantages (GAE), the same operations in the same order on every element, so the
        same numbers: the TD errors of all steps at once, then the backward recursion at two kernels a step, where
        rsl-rl's loop launches about eleven (on a GPU, launched one by one, ~4 ms of a G1 iteration)."""
        st = self.storage
        last_values = self.critic(obs).detach()  # feed-forward (the class refuses recurrent models): no state
        not_terminal = 1.0 - st.dones.float()
        next_values = torch.cat((st.values[1:], last_values.unsqueeze(0)))
        delta = st.rewards + not_terminal * self.gamma * next_values - st.values
        decay = not_terminal * self.gamma * self.lam
        advantage = st.returns  # the advantages first, then the values added: the returns
        advantage[-1] = delta[-1]  # rsl-rl: delta + decay x 0
        carried = torch.empty_like(advantage[0])
        for step in reversed(range(st.num_transitions_per_env - 1)):
            torch.mul(decay[step], advantage[step + 1], out=carried)
            torch.add(delta[step], carried, out=advantage[step])
        st.returns.add_(st.values)
        st.advantages = st.returns - st.values  # rsl-rl derives them back from the returns
        if not self.normalize_advantage_per_mini_batch:
            st.advantages = (st.advantages - st.advantages.mean()) / (st.advantages.std() + 1e-8)

    def update(self) -> dict[str, float]:
        sums = torch.zeros(LOSS_SUMS, device=self.device)
        for batch in self.storage.mini_batch_generator(self.num_mini_batches, self.num_learning_epochs):
            self.mini_batch_step(batch, sums)
        return self.finish_update(sums)

    def mini_batch_step(self, batch, sums: torch.Tensor) -> None:
        """One gradient step on a mini-batch (rsl-rl's loop body); adds its losses to `sums` on the device."""
        original_batch_size = batch.observations.batch_size[0]
        if self.normalize_advantage_per_mini_batch:
            with torch.no_grad():
                batch.advantages = (batch.advantages - batch.advantages.mean()) / (batch.advantages.std() + 1e-8)
        if self.symmetry:
            self.symmetry.augment_batch(batch, original_batch_size)
        capturing = torch.device(self.device).type == "cuda" and torch.cuda.is_current_stream_capturing()
        # no cast cache while a CUDA graph captures the step (PyTorch's rule for autocast in a capture: a cached cast
        # would outlive the capture in the graph's memory)
        with torch.amp.autocast(device_type=torch.device(self.device).type, enabled=self.use_mixed_precision,
                                dtype=torch.bfloat16, cache_enabled=not capturing):
            # the action distribution at the batch; rsl-rl's actor(..., stochastic_output=True) also draws a sample
            # that the update does not use (and a random draw would not replay in the captured update's graph)
            self.actor.distribution.update(self.actor.mlp(self.actor.get_latent(batch.observations)))
            actions_log_prob = self.actor.get_output_log_prob(batch.actions)
            values = self.critic(batch.observations, masks=batch.masks, hidden_state=batch.hidden_states[1])
            distribution_params = tuple(p[:original_batch_size] for p in self.actor.output_distribution_params)
            entropy = self.actor.output_entropy[:original_batch_size]
            if self.desired_kl is not None and self.schedule == "adaptive":
                with torch.no_grad():
                    self._adapt_learning_rate(batch.old_distribution_params, distribution_params)
            ratio = torch.exp(actions_log_prob - torch.squeeze(batch.old_actions_log_prob))
            advantages = torch.squeeze(batch.advantages)
            surrogate_loss = torch.max(-advantages * ratio, -advantages * torch.clamp(
                ratio, 1.0 - self.clip_param, 1.0 + self.clip_param)).mean()
            if self.use_clipped_value_loss:
                value_clipped = batch.values + (values - batch.values).clamp(-self.clip_param, self.clip_param)
                value_loss = torch.max((values - batch.returns).pow(2),
                                       (value_clipped - batch.returns).pow(2)).mean()
            else:
                value_loss = (batch.returns - values).pow(2).mean()
            loss = surrogate_loss + self.value_loss_coef * value_loss - self.entropy_coef * entropy.mean()
            symmetry_loss = torch.zeros((), device=self.device)
            if self.symmetry and self.symmetry.use_mirror_loss:
                symmetry_loss = self.symmetry.compute_loss(self.actor, batch, original_batch_size)
                loss = loss + self.symmetry.mirror_loss_coeff * symmetry_loss
            elif self.symmetry:  # logged only: its forward pass needs no autograd record
                with torch.no_grad():
                    symmetry_loss = self.symmetry.compute_loss(self.actor, batch, original_batch_size)
            regularization = self.regularization_loss(batch)
            if regularization is not None:
                loss = loss + regularization
            else:
                regularization = torch.zeros((), device=self.device)
        self.optimizer.zero_grad()
        loss.backward()
        if self.is_multi_gpu:
            self.reduce_parameters()
        nn.utils.clip_grad_norm_(self.actor.parameters(), self.max_grad_norm)
        nn.utils.clip_grad_norm_(self.critic.parameters(), self.max_grad_norm)
        self.optimizer.step()
        sums += torch.stack((value_loss.detach(), surrogate_loss.detach(), entropy.mean().detach(),
                             symmetry_loss.detach().float(), regularization.detach().float()))

    def finish_update(self, sums: torch.Tensor) -> dict[str, float]:
        """After the mini-batches: the observation normalisers learn the rollout, the mean losses are read (the
        update's one read back to the host), the storage is cleared."""
        obs = self.storage.observations.flatten(0, 1)
        self.actor.update_normalization(obs)
        self.critic.update_normalization(obs)
        means = (sums / (self.num_learning_epochs * self.num_mini_batches)).tolist()
        self.learning_rate = float(self.learning_rate_t)
        losses = {"value": means[0], "surrogate": means[1], "entropy": means[2]}
        if self.symmetry:
            losses["symmetry"] = means[3]
        if self.regularization_name is not None:
            losses[self.regularization_name] = means[4]
        self.storage.clear()
        return losses

    def _adapt_learning_rate(self, old_params, new_params) -> None:
        """rsl-rl's rule on the device: above twice the desired KL divide by 1.5, below half of it (and above 0)
        multiply by 1.5, within [1e-5, 1e-2]; the mean KL is averaged over the GPUs first."""
        kl_mean = torch.mean(self.actor.get_kl_divergence(old_params, new_params))
        if self.is_multi_gpu:
            torch.distributed.all_reduce(kl_mean, op=torch.distributed.ReduceOp.SUM)
            kl_mean = kl_mean / self.gpu_world_size
        lr = self.learning_rate_t
        lowered = torch.clamp(lr / 1.5, min=MIN_LEARNING_RATE)
        raised = torch.clamp(lr * 1.5, max=MAX_LEARNING_RATE)
        new_lr = torch.where(kl_mean > self.desired_kl * 2.0, lowered,
                             torch.where((kl_mean < self.desired_kl / 2.0) & (kl_mean > 0.0), raised, lr))
        lr.copy_(new_lr)

    def save(self) -> dict:
        """rsl-rl's checkpoint, with the optimizer's learning rate as a number (a plain PPO can resume from it)."""
        saved = super().save()
        for group in saved["optimizer_state_dict"]["param_groups"]:
            group["lr"] = float(group["lr"])
        return saved

    def load(self, loaded_dict: dict, load_cfg: dict | None, strict: bool) -> bool:
        resumed = super().load(loaded_dict, load_cfg, strict)
        self.learning_rate_t.fill_(float(self.learning_rate))
        for group in self.optimizer.param_groups:  # the optimizer reads the device tensor again
            group["lr"] = self.learning_rate_t
        return resumed
