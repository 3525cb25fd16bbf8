"""RSL-RL VecEnv view of a ManagerBasedRLEnv."""

from __future__ import annotations

import torch
from rsl_rl.env import VecEnv
from tensordict import TensorDict

from agile.rl_env.env import ManagerBasedRLEnv


def flatten_groups(obs: TensorDict) -> TensorDict:
    """RSL-RL's MLPs take one (N, D) tensor per group: concatenate groups kept as per-term TensorDicts. A group
    with an image term (more than one value axis per env, e.g. a recording's camera) is left out: no network here
    reads images, and rsl-rl would keep every group of every step in its rollout storage."""
    out = {}
    for key in obs.keys():
        value = obs[key]
        if isinstance(value, TensorDict):
            if any(value[k].dim() > 2 for k in value.keys()):
                continue
            value = torch.cat([value[k] for k in value.keys()], dim=-1)
        out[key] = value
    return TensorDict(out, batch_size=obs.batch_size)


class RslRlVecEnvWrapper(VecEnv):
    """The env as rsl-rl's VecEnv: observation groups flattened per group. Actions pass unchanged: the env clamps
    them (`clip_actions` of its config, Isaac Lab's agent setting), so that training steps the same env as
    evaluation and play."""

    def __init__(self, env: ManagerBasedRLEnv):
        self.env = env.unwrapped if hasattr(env, "unwrapped") else env
        self.num_envs = self.env.num_envs
        self.num_actions = self.env.action_manager.total_action_dim
        self.max_episode_length = self.env.max_episode_length
        self.device = self.env.device
        self.cfg = self.env.cfg

    @property
    def episode_length_buf(self) -> torch.Tensor:
        return self.env.episode_length_buf

    @episode_length_buf.setter
    def episode_length_buf(self, value: torch.Tensor) -> None:
        self.env.episode_length_buf.copy_(value)

    def get_observations(self) -> TensorDict:
        return flatten_groups(self.env.obs_buf)

    def reset(self) -> TensorDict:
        obs, _ = self.env.reset()
        return flatten_groups(obs)

    def step(self, actions: torch.Tensor):
        obs, reward, terminated, truncated, extras = self.env.step(actions)
        dones = (terminated | truncated).to(torch.long)
        return flatten_groups(obs), reward, dones, {"time_outs": truncated, "log": extras["log"]}

    def close(self) -> None:
        self.env.close()
