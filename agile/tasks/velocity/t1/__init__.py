from agile.tasks.registration import register_task
from agile.tasks.velocity import HUMANOID_SHIP_BAR

register_task("Velocity-T1-v0", f"{__name__}.velocity_env_cfg:T1VelocityEnvCfg",
              f"{__name__}.agents.rsl_rl_cfg:t1_velocity_ppo_runner_cfg", ship_bar=dict(HUMANOID_SHIP_BAR))
