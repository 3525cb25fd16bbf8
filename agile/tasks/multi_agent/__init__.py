"""Multi-agent tasks: several robots at their own control rates in one world (`kind: multi_agent`)."""

import gymnasium as gym

from agile.tasks.locomotion.velocity_common import RANDOMISATION_EVENTS

FLAT_NO_RANDOMISATION = ("env.scene.terrain=null", "env.curriculum.terrain_levels=null", "env.scene.ground_friction=1.0",
                         *(f"env.events.{name}=null" for name in RANDOMISATION_EVENTS))

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
        # the single-robot tasks whose MDPs the agents reuse, in the agents' conditions and rates
        # (scripts/benchmark.py compares the world's step with the sum of theirs)
        "single_agent_baselines": {
            "g1": ("Velocity-G1-History-v0", [*FLAT_NO_RANDOMISATION, "env.actions.random_pos=null"]),
            "t1": ("Velocity-T1-v0", [*FLAT_NO_RANDOMISATION, "env.actions.random_pos=null", "env.decimation=8"]),
        },
    },
)
