"""RSL-RL VecEnv view of a ManagerBasedRLEnv."""

from __future__ import annotations

import torch
from rsl_rl.env import VecEnv
from tensordict import TensorDict

from agile.rl_env.env import ManagerBasedRLEnv


def flatten_groups(obs: TensorDict) -> TensorDict:
    """RSL-RL's MLPs take one (N, D) tensor per group: concatenate groups kept as per-term TensorDicts."""
    out = {}
    for key in obs.keys():
        value = obs[key]
        if isinstance(value, TensorDict):
            value = torch.cat([value[k] for k in value.keys()], dim=-1)
        out[key] = value
    return TensorDict(out, batch_size=obs.batch_size)


class RslRlVecEnvWrapper(VecEnv):
    """The env as rsl-rl's VecEnv: observation groups flattened per group, and the policy's actions clamped to
    ±`clip_actions` when given (Isaac Lab's agent setting). The env itself clamps every action to the range the
    task declares (`ActionManager.action_bounds`), for training and evaluation alike."""

    def __init__(self, env: ManagerBasedRLEnv, clip_actions: float | None = None):
        self.env = env.unwrapped if hasattr(env, "unwrapped") else env
        self.clip_actions = clip_actions
        self.action_low = self.action_high = None
        if clip_actions is not None:
            self.action_low, self.action_high = -clip_actions, clip_actions
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
        # NaN and infinite entries pass unclamped (here and in the env): the env replaces them, ends those envs and counts them
        # (`Episode_Termination/invalid_action`); a clamp would silently turn an infinity into a valid action
        if self.clip_actions is not None:
            actions = torch.where(torch.isfinite(actions), torch.clamp(actions, self.action_low, self.action_high),
                                  actions)
        obs, reward, terminated, truncated, extras = self.env.step(actions)
        dones = (terminated | truncated).to(torch.long)
        return flatten_groups(obs), reward, dones, {"time_outs": truncated, "log": extras["log"]}

    def close(self) -> None:
        self.env.close()
