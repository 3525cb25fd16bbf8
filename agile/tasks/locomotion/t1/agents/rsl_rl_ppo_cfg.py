"""AGILE `T1VelocityPpoRunnerCfg`."""

from agile.rl_env.rsl_rl import PpoRunnerCfg
from agile.tasks.locomotion.velocity_ppo_cfg import velocity_ppo_runner_cfg


def t1_velocity_ppo_runner_cfg() -> PpoRunnerCfg:
    return velocity_ppo_runner_cfg(experiment_name="velocity_t1", max_iterations=100_000)
