"""The RL glue on rsl-rl: runner configs, the VecEnv wrapper, the runner, its logger, checkpoints, algorithms."""

from agile.rl.configs import (DistillationAlgorithmCfg, DistillationRunnerCfg,
                              DistributionCfg, EntropyAnnealingCfg, L2C2Cfg, MlpModelCfg, PpoAlgorithmCfg,
                              PpoRunnerCfg, RewardNormalizationCfg, RnnModelCfg, RunnerCfg,
                              is_distillation, make_recurrent,
                              policy_model_cfg, policy_obs_set, policy_state_key, to_rsl_rl_dict)
from agile.rl.vecenv_wrapper import RslRlVecEnvWrapper, flatten_groups

__all__ = ["DistillationAlgorithmCfg", "DistillationRunnerCfg", "DistributionCfg",
           "EntropyAnnealingCfg", "L2C2Cfg", "MlpModelCfg", "PpoAlgorithmCfg", "PpoRunnerCfg", "RewardNormalizationCfg",
           "RnnModelCfg", "RslRlVecEnvWrapper",
           "RunnerCfg", "flatten_groups", "is_distillation", "make_recurrent", "policy_model_cfg", "policy_obs_set",
           "policy_state_key", "to_rsl_rl_dict"]
