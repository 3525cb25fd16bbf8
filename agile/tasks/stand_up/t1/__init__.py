from agile.tasks.registration import register_task

# the fallen-state dataset is collected (or loaded from its disk cache) after the env is built, before learning
register_task("StandUp-T1-v0", f"{__name__}.stand_up_env_cfg:T1StandUpEnvCfg",
              f"{__name__}.agents.rsl_rl_ppo_cfg:t1_stand_up_ppo_runner_cfg",
              pre_learn_entry_point="agile.rl_env.fallen_states:pre_learn")
