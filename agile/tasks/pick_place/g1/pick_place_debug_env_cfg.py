"""PickPlace-G1-Debug-v0: pick-and-place watched live in the browser viewer (AGILE's `-Debug` variant).

The task's MDP as PickPlace-G1-v0 defines it (scene, the frozen lower body, observations, rewards, terminations),
one env, every episode from the reference's first frame, so that a policy trained on PickPlace-G1-v0 runs here
unchanged. `agile play --task PickPlace-G1-Debug-v0` plays the shipped PickPlace-G1-v0 policy where agile ships
one (or `--checkpoint`), with the reward plot of every term and the commands beside the 3D view; without a
policy its sliders drive the same actions by hand: the 17 upper-body joint targets (through the task's delta
action) and the 4-D command to the frozen lower body (vx, vy, wz, base height).

AGILE's variant replaces the task's actions by GUI controls on the same scene; here the actions stay the task's,
so that the policy and the hand drive the same MDP. The robot is not on a fixed root: it stands on its frozen
lower body, as in training. The runner is the task's, so that its checkpoints load.
"""

from __future__ import annotations

import dataclasses

from agile.rl_env import ManagerBasedRLEnvCfg
from agile.tasks.pick_place.g1.pick_place_env_cfg import commands_from_first_frame, pick_place_env_cfg


def pick_place_debug_env_cfg() -> ManagerBasedRLEnvCfg:
    """PickPlace-G1-v0 with one env whose episodes start at the reference's first frame."""
    return dataclasses.replace(pick_place_env_cfg(), num_envs=1, commands=commands_from_first_frame())
