"""A replay buffer on the training device for off-policy training from thousands of envs (`agile.rl.fast_td3`):
the last `steps_per_env` steps of every env, each observation stored once, and n-step returns computed at sampling.

The envs reset themselves at the end of an episode and return the first observation of the next one, so an ended
episode's last observation is never seen. A sampled return is therefore cut where the episode ends:

- terminated at step t+k (k < n): the rewards r_t..r_{t+k}, no bootstrap (the episode's value ends there);
- truncated at step t+k (a time-out, k >= 1): the rewards r_t..r_{t+k-1} and a bootstrap from s_{t+k} (a state
  the episode reached) discounted by gamma^k; the one transition whose own step timed out (k = 0) has no state to
  bootstrap from and is left out of the loss (`valid` False);
- no end within n steps: r_t..r_{t+n-1} and a bootstrap from s_{t+n} discounted by gamma^n.
"""

from __future__ import annotations

import dataclasses

import torch


@dataclasses.dataclass
class Batch:
    """Sampled transitions: observations and actions at t, the n-step return, where to bootstrap from and with
    which discount (0: no bootstrap), and whether the transition counts in the loss."""
    actor_obs: torch.Tensor
    critic_obs: torch.Tensor
    actions: torch.Tensor
    returns: torch.Tensor
    next_actor_obs: torch.Tensor
    next_critic_obs: torch.Tensor
    bootstrap_discount: torch.Tensor
    valid: torch.Tensor


class ReplayBuffer:
    """The newest `steps_per_env` steps of `num_envs` envs (a ring per env, all envs written each step)."""

    def __init__(self, *, num_envs: int, steps_per_env: int, actor_obs_dim: int, critic_obs_dim: int,
                 action_dim: int, device: str):
        if steps_per_env < 2:
            raise ValueError(f"steps_per_env must be at least 2, got {steps_per_env}")
        self.num_envs, self.steps_per_env, self.device = num_envs, steps_per_env, device
        shape = (steps_per_env, num_envs)
        self.actor_obs = torch.zeros(*shape, actor_obs_dim, device=device)
        self.critic_obs = torch.zeros(*shape, critic_obs_dim, device=device)
        self.actions = torch.zeros(*shape, action_dim, device=device)
        self.rewards = torch.zeros(shape, device=device)
        self.terminated = torch.zeros(shape, dtype=torch.bool, device=device)
        self.truncated = torch.zeros(shape, dtype=torch.bool, device=device)
        self.steps_stored = 0
        """Steps written since the start (the newest is at (steps_stored - 1) % steps_per_env)."""

    def add(self, *, actor_obs: torch.Tensor, critic_obs: torch.Tensor, actions: torch.Tensor, rewards: torch.Tensor,
            terminated: torch.Tensor, truncated: torch.Tensor) -> None:
        """One step of every env: the observations the actions were taken on, and the step's outcome."""
        row = self.steps_stored % self.steps_per_env
        self.actor_obs[row] = actor_obs
        self.critic_obs[row] = critic_obs
        self.actions[row] = actions
        self.rewards[row] = rewards
        self.terminated[row] = terminated
        self.truncated[row] = truncated
        self.steps_stored += 1

    def can_sample(self, n_steps: int) -> bool:
        """Whether a transition with n later steps stored exists."""
        return self.steps_stored > n_steps

    def sample(self, *, batch_size: int, n_steps: int, gamma: float, generator=None) -> Batch:
        """`batch_size` transitions drawn uniformly over envs and stored steps (those with `n_steps` later steps
        stored), with their n-step returns (module docstring)."""
        if not self.can_sample(n_steps):
            raise ValueError(f"{self.steps_stored} steps stored: sampling {n_steps}-step returns needs more than "
                             f"{n_steps}")
        oldest = max(0, self.steps_stored - self.steps_per_env)
        count = self.steps_stored - n_steps - oldest  # steps t with s_{t+n} stored
        step = oldest + torch.randint(count, (batch_size,), device=self.device, generator=generator)
        env = torch.randint(self.num_envs, (batch_size,), device=self.device, generator=generator)
        returns = torch.zeros(batch_size, device=self.device)
        discount = torch.ones(batch_size, device=self.device)  # gamma^k while the episode goes on, then frozen
        running = torch.ones(batch_size, dtype=torch.bool, device=self.device)
        bootstrap_step = step + n_steps
        bootstrap = torch.ones(batch_size, dtype=torch.bool, device=self.device)
        valid = torch.ones(batch_size, dtype=torch.bool, device=self.device)
        for k in range(n_steps):
            row = (step + k) % self.steps_per_env
            terminated, truncated = self.terminated[row, env], self.truncated[row, env]
            timed_out = running & truncated & ~terminated
            if k == 0:
                valid = ~timed_out
            else:  # bootstrap from s_{t+k}, the last state of the episode stored
                bootstrap_step = torch.where(timed_out, step + k, bootstrap_step)
            keep = running & ~timed_out  # a time-out's own reward belongs to a transition without a next state
            returns = returns + torch.where(keep, discount * self.rewards[row, env], 0.0)
            bootstrap &= ~(running & terminated)
            running = running & ~(terminated | truncated)
            discount = torch.where(running, discount * gamma, discount)
        next_row = bootstrap_step % self.steps_per_env
        row = step % self.steps_per_env
        return Batch(actor_obs=self.actor_obs[row, env], critic_obs=self.critic_obs[row, env],
                     actions=self.actions[row, env], returns=returns,
                     next_actor_obs=self.actor_obs[next_row, env], next_critic_obs=self.critic_obs[next_row, env],
                     bootstrap_discount=torch.where(bootstrap, discount, 0.0), valid=valid)
