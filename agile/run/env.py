"""A task's env as training builds it (`gym.make` builds the same: the stand-up tasks' fallen-state dataset is made
by their reset event when the env is built)."""

from __future__ import annotations


def build_env(task: str, env_cfg, device: str, use_cache: bool = True):
    """The task's env (a ManagerBasedRLEnv, or a MultiAgentEnv for a multi-agent config). `use_cache=False`: a task
    that builds a dataset at its start (its task spec's `startup_dataset`, e.g. stand-up's fallen states) collects it
    anew instead of loading its disk cache (the new one replaces it); other tasks have none to collect. Raises
    ConfigError or ValueError for a config the env cannot be built from."""
    import agile.tasks
    from agile.marl import MultiAgentEnv, MultiAgentEnvCfg
    from agile.rl_env import ManagerBasedRLEnv
    from agile.utils.config import load_entry_point

    if isinstance(env_cfg, MultiAgentEnvCfg):
        return MultiAgentEnv(env_cfg, task_name=task, device=device)
    startup_dataset = None if use_cache else agile.tasks.task_spec(task).startup_dataset
    if startup_dataset is not None:
        load_entry_point(startup_dataset)(env_cfg)
    return ManagerBasedRLEnv(env_cfg, task_name=task, device=device)

