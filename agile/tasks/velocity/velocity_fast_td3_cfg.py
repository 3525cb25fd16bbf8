"""FastTD3 settings shared by the velocity tasks (`agile train --trainer fast_td3`): FastTD3's IsaacLab velocity
settings (4,096 envs, 3-step returns, a replay of 1,024 steps per env, C51 critics over ±10 with 251 atoms), the
task's PPO actor as the policy."""

from agile.rl import PpoRunnerCfg
from agile.rl.fast_td3 import FastTd3Cfg


def velocity_fast_td3_cfg(ppo_runner_cfg: PpoRunnerCfg, action_bound: float) -> FastTd3Cfg:
    """`action_bound`: the raw actions explored, in the task's action units (±1 rad of the default pose)."""
    return FastTd3Cfg(policy=ppo_runner_cfg, experiment_name=f"{ppo_runner_cfg.experiment_name}_fast_td3",
                      seed=ppo_runner_cfg.seed, max_iterations=ppo_runner_cfg.max_iterations,
                      action_bound=action_bound, n_steps=3, buffer_steps_per_env=1024, num_atoms=251)
