"""HappoRunner: HARL's HAPPO learners (`agile.marl.harl`) fed from one synchronous stepping of a multi-rate world,
the rollout held on the world's device; checkpoints happo_<iteration>.pt in its run folder."""

from __future__ import annotations

import json
import os
import time

import torch

from agile.marl.env import MultiAgentEnv
from agile.marl.harl import (HappoCfg, HarlWorldView, build_learners, harl_args, next_agent_factor,
                             team_advantages)
from agile.marl.runner import rollout_physics_steps
from agile.utils.config import ConfigError, to_dict

CHECKPOINT_PREFIX = "happo_"


class HappoRunner:
    """Collect `cfg.rollout_s` simulated seconds slot by slot, then update the agents one after another in a random
    order (each weighted by the ratios of the agents updated before it) and the critic."""

    def __init__(self, world: MultiAgentEnv, cfg: HappoCfg, log_dir: str | None, device: str,
                 started_at: float | None = None):
        self.started_at = time.time() if started_at is None else started_at
        """time.time() when the run started: each checkpoint records the seconds since (`infos["wall_s"]`)."""
        self.view = HarlWorldView(world, cfg.actor_group, cfg.critic_group)
        self.world, self.cfg, self.log_dir, self.device = world, cfg, log_dir, device
        rollout_steps = rollout_physics_steps(world, cfg.rollout_s)
        self.slots_per_rollout = rollout_steps // world.schedule.hyperperiod_steps * len(world.schedule.slots)
        torch.manual_seed(cfg.seed)
        self.args = harl_args(cfg)
        self.actors, self.critic = build_learners(self.view, self.args, device)
        self.current_learning_iteration = 0
        self.writer = None
        if log_dir is not None:
            from torch.utils.tensorboard import SummaryWriter

            self.writer = SummaryWriter(log_dir)

    def _rnn_states(self, rows: int) -> torch.Tensor:
        # HARL's networks take a recurrent state even when not recurrent; unused then
        return torch.zeros(rows, self.args["recurrent_n"], self.args["hidden_sizes"][-1], device=self.device)

    def _ones(self, rows: int) -> torch.Tensor:
        return torch.ones(rows, 1, device=self.device)

    def policies(self, deterministic: bool = True) -> dict:
        """{agent name: observations -> actions}, HARL's actors as `evaluate` calls them."""
        def policy(actor):
            def act(obs):
                actions, _ = actor.act(obs, self._rnn_states(obs.shape[0]), self._ones(obs.shape[0]), None,
                                       deterministic)
                return actions
            return act
        return {n: policy(a) for n, a in self.actors.items()}

    # -- rollout ------------------------------------------------------------------------------------------------

    def collect(self) -> dict:
        """One rollout: per slot the state, value, team reward and done; per agent its observations, actions, their
        log-probabilities and where it was active. Everything on the device; no host synchronisation."""
        world, view, n, t_max = self.world, self.view, self.world.num_envs, self.slots_per_rollout
        rollout = {"state": [], "value": [], "reward": [], "done": [],
                   "agents": {a: {"obs": [], "action": [], "log_prob": [], "active": []} for a in view.agent_names}}
        rnn, ones = self._rnn_states(n), self._ones(n)
        for _ in range(t_max):
            state = view.state()
            value, _ = self.critic.get_values(state, rnn, ones)
            actions = {}
            for name, actor in self.actors.items():
                store = rollout["agents"][name]
                obs = view.obs(name)
                active = view.active(name)
                if name in world.acting_agents:
                    action, log_prob, _ = actor.get_actions(obs, rnn, ones)
                    actions[name] = action
                else:  # not its slot: no action, no sample
                    action = torch.zeros(n, view.action_spaces[name].shape[0], device=self.device)
                    log_prob = torch.zeros_like(action)
                store["obs"].append(obs)
                store["action"].append(action)
                store["log_prob"].append(log_prob)
                store["active"].append(active)
            steps = world.step(actions)
            reward, done, time_out = view.team_step(steps, every_agent_ended=len(steps) == len(world.agents))
            # a time-out ends the episode but not the task: the return goes on past it (as rsl-rl's PPO bootstraps)
            reward = reward + self.cfg.gamma * value.squeeze(-1) * time_out
            rollout["state"].append(state)
            rollout["value"].append(value.squeeze(-1))
            rollout["reward"].append(reward)
            rollout["done"].append(done)
        last_value, _ = self.critic.get_values(view.state(), rnn, ones)
        stacked = {k: torch.stack(rollout[k]) for k in ("state", "value", "reward", "done")}
        stacked["agents"] = {a: {k: torch.stack(v) for k, v in s.items()} for a, s in rollout["agents"].items()}
        stacked["advantage"], stacked["return"] = team_advantages(
            stacked["reward"], stacked["value"], stacked["done"], last_value.squeeze(-1), self.cfg.gamma,
            self.cfg.lam)
        return stacked

    # -- update -------------------------------------------------------------------------------------------------

    def update(self, rollout: dict) -> dict:
        """HAPPO's sequential update: each agent on its active samples, its advantage weighted by the product of the
        new/old ratios of the agents updated before it; then the critic on every slot's state."""
        advantage = rollout["advantage"].reshape(-1, 1)
        factor = torch.ones_like(advantage)
        names = list(self.actors)
        order = names if self.cfg.fixed_order else [names[i] for i in torch.randperm(len(names)).tolist()]
        info = {"order": order}
        for name in order:
            actor, samples = self.actors[name], {k: v.flatten(0, 1) for k, v in rollout["agents"][name].items()}
            active = samples["active"]
            rows = active.nonzero().squeeze(-1)
            if rows.numel() < 2:
                continue  # never active in this rollout (its robots dead throughout): nothing to learn from
            obs, action, old_log_prob = samples["obs"][rows], samples["action"][rows], samples["log_prob"][rows]
            agent_advantage = advantage[rows]
            agent_advantage = (agent_advantage - agent_advantage.mean()) / (agent_advantage.std() + 1e-5)
            with torch.no_grad():
                before, _, _ = actor.evaluate_actions(obs, self._rnn_states(rows.numel()), action,
                                                      self._ones(rows.numel()))
            losses = []
            for _ in range(self.cfg.num_epochs):
                for batch in torch.randperm(rows.numel(), device=self.device).chunk(self.cfg.num_mini_batches):
                    size = batch.numel()
                    loss, entropy, _, _ = actor.update((obs[batch], self._rnn_states(size), action[batch],
                                                        self._ones(size), self._ones(size), old_log_prob[batch],
                                                        agent_advantage[batch], None, factor[rows][batch]))
                    losses.append(loss.detach())
            with torch.no_grad():
                after, _, _ = actor.evaluate_actions(obs, self._rnn_states(rows.numel()), action,
                                                     self._ones(rows.numel()))
            factor[rows] = next_agent_factor(factor[rows], torch.ones_like(rows, dtype=torch.bool), before, after)
            info[f"{name}/surrogate_loss"] = torch.stack(losses).mean()
            info[f"{name}/entropy"] = entropy.detach()
            info[f"{name}/samples"] = rows.numel()
        state, value, ret = (rollout["state"].flatten(0, 1), rollout["value"].reshape(-1, 1),
                             rollout["return"].reshape(-1, 1))
        value_losses = []
        for _ in range(self.cfg.num_epochs):
            for batch in torch.randperm(state.shape[0], device=self.device).chunk(self.cfg.num_mini_batches):
                loss, _ = self.critic.update((state[batch], self._rnn_states(batch.numel()), value[batch], ret[batch],
                                              self._ones(batch.numel())))
                value_losses.append(loss.detach())
        info["critic/value_loss"] = torch.stack(value_losses).mean()
        info["factor/mean"] = factor.mean()
        return info

    # -- training -----------------------------------------------------------------------------------------------

    def learn(self, num_learning_iterations: int) -> list[dict]:
        """Train; a line per iteration (team reward per slot, losses, world steps per second); returns those
        figures."""
        if self.world.slot != 0:  # a rollout starts where every agent acts
            self.world.reset()
        history = []
        start_it = self.current_learning_iteration
        for it in range(start_it, start_it + num_learning_iterations):
            start = time.time()
            with torch.no_grad():
                rollout = self.collect()
            collect_s = time.time() - start
            info = self.update(rollout)
            iteration_s = time.time() - start
            figures = {"iteration": it, "team_reward_per_slot": float(rollout["reward"].mean()),
                       "env_steps_per_s": self.slots_per_rollout * self.world.num_envs / iteration_s,
                       "collect_s": collect_s, "learn_s": iteration_s - collect_s,
                       **{k: float(v) for k, v in info.items() if k != "order"}}
            history.append(figures)
            print(f"[agile] happo iteration {it}: team reward per slot {figures['team_reward_per_slot']:.4f}, value "
                  f"loss {figures['critic/value_loss']:.4f}, order {'>'.join(info['order'])}, "
                  f"{figures['env_steps_per_s']:.1f} env-steps/s", flush=True)
            if self.writer is not None:
                for key, value in figures.items():
                    if key != "iteration":
                        self.writer.add_scalar(key, value, it)
            self.current_learning_iteration = it
            if self.log_dir is not None and it % self.cfg.save_interval == 0:
                self.save(os.path.join(self.log_dir, f"{CHECKPOINT_PREFIX}{it}.pt"))
        if self.log_dir is not None:
            self.save(os.path.join(self.log_dir, f"{CHECKPOINT_PREFIX}{self.current_learning_iteration}.pt"))
            with open(os.path.join(self.log_dir, "happo_iterations.jsonl"), "a") as f:
                f.writelines(json.dumps(h) + "\n" for h in history)
            self.writer.flush()
        self.current_learning_iteration += 1
        return history

    # -- checkpoints --------------------------------------------------------------------------------------------

    def save(self, path: str) -> None:
        """Every actor, the critic and their optimisers, and the run's wall time so far (`infos["wall_s"]`, as
        agile's PPO checkpoints); written to a temporary file, then renamed."""
        saved = {"trainer": "happo", "iter": self.current_learning_iteration, "cfg": to_dict(self.cfg),
                 "infos": {"wall_s": round(time.time() - self.started_at, 1)},
                 "actors": {n: {"model": a.actor.state_dict(), "optimizer": a.actor_optimizer.state_dict()}
                            for n, a in self.actors.items()},
                 "critic": {"model": self.critic.critic.state_dict(),
                            "optimizer": self.critic.critic_optimizer.state_dict()}}
        torch.save(saved, f"{path}.tmp")
        os.replace(f"{path}.tmp", path)

    def load(self, contents: dict, optimizers: bool = True) -> None:
        """Restore a checkpoint's contents (from `save`); the agents must be the world's."""
        if contents.get("trainer") != "happo" or set(contents.get("actors", {})) != set(self.actors):
            raise ConfigError(f"not a HAPPO checkpoint of agents {list(self.actors)} (it holds "
                              f"{contents.get('trainer')!r} with agents {list(contents.get('actors', {}))})")
        for name, actor in self.actors.items():
            actor.actor.load_state_dict(contents["actors"][name]["model"])
            if optimizers:
                actor.actor_optimizer.load_state_dict(contents["actors"][name]["optimizer"])
        self.critic.critic.load_state_dict(contents["critic"]["model"])
        if optimizers:
            self.critic.critic_optimizer.load_state_dict(contents["critic"]["optimizer"])
        self.current_learning_iteration = contents["iter"] + 1
