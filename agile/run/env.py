"""A task's env as training builds it: the env, then the task's pre-learn step where its registration names one."""

from __future__ import annotations


def build_env(task: str, env_cfg, device: str, use_cache: bool = True):
    """The task's env (a ManagerBasedRLEnv, or a MultiAgentEnv for a multi-agent config) after the task's pre-learn
    step (`pre_learn_entry_point`, e.g. the stand-up tasks' fallen-state dataset; `use_cache=False`: collect again).
    Raises ConfigError or ValueError for a config the env cannot be built from."""
    import agile.tasks
    from agile.marl import MultiAgentEnv, MultiAgentEnvCfg
    from agile.rl_env import ManagerBasedRLEnv
    from agile.utils.config import load_entry_point

    env_class = MultiAgentEnv if isinstance(env_cfg, MultiAgentEnvCfg) else ManagerBasedRLEnv
    env = env_class(env_cfg, task_name=task, device=device)
    pre_learn = agile.tasks.task_spec(task).kwargs.get("pre_learn_entry_point")
    if pre_learn is not None:
        load_entry_point(pre_learn)(env, task, use_cache=use_cache)
    return env
