"""AGILE `G1VelocityPpoRunnerCfg` (as T1's, 50k iterations), and its G1 velocity teacher's."""

from agile.rl import PpoRunnerCfg
from agile.tasks.velocity.velocity_ppo_cfg import velocity_ppo_runner_cfg


def g1_velocity_history_ppo_runner_cfg() -> PpoRunnerCfg:
    return velocity_ppo_runner_cfg(experiment_name="velocity_g1_history", max_iterations=50_000)


def g1_velocity_teacher_ppo_runner_cfg() -> PpoRunnerCfg:
    """Velocity-G1-Teacher-v0: the G1 velocity runner with entropy 0.01 (the env clips the raw actions to ±4)."""
    return velocity_ppo_runner_cfg(experiment_name="velocity_g1_teacher", max_iterations=50_000, entropy_coef=0.01)
