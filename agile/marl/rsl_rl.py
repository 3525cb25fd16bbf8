"""Training agent groups of a multi-agent world with RSL-RL's PPO, one process, no threads.

A group is trained by one PPO learner, in one of three modes:
- "normal": one agent, its own policy;
- "shared": homogeneous agents (same observations, actions and rate) through one policy, their samples
  batched (num_envs x agents rows): the same weights, separate samples;
- "joint": one policy over several agents' observations (concatenated) and actions (split), rewarded with
  their sum; a member that dies is masked (zeros) while the others play on.
`GroupVecEnv` is the VecEnv RSL-RL builds a group's learner from; `MultiAgentRunner` steps the world and feeds
every group's learner at its own slots.
"""

from __future__ import annotations


import torch
from rsl_rl.env import VecEnv
from tensordict import TensorDict

from agile.marl.env import AgentStep, MultiAgentEnv
from agile.rl import PpoRunnerCfg, flatten_groups
from agile.utils.config import ConfigError, configclass

TRAINING_MODES = ("normal", "shared", "joint")


@configclass
class AgentGroupCfg:
    agents: list = []
    """Agent names (`MultiAgentEnvCfg.agents`); all of one control rate."""
    mode: str = "normal"
    """'normal' (one agent), 'shared' (one policy, samples batched across agents) or 'joint' (one policy over
    the agents' joint observations and actions)."""
    runner: PpoRunnerCfg = PpoRunnerCfg()
    """Its PPO settings; `num_steps_per_env` is set from `MultiAgentRunnerCfg.rollout_s` and its rate."""


@configclass
class MultiAgentRunnerCfg:
    experiment_name: str = "multi_agent"
    run_name: str = ""
    seed: int = 42
    max_iterations: int = 1000
    save_interval: int = 100
    logger: str = "tensorboard"
    rollout_s: float = 0.48
    """Simulated time of one rollout; every group collects over the same span, so all update together. A group
    acting every `period` seconds collects rollout_s / period steps per env."""
    groups: dict = {}
    """{group name: AgentGroupCfg}; every agent of the world in exactly one group."""


class GroupVecEnv(VecEnv):
    """The VecEnv of one agent group: its observations, actions and rewards in the layout of its mode.

    `step` works when the group holds every agent of a single-rate world; otherwise `MultiAgentRunner` steps
    the world and converts with `split_actions` and `combine`.
    """

    def __init__(self, world: MultiAgentEnv, name: str, cfg: AgentGroupCfg):
        where = f"group '{name}'"
        unknown = [a for a in cfg.agents if a not in world.agents]
        if unknown or not cfg.agents:
            raise ConfigError(f"{where}: agents {unknown or '[]'} are not agents of the world {list(world.agents)}")
        if cfg.mode not in TRAINING_MODES:
            raise ConfigError(f"{where}: mode '{cfg.mode}' is not one of {TRAINING_MODES}")
        if cfg.mode == "normal" and len(cfg.agents) != 1:
            raise ConfigError(f"{where}: mode 'normal' trains one agent, got {cfg.agents} ('shared' or 'joint' "
                              f"train several)")
        self.name = name
        self.mode = cfg.mode
        self.world = world
        self.agents = [world.agents[a] for a in cfg.agents]
        periods = {a.name: a.cfg.decimation for a in self.agents}
        if len(set(periods.values())) != 1:
            raise ConfigError(f"{where}: its agents act at different rates (physics steps per action {periods})")
        self.action_dims = [a.action_manager.total_action_dim for a in self.agents]
        if self.mode == "shared":
            layouts = {a.name: (a.observation_manager.group_dims, a.action_manager.total_action_dim)
                       for a in self.agents}
            if len({str(v) for v in layouts.values()}) != 1:
                raise ConfigError(f"{where}: 'shared' needs agents with the same observations and actions, got "
                                  f"{layouts}")
        self.env = self.agents[0]
        """The agent whose layout a policy of this group reads (the symmetry functions mirror it)."""
        k = len(self.agents)
        self.num_envs = world.num_envs * k if self.mode == "shared" else world.num_envs
        self.num_actions = self.action_dims[0] if self.mode == "shared" else sum(self.action_dims)
        self.max_episode_length = self.env.max_episode_length
        self.device = world.device
        self.cfg = world.cfg
        self.agent_names = [a.name for a in self.agents]

    @property
    def episode_length_buf(self) -> torch.Tensor:
        if self.mode == "shared":
            return torch.cat([a.episode_length_buf for a in self.agents])
        return self.env.episode_length_buf

    @episode_length_buf.setter
    def episode_length_buf(self, value: torch.Tensor) -> None:
        for i, agent in enumerate(self.agents):
            n = self.world.num_envs
            agent.episode_length_buf.copy_(value[i * n:(i + 1) * n] if self.mode == "shared" else value)

    # -- layout -------------------------------------------------------------------------------------------

    def combine_obs(self, per_agent: list[TensorDict]) -> TensorDict:
        flat = [flatten_groups(o) for o in per_agent]
        if self.mode == "normal":
            return flat[0]
        keys = list(flat[0].keys())
        dim = 0 if self.mode == "shared" else -1
        return TensorDict({k: torch.cat([o[k] for o in flat], dim=dim) for k in keys}, batch_size=[self.num_envs])

    def split_actions(self, actions: torch.Tensor) -> dict[str, torch.Tensor]:
        if self.mode == "shared":
            parts = actions.chunk(len(self.agents), dim=0)
        else:
            parts = actions.split(self.action_dims, dim=-1)
        return dict(zip(self.agent_names, parts))

    def combine(self, steps: dict[str, AgentStep]):
        """(obs, rewards, dones, extras) of the group from its agents' steps."""
        mine = [steps[n] for n in self.agent_names]
        obs = self.combine_obs([s.obs for s in mine])
        if len(mine) == 1:
            s = mine[0]
            return obs, s.reward, (s.terminated | s.truncated).long(), {"time_outs": s.truncated,
                                                                        "log": s.extras["log"]}
        log = {f"{n}/{k}": v for n, s in zip(self.agent_names, mine) for k, v in s.extras["log"].items()}
        if self.mode == "shared":
            time_outs = torch.cat([s.truncated for s in mine])
            dones = torch.cat([s.terminated | s.truncated for s in mine]).long()
            return obs, torch.cat([s.reward for s in mine]), dones, {"time_outs": time_outs, "log": log}
        # joint: the group's episode ends when none of its members plays on; a member that died earlier
        # (alive False) counts as finished
        finished = torch.stack([s.terminated | s.truncated | ~s.alive for s in mine]).all(dim=0)
        ending = torch.stack([s.terminated | s.truncated for s in mine]).any(dim=0)
        time_outs = torch.stack([s.truncated for s in mine]).any(dim=0)
        reward = torch.stack([s.reward for s in mine]).sum(dim=0)
        return obs, reward, (finished & ending).long(), {"time_outs": time_outs & finished, "log": log}

    # -- VecEnv ---------------------------------------------------------------------------------------------

    def get_observations(self) -> TensorDict:
        return self.combine_obs([a.obs_buf for a in self.agents])

    def step(self, actions: torch.Tensor):
        if set(self.world.agents) != set(self.agent_names) or len(self.world.schedule.slots) != 1:
            raise RuntimeError(f"group '{self.name}' holds {self.agent_names} of a world with agents "
                               f"{list(self.world.agents)} acting at {self.world.schedule.describe()}: step the "
                               "world with MultiAgentRunner (or MultiAgentEnv.step) instead")
        return self.combine(self.world.step(self.split_actions(actions)))

    def reset(self) -> TensorDict:
        self.world.reset()
        return self.get_observations()
