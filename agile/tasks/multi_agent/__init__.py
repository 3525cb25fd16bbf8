"""Multi-agent tasks: several robots at their own control rates in one world (`kind: multi_agent`)."""

import gymnasium as gym

gym.register(
    id="MultiRate-G1-T1-Velocity-v0",
    entry_point="agile.marl.env:MultiAgentEnv",
    disable_env_checker=True,
    order_enforce=False,
    kwargs={
        "task_name": "MultiRate-G1-T1-Velocity-v0",
        "kind": "multi_agent",
        "env_cfg_entry_point": f"{__name__}.multi_rate_velocity_env_cfg:MultiRateG1T1VelocityEnvCfg",
        "rsl_rl_cfg_entry_point": f"{__name__}.agents.rsl_rl_ppo_cfg:multi_rate_velocity_runner_cfg",
    },
)
