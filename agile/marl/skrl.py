"""A MAPPO-style centralised critic through skrl's multi-agent PPO (a maintained implementation, rather than one
written here): the world as the multi-agent env of skrl's Isaac Lab wrapper, and the learner built on it.

Every agent's actor sees its own "policy" observation group; the shared critic sees the "critic" groups of all
agents, concatenated (the state). MAPPO acts for every agent at every step, so the world's agents must share one
control rate; a multi-rate world is trained by agent groups (`agile.marl.runner`) or stepped through the AEC view.
"""

from __future__ import annotations

import dataclasses

import gymnasium as gym
import numpy as np
import torch

from agile.marl.env import MultiAgentEnv
from agile.rl import flatten_groups
from agile.utils.config import ConfigError


class SkrlMultiAgentView:
    """What `skrl.envs.wrappers.torch.wrap_env(view, wrapper="isaaclab-multi-agent")` reads: batched dicts of
    tensors per agent, a state for the centralised critic, the spaces."""

    def __init__(self, world: MultiAgentEnv, actor_group: str = "policy", critic_group: str = "critic"):
        if len(world.schedule.slots) != 1:
            raise ConfigError(f"MAPPO acts for every agent at every step; this world's agents act at different "
                              f"steps ({world.schedule.describe()}): train it by agent groups instead")
        world.check_observation_groups(actor_group, critic_group)
        self.world = world
        self.actor_group, self.critic_group = actor_group, critic_group
        self.num_envs = world.num_envs
        self.device = world.device
        self.possible_agents = list(world.agents)
        self.agents = list(self.possible_agents)
        self.num_agents = self.max_num_agents = len(self.agents)
        dims = {n: a.observation_manager.group_dims for n, a in world.agents.items()}
        self.observation_spaces = {n: gym.spaces.Box(-np.inf, np.inf, (d[actor_group],), np.float32)
                                   for n, d in dims.items()}
        self.action_spaces = dict(world.single_action_spaces)
        self.state_space = gym.spaces.Box(-np.inf, np.inf, (sum(d[critic_group] for d in dims.values()),),
                                          np.float32)
        self.state_spaces = dict.fromkeys(self.possible_agents, self.state_space)

    @property
    def unwrapped(self):
        return self

    def _observations(self) -> dict[str, torch.Tensor]:
        return {n: flatten_groups(a.obs_buf)[self.actor_group] for n, a in self.world.agents.items()}

    def state(self) -> torch.Tensor:
        return torch.cat([flatten_groups(a.obs_buf)[self.critic_group] for a in self.world.agents.values()], dim=-1)

    def reset(self, seed: int | None = None, options: dict | None = None):
        self.world.reset(seed=seed)
        return self._observations(), {}

    def step(self, actions: dict[str, torch.Tensor]):
        steps = self.world.step(actions)
        return (self._observations(), {n: s.reward for n, s in steps.items()},
                {n: s.terminated for n, s in steps.items()}, {n: s.truncated for n, s in steps.items()}, {})

    def render(self, *args, **kwargs):
        return None

    def close(self) -> None:
        self.world.close()


def mappo(view: SkrlMultiAgentView, rollouts: int = 24, hidden_dims: tuple[int, ...] = (256, 128),
          learning_rate: float = 1e-3, experiment_dir: str = "", **cfg):
    """skrl's MAPPO over the view: a Gaussian actor per agent on its own observations, a value network per agent
    on the shared state; `cfg` sets further `MAPPO_CFG` fields. Returns (wrapped env, learner)."""
    from skrl.envs.wrappers.torch import wrap_env
    from skrl.memories.torch import RandomMemory
    from skrl.multi_agents.torch.mappo import MAPPO, MAPPO_CFG
    from skrl.utils.model_instantiators.torch import deterministic_model, gaussian_model

    env = wrap_env(view, wrapper="isaaclab-multi-agent", verbose=False)
    layers = {"layers": list(hidden_dims), "activations": "elu"}
    models, memories = {}, {}
    for name in env.possible_agents:
        models[name] = {
            "policy": gaussian_model(observation_space=env.observation_spaces[name], action_space=env.action_spaces[name],
                                     device=env.device, network=[{"name": "net", "input": "OBSERVATIONS", **layers}],
                                     output="ACTIONS"),
            "value": deterministic_model(state_space=env.state_spaces[name], action_space=env.action_spaces[name],
                                         device=env.device, network=[{"name": "net", "input": "STATES", **layers}],
                                         output="ONE"),
        }
        memories[name] = RandomMemory(memory_size=rollouts, num_envs=env.num_envs, device=env.device)
    learner_cfg = MAPPO_CFG(rollouts=rollouts, learning_rate=learning_rate, **cfg)
    learner_cfg.experiment.directory = experiment_dir
    # skrl 2.1 expands per-agent settings and takes an empty dict (e.g. a scheduler's kwargs) for a dict of agents
    # that misses them all: give every agent its own empty dict
    for field in dataclasses.fields(learner_cfg):
        if getattr(learner_cfg, field.name) == {} and field.name != "experiment":
            setattr(learner_cfg, field.name, {name: {} for name in env.possible_agents})
    learner = MAPPO(possible_agents=env.possible_agents, models=models, memories=memories,
                    observation_spaces=env.observation_spaces, state_spaces=env.state_spaces,
                    action_spaces=env.action_spaces, device=env.device, cfg=learner_cfg)
    return env, learner
