"""AGILE V1.3 HeightTracking-G1 runner: the velocity runner with gamma 0.995 and the stand-up runner's entropy."""

from agile.rl_env.rsl_rl import PpoRunnerCfg
from agile.tasks.velocity.velocity_ppo_cfg import velocity_ppo_runner_cfg


def g1_height_tracking_ppo_runner_cfg() -> PpoRunnerCfg:
    # AGILE also uses L2C2 smoothness regularisation (actor 1.0, critic 0.1) and reward normalisation (return scale
    # decay 0.999); rsl-rl 5.5 and PpoRunnerCfg have neither, so they are not reproduced. The reference lists no
    # mirror augmentation for this task, and the mirror function does not know the height command: none here.
    return velocity_ppo_runner_cfg(experiment_name="height_tracking_g1", max_iterations=100_000, init_action_std=1.0,
                                   entropy_coef=0.0025, gamma=0.995, symmetry_cfg=None)
