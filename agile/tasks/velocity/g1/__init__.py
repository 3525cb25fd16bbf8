from agile.tasks.registration import register_task
from agile.tasks.velocity import HUMANOID_SHIP_BAR

register_task("Velocity-G1-History-v0", f"{__name__}.velocity_history_env_cfg:G1VelocityHistoryEnvCfg",
              f"{__name__}.agents.rsl_rl_cfg:g1_velocity_history_ppo_runner_cfg",
              ship_bar=dict(HUMANOID_SHIP_BAR))
register_task("Velocity-G1-Teacher-v0", f"{__name__}.velocity_teacher_env_cfg:G1VelocityTeacherEnvCfg",
              f"{__name__}.agents.rsl_rl_cfg:g1_velocity_teacher_ppo_runner_cfg")
