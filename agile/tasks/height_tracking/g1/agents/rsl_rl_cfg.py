"""AGILE V1.3 HeightTracking-G1 runner: the velocity runner with gamma 0.995, the stand-up runner's entropy, AGILE's
reward normalisation and L2C2."""

from agile.rl_env.rsl_rl import L2C2Cfg, PpoRunnerCfg, RewardNormalizationCfg
from agile.tasks.velocity.velocity_ppo_cfg import velocity_ppo_runner_cfg


def g1_height_tracking_ppo_runner_cfg() -> PpoRunnerCfg:
    # The reference lists no mirror augmentation for this task, and the mirror function does not know the height
    # command: none here.
    cfg = velocity_ppo_runner_cfg(experiment_name="height_tracking_g1", max_iterations=100_000, init_action_std=1.0,
                                  entropy_coef=0.0025, gamma=0.995, symmetry_cfg=None)
    # AGILE's reward normalisation (decay 0.999, epsilon 1e-2, return-scale correction 0.999) and L2C2 (actor 1.0,
    # critic 0.1), registered from 19,000 on, where the run trained without them drifted between postures
    # (docs/stand_up.md). L2C2's term goes into SyncFreePPO's mini-batch step (rsl-rl's PPO update, the same math).
    # A resume from a checkpoint without the normaliser's statistics first re-trains the critic on the new scale for
    # `critic_warmup_iterations`, the actor held.
    cfg.algorithm.class_name = "agile.rl_env.rsl_rl.sync_free_ppo:SyncFreePPO"
    cfg.algorithm.reward_normalization = RewardNormalizationCfg()
    cfg.algorithm.l2c2 = L2C2Cfg()
    cfg.critic_warmup_iterations = 50
    return cfg
