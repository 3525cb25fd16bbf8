from agile.tasks.registration import register_task

# one task, two IDs: AGILE v1.3 renamed Tracking-Flat-G1-v0 to MotionTracking-G1-v0
for task_id in ("MotionTracking-G1-v0", "Tracking-Flat-G1-v0"):
    register_task(task_id, f"{__name__}.motion_tracking_env_cfg:G1MotionTrackingEnvCfg",
                  f"{__name__}.agents.rsl_rl_ppo_cfg:g1_motion_tracking_ppo_runner_cfg")
