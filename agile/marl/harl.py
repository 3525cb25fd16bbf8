"""HAPPO (heterogeneous-agent PPO, Kuba et al. 2022) through PKU-MARL HARL's implementation as packaged in
`harl-aht` 0.1.0 (`pip install 'agile[harl]'`): its HAPPO actors (one network and one optimiser per agent, no
parameter sharing; the clipped surrogate weighted by the factor of the agents updated before) and its V critic.

HARL's own runner builds its envs from a fixed list of names and keeps its buffers as numpy arrays on the host; this
adapter uses HARL's learners only, on a rollout held on the world's device (HARL's `update` methods take tensors):
- the timeline is the world's schedule slots; at a slot only the agents due act (`MultiAgentEnv.acting_agents`);
- an agent contributes a sample at a slot where it acts and is alive (HARL's active mask): the samples of the
  others are not fed to its update, and its ratio does not enter the factor there;
- the centralised critic reads the world's state, the agents' "critic" observation groups concatenated (an agent
  that does not act at a slot shows its observation of its last slot), and learns the team return: the sum of the
  agents' rewards over the slots, an episode ending where the world resets the env.
"""

from __future__ import annotations

import importlib.resources

import gymnasium as gym
import numpy as np
import torch
import yaml

from agile.marl.env import AgentStep, MultiAgentEnv
from agile.rl import flatten_groups
from agile.utils.config import ConfigError, configclass


@configclass
class HappoCfg:
    experiment_name: str = "multi_agent_happo"
    run_name: str = ""
    seed: int = 42
    max_iterations: int = 1000
    save_interval: int = 100
    rollout_s: float = 0.48
    """Simulated time of one rollout; a whole number of the schedule's hyperperiods."""
    actor_group: str = "policy"
    """Observation group each agent's actor reads."""
    critic_group: str = "critic"
    """Observation group of every agent that the centralised critic reads (concatenated: the state)."""
    hidden_dims: list = [256, 128]
    activation: str = "relu"
    """One of HARL's: sigmoid, tanh, relu, leaky_relu, selu."""
    actor_learning_rate: float = 5e-4
    critic_learning_rate: float = 5e-4
    num_epochs: int = 5
    num_mini_batches: int = 4
    clip_param: float = 0.2
    entropy_coef: float = 0.01
    max_grad_norm: float = 10.0
    gamma: float = 0.99
    """Discount per slot of the schedule."""
    lam: float = 0.95
    fixed_order: bool = False
    """Update the agents in the world's order every iteration instead of a random order."""
    harl_args: dict = {}
    """Further keys of HARL's happo.yaml ("model" and "algo" sections), e.g. {"std_y_coef": 0.5}."""


def harl_args(cfg: HappoCfg) -> dict:
    """HARL's settings: its happo.yaml defaults, then ours, then `cfg.harl_args`."""
    defaults = yaml.safe_load((importlib.resources.files("harl") / "configs" / "algos_cfgs" / "happo.yaml").read_text())
    args = {**defaults["model"], **defaults["algo"]}
    unknown = sorted(set(cfg.harl_args) - set(args))
    if unknown:
        raise ConfigError(f"harl_args: HARL's HAPPO has no setting {unknown}; its settings: {sorted(args)}")
    args.update(hidden_sizes=list(cfg.hidden_dims), activation_func=cfg.activation, lr=cfg.actor_learning_rate,
                critic_lr=cfg.critic_learning_rate, ppo_epoch=cfg.num_epochs, critic_epoch=cfg.num_epochs,
                actor_num_mini_batch=cfg.num_mini_batches, critic_num_mini_batch=cfg.num_mini_batches,
                clip_param=cfg.clip_param, entropy_coef=cfg.entropy_coef, max_grad_norm=cfg.max_grad_norm,
                gamma=cfg.gamma, gae_lambda=cfg.lam, use_policy_active_masks=True, action_aggregation="prod",
                use_recurrent_policy=False, use_naive_recurrent_policy=False)
    args.update(cfg.harl_args)
    return args


class HarlWorldView:
    """The world in HARL's terms: per-agent observations and actions, the shared state, the active mask."""

    def __init__(self, world: MultiAgentEnv, actor_group: str = "policy", critic_group: str = "critic"):
        if not isinstance(world, MultiAgentEnv):
            raise ConfigError(f"HAPPO trains a multi-agent world; got a {type(world).__name__}")
        world.check_observation_groups(actor_group, critic_group)
        self.world = world
        self.actor_group, self.critic_group = actor_group, critic_group
        self.agent_names = list(world.agents)
        dims = {n: a.observation_manager.group_dims for n, a in world.agents.items()}
        self.observation_spaces = {n: gym.spaces.Box(-np.inf, np.inf, (d[actor_group],), np.float32)
                                   for n, d in dims.items()}
        self.action_spaces = {n: gym.spaces.Box(-np.inf, np.inf, s.shape, np.float32)
                              for n, s in world.single_action_spaces.items()}
        self.state_space = gym.spaces.Box(-np.inf, np.inf, (sum(d[critic_group] for d in dims.values()),), np.float32)

    def obs(self, name: str) -> torch.Tensor:
        return flatten_groups(self.world.agents[name].obs_buf)[self.actor_group]

    def state(self) -> torch.Tensor:
        return torch.cat([flatten_groups(a.obs_buf)[self.critic_group] for a in self.world.agents.values()], dim=-1)

    def active(self, name: str) -> torch.Tensor:
        """(N,) the agent acts at the current slot and its robots are alive."""
        agent = self.world.agents[name]
        return agent.alive & (name in self.world.acting_agents)

    @staticmethod
    def team_step(steps: dict[str, AgentStep], every_agent_ended: bool):
        """(team reward, env done, time out) of a step: the reward summed over the agents whose period ended; the env
        is done where the world reset it (only where every agent's period ends)."""
        reward = torch.stack([s.reward for s in steps.values()]).sum(dim=0)
        if not every_agent_ended:
            never = torch.zeros_like(reward, dtype=torch.bool)
            return reward, never, never
        done = torch.stack([s.terminated | s.truncated for s in steps.values()]).all(dim=0)
        return reward, done, done & torch.stack([s.truncated for s in steps.values()]).any(dim=0)


class AgentPolicyView:
    """One agent as `agile.run.multi_agent_world.evaluate` reads a group: its observations, its actions by name."""

    def __init__(self, view: HarlWorldView, name: str):
        self.view, self.agent_names = view, [name]

    def get_observations(self) -> torch.Tensor:
        return self.view.obs(self.agent_names[0])

    def split_actions(self, actions: torch.Tensor) -> dict[str, torch.Tensor]:
        return {self.agent_names[0]: actions}


def build_learners(view: HarlWorldView, args: dict, device: str):
    """({agent: HARL HAPPO actor}, HARL V critic on the state)."""
    from harl.algorithms.actors.happo import HAPPO
    from harl.algorithms.critics.v_critic import VCritic

    device = torch.device(device)
    actors = {n: HAPPO(args, view.observation_spaces[n], view.action_spaces[n], device) for n in view.agent_names}
    return actors, VCritic(args, view.state_space, device)


def next_agent_factor(factor: torch.Tensor, active: torch.Tensor, log_prob_before: torch.Tensor,
                      log_prob_after: torch.Tensor) -> torch.Tensor:
    """HAPPO's factor for the next agent: `factor` (B, 1) times the updated agent's new/old probability ratio of its
    actions (the product over the action dimensions of (B, A) log-probabilities) where it acted (`active` (B,)),
    unchanged where it did not."""
    ratio = torch.exp((log_prob_after - log_prob_before).sum(dim=-1, keepdim=True))
    return factor * torch.where(active.unsqueeze(-1), ratio, torch.ones_like(ratio))


def team_advantages(rewards: torch.Tensor, values: torch.Tensor, dones: torch.Tensor, last_values: torch.Tensor,
                    gamma: float, lam: float) -> tuple[torch.Tensor, torch.Tensor]:
    """GAE over the slots: (advantages, returns), each (T, N), from rewards, values, dones (T, N) and the values
    after the last slot (N,)."""
    advantages = torch.zeros_like(rewards)
    running = torch.zeros_like(last_values)
    for t in reversed(range(rewards.shape[0])):
        next_values = last_values if t == rewards.shape[0] - 1 else values[t + 1]
        not_done = (~dones[t]).float()
        delta = rewards[t] + gamma * next_values * not_done - values[t]
        running = delta + gamma * lam * not_done * running
        advantages[t] = running
    return advantages, advantages + values
