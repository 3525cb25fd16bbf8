"""rsl-rl PPO algorithms on a fake env (no simulation), for the algorithm extensions' CPU tests."""

from __future__ import annotations

import torch
from tensordict import TensorDict

from agile.rl.extensions import compose_algorithm


class FakeVecEnv:
    """What rsl-rl's algorithm construction reads of an env."""

    def __init__(self, num_envs: int, num_actions: int, max_episode_length: int = 100):
        self.num_envs, self.num_actions, self.max_episode_length = num_envs, num_actions, max_episode_length


def ppo_algorithm(class_name: str, num_envs: int, num_steps: int, obs_dim: int, num_actions: int,
                  device: str = "cpu", **settings):
    """The PPO class `class_name` with the algorithm `settings` (extensions composed as `to_rsl_rl_dict` does), tiny
    MLPs, built by rsl-rl's own construction on `device`."""
    algorithm = {"class_name": class_name, **settings}
    compose_algorithm(algorithm)
    cfg = {"obs_groups": {"actor": ["policy"], "critic": ["policy"]}, "num_steps_per_env": num_steps,
           "multi_gpu": None,
           "actor": {"class_name": "MLPModel", "hidden_dims": [16], "activation": "elu",
                     "distribution_cfg": {"class_name": "GaussianDistribution", "init_std": 1.0}},
           "critic": {"class_name": "MLPModel", "hidden_dims": [16], "activation": "elu"},
           "algorithm": algorithm}
    obs = TensorDict({"policy": torch.zeros(num_envs, obs_dim, device=device)}, batch_size=[num_envs], device=device)
    torch.manual_seed(0)
    from rsl_rl.utils import resolve_callable

    return resolve_callable(algorithm["class_name"]).construct_algorithm(obs, FakeVecEnv(num_envs, num_actions), cfg,
                                                                         device)
