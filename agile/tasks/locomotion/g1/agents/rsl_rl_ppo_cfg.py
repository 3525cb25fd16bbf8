"""AGILE `G1VelocityPpoRunnerCfg` (as T1's, 50k iterations)."""

from agile.rl_env.rsl_rl import PpoRunnerCfg
from agile.tasks.locomotion.velocity_ppo_cfg import velocity_ppo_runner_cfg


def g1_velocity_history_ppo_runner_cfg() -> PpoRunnerCfg:
    return velocity_ppo_runner_cfg(experiment_name="velocity_g1_history", max_iterations=50_000)
