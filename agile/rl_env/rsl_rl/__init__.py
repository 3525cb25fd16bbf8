"""RSL-RL integration: VecEnv wrapper and runner configs."""

from agile.rl_env.rsl_rl.runner_cfg import (DistributionCfg, MlpModelCfg, PpoAlgorithmCfg, PpoRunnerCfg,
                                            to_rsl_rl_dict)
from agile.rl_env.rsl_rl.vecenv_wrapper import RslRlVecEnvWrapper, flatten_groups

__all__ = ["DistributionCfg", "MlpModelCfg", "PpoAlgorithmCfg", "PpoRunnerCfg", "RslRlVecEnvWrapper",
           "flatten_groups", "to_rsl_rl_dict"]
