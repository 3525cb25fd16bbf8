"""AGILE `G1VelocityPpoRunnerCfg` (as T1's, 50k iterations), and its G1 velocity teacher's."""

from agile.rl_env.rsl_rl import PpoRunnerCfg
from agile.tasks.locomotion.velocity_ppo_cfg import velocity_ppo_runner_cfg


def g1_velocity_history_ppo_runner_cfg() -> PpoRunnerCfg:
    return velocity_ppo_runner_cfg(experiment_name="velocity_g1_history", max_iterations=50_000)


TEACHER_ACTION_CLIP = 4.0
"""AGILE's G1 velocity teacher clips the raw leg actions to ±4 (scale 0.25: targets within ±1 rad of default)."""


def g1_velocity_teacher_ppo_runner_cfg() -> PpoRunnerCfg:
    """Velocity-G1-Teacher-v0: the G1 velocity runner with entropy 0.01 and the raw actions clipped to ±4."""
    cfg = velocity_ppo_runner_cfg(experiment_name="velocity_g1_teacher", max_iterations=50_000)
    cfg.algorithm.entropy_coef = 0.01
    cfg.clip_actions = TEACHER_ACTION_CLIP
    return cfg
