"""Velocity-G1-History-v0 with FastTD3 (`agile train --task Velocity-G1-History-v0 --trainer fast_td3`)."""

from agile.rl.fast_td3 import FastTd3Cfg
from agile.tasks.velocity.g1.agents.rsl_rl_cfg import g1_velocity_history_ppo_runner_cfg
from agile.tasks.velocity.velocity_fast_td3_cfg import velocity_fast_td3_cfg


def g1_velocity_history_fast_td3_cfg() -> FastTd3Cfg:
    return velocity_fast_td3_cfg(g1_velocity_history_ppo_runner_cfg(), action_bound=2.0)  # scale 0.5 rad per unit
