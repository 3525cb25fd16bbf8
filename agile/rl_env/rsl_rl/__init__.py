"""RSL-RL integration: VecEnv wrapper and runner configs."""

from agile.rl_env.rsl_rl.runner_cfg import (DistributionCfg, MlpModelCfg, PpoAlgorithmCfg, PpoRunnerCfg, RnnModelCfg,
                                            make_recurrent, to_rsl_rl_dict)
from agile.rl_env.rsl_rl.vecenv_wrapper import RslRlVecEnvWrapper, flatten_groups

__all__ = ["DistributionCfg", "MlpModelCfg", "PpoAlgorithmCfg", "PpoRunnerCfg", "RnnModelCfg", "RslRlVecEnvWrapper",
           "flatten_groups", "make_recurrent", "to_rsl_rl_dict"]
