import gymnasium as gym

gym.register(
    id="Velocity-G1-History-v0",
    entry_point="agile.rl_env.env:ManagerBasedRLEnv",
    disable_env_checker=True,
    order_enforce=False,
    kwargs={
        "task_name": "Velocity-G1-History-v0",
        "env_cfg_entry_point": f"{__name__}.velocity_history_env_cfg:G1VelocityHistoryEnvCfg",
        "rsl_rl_cfg_entry_point": f"{__name__}.agents.rsl_rl_ppo_cfg:g1_velocity_history_ppo_runner_cfg",
    },
)

gym.register(
    id="Velocity-G1-Teacher-v0",
    entry_point="agile.rl_env.env:ManagerBasedRLEnv",
    disable_env_checker=True,
    order_enforce=False,
    kwargs={
        "task_name": "Velocity-G1-Teacher-v0",
        "env_cfg_entry_point": f"{__name__}.velocity_teacher_env_cfg:G1VelocityTeacherEnvCfg",
        "rsl_rl_cfg_entry_point": f"{__name__}.agents.rsl_rl_ppo_cfg:g1_velocity_teacher_ppo_runner_cfg",
    },
)
