"""AGILE `T1StandUpPpoRunnerCfg`: the velocity runner with 100k iterations, entropy 0.0025 and gamma 0.995."""

from agile.rl import PpoRunnerCfg
from agile.tasks.velocity.velocity_ppo_cfg import velocity_ppo_runner_cfg


def t1_stand_up_ppo_runner_cfg() -> PpoRunnerCfg:
    # AGILE also normalises rewards (decay 0.999, eps 1e-2); rsl-rl 5.5 has no reward normalisation, so it is not
    # reproduced here (the reward scale is left to the weights)
    return velocity_ppo_runner_cfg(experiment_name="stand_up_t1", max_iterations=100_000, init_action_std=1.0,
                                   entropy_coef=0.0025, gamma=0.995)
