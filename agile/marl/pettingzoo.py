"""PettingZoo views of a MultiAgentEnv: thin converters over its synchronous slot step.

- `ParallelView`: every agent in every step, each value batched over the envs (torch); envs reset on their own.
  In a multi-rate world one step is one slot: an agent's action is used only when it acts (`infos[agent]
  ["acting"]` says whether it acts at the next step), its reward and done flags arrive when its period ends.
- `SingleEnvParallelView` and `SingleEnvAECView`: a one-env world as PettingZoo's standard single-env APIs
  (numpy values, dead agents leave `agents`, the episode ends when none is left), checked by PettingZoo's
  `parallel_api_test` and `api_test`. The AEC view is the multi-rate one: `agent_selection` runs through the
  agents acting at the current slot, and the world advances once each of them has acted.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import torch
from pettingzoo import AECEnv, ParallelEnv

from agile.marl.env import MultiAgentEnv
from agile.rl import flatten_groups


class ParallelView(ParallelEnv):
    """The world as a batched PettingZoo ParallelEnv (values are tensors with the env count first)."""

    metadata = {"name": "agile_multi_agent_parallel"}

    def __init__(self, world: MultiAgentEnv):
        self.world = world
        self.possible_agents = list(world.agents)
        self.agents = list(self.possible_agents)

    def observation_space(self, agent):
        return self.world.single_observation_spaces[agent]

    def action_space(self, agent):
        return self.world.single_action_spaces[agent]

    def _infos(self) -> dict:
        acting = set(self.world.acting_agents)
        return {a: {"acting": a in acting, "log": self.world.agents[a].log.snapshot()} for a in self.agents}

    def reset(self, seed: int | None = None, options: dict | None = None):
        obs, _ = self.world.reset(seed=seed)
        return obs, self._infos()

    def step(self, actions: dict):
        world = self.world
        steps = world.step({a: torch.as_tensor(actions[a], dtype=torch.float32) for a in world.acting_agents})
        n, device = world.num_envs, world.device
        no = torch.zeros(n, dtype=torch.bool, device=device)
        obs = {a: world.agents[a].obs_buf for a in self.agents}
        rewards = {a: steps[a].reward if a in steps else torch.zeros(n, device=device) for a in self.agents}
        terminated = {a: steps[a].terminated if a in steps else no for a in self.agents}
        truncated = {a: steps[a].truncated if a in steps else no for a in self.agents}
        return obs, rewards, terminated, truncated, self._infos()


def _single_env_spaces(world: MultiAgentEnv) -> dict[str, gym.spaces.Dict]:
    """Per agent, a Dict of its observation groups, each flattened to one float32 vector."""
    if world.num_envs != 1:
        raise ValueError(f"a single-env view needs a world of 1 env, got {world.num_envs}")
    return {name: gym.spaces.Dict({g: gym.spaces.Box(-np.inf, np.inf, (dim,), np.float32)
                                   for g, dim in flatten_groups(agent.obs_buf)[0].items()
                                   for dim in [dim.shape[-1]]})
            for name, agent in world.agents.items()}


def _observe(world: MultiAgentEnv, agent: str) -> dict[str, np.ndarray]:
    flat = flatten_groups(world.agents[agent].obs_buf)
    return {g: flat[g][0].detach().cpu().numpy().astype(np.float32) for g in flat.keys()}


def _world_actions(world: MultiAgentEnv, actions: dict) -> dict[str, torch.Tensor]:
    """The actions of the agents acting now, from numpy; zeros for one that has left (its robots are frozen)."""
    out = {}
    for a in world.acting_agents:
        dim = world.agents[a].action_manager.total_action_dim
        value = actions.get(a)
        out[a] = torch.zeros(1, dim) if value is None else torch.as_tensor(np.asarray(value, np.float32)).view(1, dim)
    return out


class SingleEnvParallelView(ParallelEnv):
    """A one-env world as a standard PettingZoo ParallelEnv (numpy observations, float rewards)."""

    metadata = {"name": "agile_multi_agent_parallel_single_env"}

    def __init__(self, world: MultiAgentEnv):
        self.world = world
        self.possible_agents = list(world.agents)
        self.agents = list(self.possible_agents)
        self._observation_spaces = _single_env_spaces(world)

    def observation_space(self, agent):
        return self._observation_spaces[agent]

    def action_space(self, agent):
        return self.world.single_action_spaces[agent]

    def _infos(self) -> dict:
        return {a: {"acting": a in self.world.acting_agents} for a in self.agents}

    def reset(self, seed: int | None = None, options: dict | None = None):
        self.world.reset(seed=seed)
        self.agents = list(self.possible_agents)
        return {a: _observe(self.world, a) for a in self.agents}, self._infos()

    def step(self, actions: dict):
        steps = self.world.step(_world_actions(self.world, {a: v for a, v in actions.items() if a in self.agents}))
        rewards = {a: float(steps[a].reward[0]) if a in steps else 0.0 for a in self.agents}
        terminated = {a: bool(steps[a].terminated[0]) if a in steps else False for a in self.agents}
        truncated = {a: bool(steps[a].truncated[0]) if a in steps else False for a in self.agents}
        obs = {a: _observe(self.world, a) for a in self.agents}
        infos = self._infos()
        self.agents = [a for a in self.agents if not (terminated[a] or truncated[a])]
        return obs, rewards, terminated, truncated, infos


class SingleEnvAECView(AECEnv):
    """A one-env world as a PettingZoo AECEnv: the agents acting at the current slot take turns; once they all
    have, the world runs to the next slot."""

    metadata = {"name": "agile_multi_agent_aec", "is_parallelizable": False}

    def __init__(self, world: MultiAgentEnv):
        super().__init__()
        self.world = world
        self.possible_agents = list(world.agents)
        self._observation_spaces = _single_env_spaces(world)
        self.agents = []

    def observation_space(self, agent):
        return self._observation_spaces[agent]

    def action_space(self, agent):
        return self.world.single_action_spaces[agent]

    def observe(self, agent):
        return _observe(self.world, agent)

    def reset(self, seed: int | None = None, options: dict | None = None):
        self.world.reset(seed=seed)
        self.agents = list(self.possible_agents)
        self.rewards = dict.fromkeys(self.agents, 0.0)
        self._cumulative_rewards = dict.fromkeys(self.agents, 0.0)
        self.terminations = dict.fromkeys(self.agents, False)
        self.truncations = dict.fromkeys(self.agents, False)
        self.infos = {a: {} for a in self.agents}
        self._actions: dict[str, np.ndarray] = {}
        self._turns = [a for a in self.world.acting_agents if a in self.agents]
        self._skip_agent_selection = None
        self.agent_selection = self._turns[0]

    def step(self, action):
        agent = self.agent_selection
        if self.terminations[agent] or self.truncations[agent]:
            self._was_dead_step(action)
            return
        self._cumulative_rewards[agent] = 0.0
        self._actions[agent] = action
        self._turns.remove(agent)
        self._clear_rewards()
        if not self._turns:
            self._advance()
        self.agent_selection = self._turns[0] if self._turns else next(
            (a for a in self.agents if self.terminations[a] or self.truncations[a]), agent)
        self._accumulate_rewards()
        self._deads_step_first()

    def _playing(self) -> list[str]:
        return [a for a in self.agents if not (self.terminations[a] or self.truncations[a])]

    def _advance(self) -> None:
        """Run the world to the next slot at which an agent still playing acts, collecting rewards and dones."""
        while True:
            steps = self.world.step(_world_actions(self.world, self._actions))
            self._actions = {}
            for a in self._playing():
                if a in steps:
                    self.rewards[a] += float(steps[a].reward[0])
                    self.terminations[a] = bool(steps[a].terminated[0])
                    self.truncations[a] = bool(steps[a].truncated[0])
            playing = self._playing()
            self._turns = [a for a in self.world.acting_agents if a in playing]
            if self._turns or not playing:
                return
