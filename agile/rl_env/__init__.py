"""Manager-based RL environment."""

from agile.rl_env.env import ManagerBasedRLEnv, ManagerBasedRLEnvCfg

__all__ = ["ManagerBasedRLEnv", "ManagerBasedRLEnvCfg"]
