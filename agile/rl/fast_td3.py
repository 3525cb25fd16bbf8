"""FastTD3 (Seo et al., 2025, arXiv 2505.22642) on a registered single-agent task: off-policy TD3 from thousands of
parallel envs, a replay buffer on the GPU (`agile.rl.replay_buffer`), large batches, several updates per env step,
twin distributional (C51) critics with clipped double Q, per-env exploration noise, n-step returns.

The actor is the task's own rsl-rl actor (its PPO config's network and observation normalisation, acting on the
mean), saved under the same "actor_state_dict" key as a PPO checkpoint, so that `agile eval`, `play`, `export`
and `time_to_policy` take a FastTD3 checkpoint unchanged. TD3 needs bounded actions; rsl-rl's actor is not
(no tanh), so exploration and the critic's inputs are clamped to ±`action_bound` and the actor pays a penalty for
outputs beyond it (its deterministic outputs stay within, as evaluation runs them)."""

from __future__ import annotations

import dataclasses
import os
import time
from contextlib import nullcontext
from dataclasses import field

import torch
import torch.nn.functional as F

from agile.rl.configs import PpoRunnerCfg
from agile.rl.replay_buffer import ReplayBuffer
from agile.utils.config import ConfigError, configclass


@configclass
class FastTd3Cfg:
    """FastTD3's settings (its IsaacLab humanoid defaults where not said otherwise). An iteration is
    `num_steps_per_env` env steps, each followed by `updates_per_step` critic updates."""

    policy: PpoRunnerCfg = field(default_factory=PpoRunnerCfg)
    """The task's PPO runner config: its actor (network, observation groups, normalisation) is the policy trained
    here, and what evaluation loads the checkpoint with."""
    experiment_name: str = "agile_fast_td3"
    run_name: str = ""
    seed: int = 42
    num_steps_per_env: int = 24
    max_iterations: int = 1000
    save_interval: int = 50
    logger: str = "tensorboard"
    action_bound: float = 1.0
    """Actions explored and judged within ±action_bound (in the task's raw action units)."""
    action_bound_penalty: float = 1.0
    """Weight of the actor's squared excess beyond ±action_bound (per action, averaged)."""
    buffer_steps_per_env: int = 1024
    batch_size: int = 32768
    updates_per_step: int = 2
    policy_frequency: int = 2
    """Critic updates per actor update (TD3's delayed policy update)."""
    n_steps: int = 3
    gamma: float = 0.99
    tau: float = 0.1
    """Target critics: target <- (1 - tau) target + tau online, after every critic update."""
    actor_learning_rate: float = 3.0e-4
    critic_learning_rate: float = 3.0e-4
    weight_decay: float = 0.1
    """AdamW's, on both networks."""
    critic_hidden_dims: list[int] = field(default_factory=lambda: [1024, 512, 256])
    num_atoms: int = 251
    v_min: float = -10.0
    v_max: float = 10.0
    exploration_std_min: float = 0.001
    exploration_std_max: float = 0.4
    """Each env explores with Gaussian noise of a std drawn in [min, max] at the start of each of its episodes."""
    target_policy_noise: float = 0.001
    target_noise_clip: float = 0.5
    learning_starts: int = 10
    """Env steps before the first update."""
    mixed_precision: bool = True
    """bf16 autocast of the networks' forward passes on a GPU (the weights and optimizers stay FP32)."""
    max_grad_norm: float = 0.0
    """Gradient-norm clipping of both networks; 0: none."""

    def check(self) -> None:
        positive = ("num_steps_per_env", "max_iterations", "save_interval", "batch_size", "updates_per_step",
                    "policy_frequency", "n_steps", "num_atoms", "action_bound", "actor_learning_rate",
                    "critic_learning_rate")
        for name in positive:
            if not getattr(self, name) > 0:
                raise ConfigError(f"{name}: {getattr(self, name)}; give a positive value")
        if self.buffer_steps_per_env <= self.n_steps:
            raise ConfigError(f"buffer_steps_per_env: {self.buffer_steps_per_env}; give more than n_steps "
                              f"({self.n_steps})")
        if not 0.0 < self.gamma <= 1.0 or not 0.0 < self.tau <= 1.0:
            raise ConfigError(f"gamma {self.gamma}, tau {self.tau}: give factors in (0, 1]")
        if not self.v_min < self.v_max or self.num_atoms < 2:
            raise ConfigError(f"v_min {self.v_min}, v_max {self.v_max}, num_atoms {self.num_atoms}: the critic's "
                              "support needs v_min < v_max and at least 2 atoms")
        if not 0.0 <= self.exploration_std_min <= self.exploration_std_max:
            raise ConfigError(f"exploration_std_min {self.exploration_std_min}, exploration_std_max "
                              f"{self.exploration_std_max}: give 0 <= min <= max")
        if self.policy.actor.class_name != "MLPModel":
            raise ConfigError(f"policy.actor.class_name: {self.policy.actor.class_name}; FastTD3 trains a "
                              "feed-forward actor (MLPModel)")


class TwinDistributionalCritic(torch.nn.Module):
    """Two C51 critics over the normalised critic observations and the action: logits over `num_atoms` returns
    evenly spaced in [v_min, v_max]."""

    def __init__(self, obs_dim: int, action_dim: int, cfg: FastTd3Cfg):
        from rsl_rl.modules import MLP, EmpiricalNormalization

        super().__init__()
        self.obs_normalizer = EmpiricalNormalization(obs_dim)
        self.q1 = MLP(obs_dim + action_dim, cfg.num_atoms, cfg.critic_hidden_dims, "relu")
        self.q2 = MLP(obs_dim + action_dim, cfg.num_atoms, cfg.critic_hidden_dims, "relu")
        self.register_buffer("support", torch.linspace(cfg.v_min, cfg.v_max, cfg.num_atoms))

    def forward(self, obs: torch.Tensor, actions: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        x = torch.cat([self.obs_normalizer(obs), actions], dim=-1)
        return self.q1(x), self.q2(x)

    def values(self, logits: torch.Tensor) -> torch.Tensor:
        """The expected return of each row's distribution."""
        return (torch.softmax(logits.float(), dim=-1) * self.support).sum(-1)


def project_distribution(probs: torch.Tensor, returns: torch.Tensor, discount: torch.Tensor,
                         support: torch.Tensor) -> torch.Tensor:
    """C51's projection of returns + discount * support (probabilities `probs` per atom) onto `support`."""
    v_min, v_max, num_atoms = support[0], support[-1], support.numel()
    delta = (v_max - v_min) / (num_atoms - 1)
    target = (returns[:, None] + discount[:, None] * support[None, :]).clamp(v_min, v_max)
    position = (target - v_min) / delta
    lower, upper = position.floor().long(), position.ceil().long()
    # an atom landing exactly on the grid gives its whole mass to that point
    lower_weight = torch.where(lower == upper, 1.0, upper.float() - position)
    upper_weight = torch.where(lower == upper, 0.0, position - lower.float())
    projected = torch.zeros_like(probs)
    projected.scatter_add_(1, lower, probs * lower_weight)
    projected.scatter_add_(1, upper, probs * upper_weight)
    return projected


def build_actor(cfg: FastTd3Cfg, obs, num_actions: int, device: str):
    """The task's rsl-rl actor (as rsl-rl's PPO builds it from the same config) and the resolved observation
    groups ({"actor": [...], "critic": [...]})."""
    from rsl_rl.utils import resolve_class, resolve_obs_groups

    from agile.rl.configs import to_rsl_rl_dict

    train_cfg = to_rsl_rl_dict(cfg.policy)
    obs_groups = resolve_obs_groups(obs, train_cfg["obs_groups"], ["actor", "critic"])
    actor_class, actor_kwargs = resolve_class(train_cfg["actor"])
    return actor_class(obs, obs_groups, "actor", num_actions, **actor_kwargs).to(device), obs_groups


def actor_mean(actor, actor_obs: torch.Tensor) -> torch.Tensor:
    """The actor's deterministic output on its concatenated observation groups (what rsl-rl's `forward` computes
    from a TensorDict: normalise, MLP, the distribution's mean)."""
    out = actor.mlp(actor.obs_normalizer(actor_obs))
    return out if actor.distribution is None else actor.distribution.deterministic_output(out)


class FastTd3:
    """The networks, their optimizers and one update (critic every call, actor every `policy_frequency`)."""

    def __init__(self, cfg: FastTd3Cfg, actor, critic_obs_dim: int, action_dim: int, device: str):
        import copy

        self.cfg, self.device, self.actor = cfg, device, actor
        self.critic = TwinDistributionalCritic(critic_obs_dim, action_dim, cfg).to(device)
        self.critic_target = copy.deepcopy(self.critic).requires_grad_(False)
        self.actor_optimizer = torch.optim.AdamW(actor.parameters(), lr=cfg.actor_learning_rate,
                                                 weight_decay=cfg.weight_decay)
        self.critic_optimizer = torch.optim.AdamW(self.critic.parameters(), lr=cfg.critic_learning_rate,
                                                  weight_decay=cfg.weight_decay)
        self.updates = 0
        self.autocast = (torch.autocast("cuda", dtype=torch.bfloat16)
                         if cfg.mixed_precision and str(device).startswith("cuda") else nullcontext())

    def bounded(self, actions: torch.Tensor) -> torch.Tensor:
        return actions.clamp(-self.cfg.action_bound, self.cfg.action_bound)

    def update(self, batch) -> dict:
        """One critic update (and, every `policy_frequency` calls, one actor update); the losses (tensors, no
        host synchronisation)."""
        cfg, critic = self.cfg, self.critic
        with torch.no_grad(), self.autocast:
            noise = (torch.randn_like(batch.actions) * cfg.target_policy_noise).clamp(-cfg.target_noise_clip,
                                                                                      cfg.target_noise_clip)
            next_actions = self.bounded(actor_mean(self.actor, batch.next_actor_obs) + noise)
            target1, target2 = self.critic_target(batch.next_critic_obs, next_actions)
            # clipped double Q: the distribution of the target critic with the smaller expected return
            use_first = critic.values(target1) < critic.values(target2)
            target_logits = torch.where(use_first[:, None], target1, target2)
            target = project_distribution(torch.softmax(target_logits.float(), -1), batch.returns,
                                          batch.bootstrap_discount, critic.support)
        with self.autocast:
            logits1, logits2 = critic(batch.critic_obs, batch.actions)
        weight = batch.valid.float() / batch.valid.float().sum().clamp(min=1.0)
        critic_loss = sum(-(target * F.log_softmax(logits.float(), -1)).sum(-1).mul(weight).sum()
                          for logits in (logits1, logits2))
        self.step(self.critic_optimizer, critic_loss, critic.parameters())
        with torch.no_grad():
            for target_weight, weight_now in zip(self.critic_target.parameters(), critic.parameters()):
                target_weight.lerp_(weight_now, cfg.tau)
        self.updates += 1
        losses = {"critic": critic_loss.detach()}
        if self.updates % cfg.policy_frequency == 0:
            with self.autocast:
                mean = actor_mean(self.actor, batch.actor_obs)
                q1, q2 = critic(batch.critic_obs, self.bounded(mean))
            q = torch.minimum(critic.values(q1), critic.values(q2))
            excess = (mean.float().abs() - cfg.action_bound).clamp(min=0.0)
            actor_loss = -q.mean() + cfg.action_bound_penalty * excess.square().mean()
            self.step(self.actor_optimizer, actor_loss, self.actor.parameters())
            losses.update(actor=actor_loss.detach(), q=q.mean().detach())
        return losses

    def step(self, optimizer, loss: torch.Tensor, parameters) -> None:
        optimizer.zero_grad(set_to_none=True)
        loss.backward()
        if self.cfg.max_grad_norm > 0.0:
            torch.nn.utils.clip_grad_norm_(list(parameters), self.cfg.max_grad_norm)
        optimizer.step()


class FastTd3Runner:
    """Trains `FastTd3` on a `RslRlVecEnvWrapper`'d env: iterations of env steps and updates, a checkpoint every
    `save_interval` iterations (model_<iteration>.pt in `log_dir`), a log block per iteration."""

    def __init__(self, env, cfg: FastTd3Cfg, log_dir: str | None, device: str, overrides=()):
        cfg.check()
        torch.manual_seed(cfg.seed)
        self.env, self.cfg, self.log_dir, self.device = env, cfg, log_dir, device
        self.overrides = list(overrides)
        obs = env.get_observations()
        actor, self.obs_groups = build_actor(cfg, obs, env.num_actions, device)
        critic_obs_dim = sum(obs[g].shape[-1] for g in self.obs_groups["critic"])
        self.alg = FastTd3(cfg, actor, critic_obs_dim, env.num_actions, device)
        self.buffer = ReplayBuffer(num_envs=env.num_envs, steps_per_env=cfg.buffer_steps_per_env,
                                   actor_obs_dim=actor.obs_dim, critic_obs_dim=critic_obs_dim,
                                   action_dim=env.num_actions, device=device)
        self.current_learning_iteration = 0
        self.writer = None
        if log_dir is not None and cfg.logger == "tensorboard":
            from torch.utils.tensorboard import SummaryWriter

            self.writer = SummaryWriter(log_dir=log_dir, flush_secs=10)

    def group_obs(self, obs, name: str) -> torch.Tensor:
        return torch.cat([obs[g] for g in self.obs_groups[name]], dim=-1)

    def new_exploration_std(self, count: int) -> torch.Tensor:
        low, high = self.cfg.exploration_std_min, self.cfg.exploration_std_max
        return low + (high - low) * torch.rand(count, 1, device=self.device)

    def learn(self, num_learning_iterations: int) -> None:
        cfg, env, alg = self.cfg, self.env, self.alg
        obs = env.get_observations()
        if self.current_learning_iteration == 0:  # spread the time-outs over the episode, as rsl-rl's PPO does
            env.episode_length_buf = torch.randint_like(env.episode_length_buf, high=int(env.max_episode_length))
        std = self.new_exploration_std(env.num_envs)
        episode_return = torch.zeros(env.num_envs, device=self.device)
        episode_length = torch.zeros(env.num_envs, device=self.device)
        start = self.current_learning_iteration
        last = start + num_learning_iterations - 1
        for iteration in range(start, last + 1):
            self.current_learning_iteration = iteration
            started = time.perf_counter()
            ended_return = torch.zeros((), device=self.device)
            ended_length = torch.zeros((), device=self.device)
            ended = torch.zeros((), device=self.device)
            losses = {}
            for _ in range(cfg.num_steps_per_env):
                actor_obs, critic_obs = self.group_obs(obs, "actor"), self.group_obs(obs, "critic")
                with torch.no_grad():
                    alg.actor.update_normalization(obs)  # a no-op where the task's actor normalises nothing
                    alg.critic.obs_normalizer.update(critic_obs)
                    with alg.autocast:
                        mean = actor_mean(alg.actor, actor_obs).float()
                    actions = alg.bounded(mean + torch.randn_like(mean) * std)
                obs, rewards, dones, extras = env.step(actions)
                done = dones.bool()
                truncated = extras["time_outs"].bool()
                self.buffer.add(actor_obs=actor_obs, critic_obs=critic_obs, actions=actions, rewards=rewards,
                                terminated=done & ~truncated, truncated=truncated)
                episode_return += rewards
                episode_length += 1
                ended_return += (episode_return * done).sum()
                ended_length += (episode_length * done).sum()
                ended += done.sum()
                episode_return *= ~done
                episode_length *= ~done
                std = torch.where(done[:, None], self.new_exploration_std(env.num_envs), std)
                if self.buffer.steps_stored > max(cfg.learning_starts, cfg.n_steps):
                    for _ in range(cfg.updates_per_step):
                        batch = self.buffer.sample(batch_size=cfg.batch_size, n_steps=cfg.n_steps, gamma=cfg.gamma)
                        losses.update(alg.update(batch))
            self.log(iteration, last, time.perf_counter() - started, losses, extras,
                     ended_return / ended.clamp(min=1), ended_length / ended.clamp(min=1), ended)
            if self.log_dir is not None and (iteration % cfg.save_interval == 0 or iteration == last):
                self.save(os.path.join(self.log_dir, f"model_{iteration}.pt"))

    def log(self, iteration: int, last: int, seconds: float, losses: dict, extras: dict, mean_return, mean_length,
            ended) -> None:
        """rsl-rl's block heading ("Learning iteration i/N", which `agile time_to_policy` waits for), the means of
        the episodes ended in the iteration, the losses and the env's logged terms (one host synchronisation)."""
        values = {"Train/mean_reward": mean_return, "Train/mean_episode_length": mean_length,
                  "Train/episodes_ended": ended, **{f"Loss/{k}": v for k, v in losses.items()}}
        values.update({k: v for k, v in extras.get("log", {}).items() if isinstance(v, (torch.Tensor, float, int))})
        values = {k: float(v) for k, v in values.items()}
        steps = self.env.num_envs * self.cfg.num_steps_per_env
        lines = [f"Learning iteration {iteration}/{last}",
                 f"  env steps/s {steps / seconds:,.0f}, iteration time {seconds:.2f} s"]
        lines += [f"  {k}: {v:.4f}" for k, v in values.items()]
        print("\n".join(lines), flush=True)
        if self.writer is not None:
            for key, value in values.items():
                self.writer.add_scalar(key, value, iteration)

    def save(self, path: str) -> None:
        """A checkpoint written whole or not at all: the actor as a PPO checkpoint holds it ("actor_state_dict"),
        FastTD3's critic and optimizers under their own keys, no "optimizer_state_dict" (evaluation loads the
        actor alone), the env's training state and the run's overrides."""
        alg = self.alg
        env = getattr(self.env, "env", self.env)
        infos = {"overrides": self.overrides, "trainer": "fast_td3", "fast_td3": dataclasses.asdict(self.cfg)}
        if hasattr(env, "training_state"):
            infos["env_state"] = env.training_state()
        saved = {"actor_state_dict": alg.actor.state_dict(), "fast_td3_critic_state_dict": alg.critic.state_dict(),
                 "fast_td3_critic_target_state_dict": alg.critic_target.state_dict(),
                 "fast_td3_actor_optimizer_state_dict": alg.actor_optimizer.state_dict(),
                 "fast_td3_critic_optimizer_state_dict": alg.critic_optimizer.state_dict(),
                 "iter": self.current_learning_iteration, "infos": infos}
        torch.save(saved, f"{path}.tmp")
        os.replace(f"{path}.tmp", path)
