from agile.tasks.registration import register_task

# what a shipped Go1 policy must meet in `agile eval_all` (maxima, as the humanoid velocity tasks'): falls per
# episode, planar velocity error [m/s], yaw-rate error [rad/s]
GO1_VELOCITY_CRITERIA = {"fall_rate": 0.05, "lin_vel_error_mps": 0.25, "ang_vel_error_radps": 0.3}

for task_id, env_cfg in (("Velocity-Go1-v0", "Go1VelocityEnvCfg"), ("Velocity-Flat-Go1-v0", "go1_flat_velocity_env_cfg")):
    register_task(task_id, f"{__name__}.velocity_env_cfg:{env_cfg}",
                  f"{__name__}.agents.rsl_rl_cfg:go1_velocity_ppo_runner_cfg", eval_criteria=dict(GO1_VELOCITY_CRITERIA))
