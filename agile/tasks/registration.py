"""One way to register an agile task with gymnasium."""

from __future__ import annotations

import gymnasium as gym

SINGLE_AGENT_ENV = "agile.rl_env.env:ManagerBasedRLEnv"
MULTI_AGENT_ENV = "agile.marl.env:MultiAgentEnv"


def register_task(task_id: str, env_cfg: str, runner_cfg: str, env_class: str = SINGLE_AGENT_ENV, **kwargs) -> None:
    """Register `task_id`: `env_cfg` and `runner_cfg` are "module:attribute" entry points of its env config class
    and its runner config function; `kwargs` go into the registration (e.g. `kind`, `shipped_policy`)."""
    gym.register(id=task_id, entry_point=env_class, disable_env_checker=True, order_enforce=False,
                 kwargs={"task_name": task_id, "env_cfg_entry_point": env_cfg, "rsl_rl_cfg_entry_point": runner_cfg,
                         **kwargs})
