"""Multi-agent tasks: several robots at their own control rates in one world (`kind: multi_agent`)."""

from agile.tasks.registration import MULTI_AGENT_ENV, register_task
from agile.tasks.velocity import RANDOMISATION_EVENTS

FLAT_NO_RANDOMISATION = ("env.scene.terrain=null", "env.curriculum.terrain_levels=null", "env.scene.ground_friction=1.0",
                         *(f"env.events.{name}=null" for name in RANDOMISATION_EVENTS))

register_task(
    "MultiRate-G1-T1-Velocity-v0", f"{__name__}.multi_rate_velocity_env_cfg:MultiRateG1T1VelocityEnvCfg",
    f"{__name__}.agents.rsl_rl_cfg:multi_rate_velocity_runner_cfg", env_class=MULTI_AGENT_ENV, kind="multi_agent",
    trainer_cfgs={"happo": f"{__name__}.agents.happo_cfg:multi_rate_velocity_happo_cfg"},
    # the single-robot tasks whose MDPs the agents reuse, in the agents' conditions and rates
    # (scripts/benchmark.py compares the world's step with the sum of theirs)
    single_agent_baselines={
        "g1": ("Velocity-G1-History-v0", [*FLAT_NO_RANDOMISATION, "env.actions.random_pos=null"]),
        "t1": ("Velocity-T1-v0", [*FLAT_NO_RANDOMISATION, "env.actions.random_pos=null", "env.decimation=8"]),
    },
)

register_task(
    "Shared-Go1-Velocity-v0", f"{__name__}.shared_go1_velocity_env_cfg:SharedGo1VelocityEnvCfg",
    f"{__name__}.agents.rsl_rl_cfg:shared_go1_velocity_runner_cfg", env_class=MULTI_AGENT_ENV, kind="multi_agent",
    single_agent_baselines={"go1_a": ("Velocity-Flat-Go1-v0", []), "go1_b": ("Velocity-Flat-Go1-v0", [])},
)
