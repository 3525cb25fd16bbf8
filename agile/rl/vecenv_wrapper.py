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


def defer_nan_check(train_cfg: dict) -> int:
    """Move the NaN check out of rsl-rl's rollout loop into the wrapper: rsl-rl's (`check_for_nan`) checks every
    step's observations and rewards with a host synchronisation each; the wrapper's flags NaN on the device every step
    and reports once per rollout, before the update reads it. Turns rsl-rl's off in `train_cfg` and returns the
    wrapper's `nan_check_every_steps` (the rollout's length; 0 where the config turned the check off)."""
    checks = bool(train_cfg.get("check_for_nan", True))
    train_cfg["check_for_nan"] = False
    return int(train_cfg["num_steps_per_env"]) if checks else 0


class RslRlVecEnvWrapper(VecEnv):
    """The env as rsl-rl's VecEnv: observation groups flattened per group. Actions pass unchanged: the env clamps
    them (`clip_actions` of its config, Isaac Lab's agent setting), so that training steps the same env as
    evaluation and play.

    `nan_check_every_steps` > 0: every step's observations and rewards are checked for NaN on the device, and a NaN
    seen is raised (naming the group) at every that many steps, one host synchronisation each (`defer_nan_check`)."""

    def __init__(self, env: ManagerBasedRLEnv, nan_check_every_steps: int = 0):
        self.env = env.unwrapped if hasattr(env, "unwrapped") else env
        self.num_envs = self.env.num_envs
        self.num_actions = self.env.action_manager.total_action_dim
        self.max_episode_length = self.env.max_episode_length
        self.device = self.env.device
        self.cfg = self.env.cfg
        if nan_check_every_steps < 0:
            raise ValueError(f"nan_check_every_steps must be >= 0 (0: no check), got {nan_check_every_steps}")
        self.nan_check_every_steps = nan_check_every_steps
        self.nan_seen: torch.Tensor | None = None
        """(groups + 1,) bool on the device: NaN seen in each observation group, then the rewards, since the last
        report."""
        self.nan_sources: list[str] = []
        self.steps_unchecked = 0

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
        obs = flatten_groups(obs)
        if self.nan_check_every_steps:
            self.flag_nan(obs, reward)
        return obs, reward, dones, {"time_outs": truncated, "log": extras["log"]}

    def flag_nan(self, obs: TensorDict, reward: torch.Tensor) -> None:
        values = [obs[key] for key in obs.keys()] + [reward]
        seen = torch.stack([torch.isnan(value).any() for value in values])
        if self.nan_seen is None or len(self.nan_seen) != len(seen):
            self.nan_seen = torch.zeros_like(seen)
            self.nan_sources = [f"the observation group '{key}'" for key in obs.keys()] + ["the rewards"]
        self.nan_seen |= seen
        self.steps_unchecked += 1
        if self.steps_unchecked >= self.nan_check_every_steps:
            self.report_nan()

    def report_nan(self) -> None:
        """Raise if NaN was seen since the last report (one host synchronisation)."""
        steps, self.steps_unchecked = self.steps_unchecked, 0
        if self.nan_seen is None:
            return
        seen = self.nan_seen.tolist()
        self.nan_seen.zero_()
        sources = [source for source, nan in zip(self.nan_sources, seen) if nan]
        if sources:
            raise ValueError(f"{' and '.join(sources)} returned by the environment contained NaN values within the "
                             f"last {steps} steps. This usually indicates a bug in the environment's step() or "
                             f"reset() function.")

    def close(self) -> None:
        self.env.close()
