import gymnasium as gym

gym.register(
    id="Velocity-T1-v0",
    entry_point="agile.rl_env.env:ManagerBasedRLEnv",
    disable_env_checker=True,
    order_enforce=False,
    kwargs={
        "task_name": "Velocity-T1-v0",
        "env_cfg_entry_point": f"{__name__}.velocity_env_cfg:T1VelocityEnvCfg",
        "rsl_rl_cfg_entry_point": f"{__name__}.agents.rsl_rl_ppo_cfg:t1_velocity_ppo_runner_cfg",
    },
)
