from agile.tasks.registration import register_task

# episodes start from fallen states (AGILE resets with reset_from_fallen_dataset, half of them standing): the
# reset event collects the dataset (or loads it from its disk cache) when the env is built. Evaluated as issue 43
# asks (at least 256 envs; 1,024 here, where a band's standard error is ~0.002-0.004 m, not ~0.01 m): 15 s episodes
# from fallen and standing starts without the lift (training-only), settled height error < 0.05 m overall and in
# every commanded-height band eval.py bins it by, falls < 5% (the catalogue's default for tasks without a velocity
# command)
register_task("HeightTracking-G1-v0", f"{__name__}.height_tracking_env_cfg:G1HeightTrackingEnvCfg",
              f"{__name__}.agents.rsl_rl_cfg:g1_height_tracking_ppo_runner_cfg",
              eval_criteria={"height/height_error_m": 0.05, "height_error_m_by_height_m": 0.05},
              eval_settings={"num_envs": 1024, "episode_length_s": 15.0},
              startup_dataset="agile.tasks.stand_up.fallen_states.startup:collect_fallen_states_anew")
