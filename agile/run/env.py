"""A task's env as training builds it (`gym.make` builds the same: the stand-up tasks' fallen-state dataset is made
by their reset event when the env is built)."""

from __future__ import annotations

import dataclasses


def build_env(task: str, env_cfg, device: str, use_cache: bool = True):
    """The task's env (a ManagerBasedRLEnv, or a MultiAgentEnv for a multi-agent config). `use_cache=False`: a
    fallen-state dataset is collected anew instead of loaded from its disk cache (the new one replaces it). Raises
    ConfigError or ValueError for a config the env cannot be built from."""
    from agile.marl import MultiAgentEnv, MultiAgentEnvCfg
    from agile.rl_env import ManagerBasedRLEnv

    if isinstance(env_cfg, MultiAgentEnvCfg):
        return MultiAgentEnv(env_cfg, task_name=task, device=device)
    if not use_cache:
        collect_fallen_states_anew(env_cfg)
    return ManagerBasedRLEnv(env_cfg, task_name=task, device=device)


def collect_fallen_states_anew(env_cfg) -> None:
    """Every `reset_from_fallen_dataset` event of `env_cfg` collects its dataset instead of loading the cache."""
    from agile.tasks.stand_up.fallen_states import FallenStateDatasetCfg, reset_from_fallen_dataset
    from agile.rl_env.managers import EventTerm

    for term in vars(env_cfg.events or object()).values():
        if isinstance(term, EventTerm) and term.func is reset_from_fallen_dataset:
            dataset = term.params.get("dataset") or FallenStateDatasetCfg()
            term.params["dataset"] = dataclasses.replace(dataset, use_cache=False)
