"""Velocity-T1-v0 with FastTD3 (`agile train --task Velocity-T1-v0 --trainer fast_td3`)."""

from agile.rl.fast_td3 import FastTd3Cfg
from agile.tasks.velocity.t1.agents.rsl_rl_cfg import t1_velocity_ppo_runner_cfg
from agile.tasks.velocity.velocity_fast_td3_cfg import velocity_fast_td3_cfg


def t1_velocity_fast_td3_cfg() -> FastTd3Cfg:
    return velocity_fast_td3_cfg(t1_velocity_ppo_runner_cfg(), action_bound=1.0)  # scale 1 rad per unit
