from agile.tasks.registration import register_task

# one task, two IDs: AGILE v1.3 renamed Tracking-Flat-G1-v0 to MotionTracking-G1-v0
for task_id in ("MotionTracking-G1-v0", "Tracking-Flat-G1-v0"):
    register_task(task_id, f"{__name__}.motion_tracking_env_cfg:G1MotionTrackingEnvCfg",
                  f"{__name__}.agents.rsl_rl_cfg:g1_motion_tracking_ppo_runner_cfg",
                  shipped_policy="MotionTracking-G1-v0",
                  # a tracking policy learns one motion: one shipped policy per shipped motion
                  shipped_policy_per="commands.motion.motion_file",
                  eval_criteria={"motion/body_pos_error_m": 0.05, "motion/joint_pos_error_rad": 0.1},
                  eval_settings={"num_envs": 1024, "episode_length_s": 8.0,
                                 "overrides": ["env.commands.motion.start_frame=0"]})
