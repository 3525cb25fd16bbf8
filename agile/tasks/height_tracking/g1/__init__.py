from agile.tasks.registration import register_task

# episodes start from fallen states (AGILE resets with reset_from_fallen_dataset, half of them standing): the
# reset event collects the dataset (or loads it from its disk cache) when the env is built
register_task("HeightTracking-G1-v0", f"{__name__}.height_tracking_env_cfg:G1HeightTrackingEnvCfg",
              f"{__name__}.agents.rsl_rl_cfg:g1_height_tracking_ppo_runner_cfg")
