"""PickPlace-G1-Debug-v0: the pick-and-place scene checked by hand in the browser GUI (AGILE's `-Debug` variant).

One env; the G1 with hands on a fixed root (no lower-body policy needed) at the table; sliders set the right arm's
and hand's joint targets and pose the cube (kinematic here, so it stays where it is put); the reward panel plots
the palm-to-cube distance, the lift reward and the arm's joint-limit penalty live. Run it with
`python scripts/play.py --task PickPlace-G1-Debug-v0`. Not for training: the runner's learning rate is 0.
"""

from __future__ import annotations

import dataclasses
import math

from agile.assets.unitree_g1_with_hands import GRASP_POINT_M, RIGHT_ARM_JOINTS, RIGHT_HAND_JOINTS
from agile.rl_env import ManagerBasedRLEnvCfg
from agile.rl_env.managers import DoneTerm, ObsGroup, ObsTerm, RewTerm, SceneEntityCfg
from agile.sim.scene_cfg import SceneCfg
from agile.tasks.pick_place import mdp
from agile.tasks.pick_place.g1.pick_place_env_cfg import (LIFTED_HEIGHT_M, PALM, pick_place_scene_cfg,
                                                          pick_place_sim_cfg)
from agile.utils.config import configclass

RIGHT_ARM_AND_HAND = [*RIGHT_ARM_JOINTS, *RIGHT_HAND_JOINTS]


# -- scene: the task's, with the robot on a fixed root and the cube posed by its sliders ---------------------------

def debug_scene_cfg() -> SceneCfg:
    scene = pick_place_scene_cfg()
    entities = dict(scene.entities)
    entities["robot"] = dataclasses.replace(entities["robot"], fixed_base=True)
    entities["object"] = dataclasses.replace(entities["object"], body_type="kinematic", mass_kg=None)
    return dataclasses.replace(scene, entities=entities)


# -- actions: a slider per right-arm and right-hand joint (its target [rad]) and the cube's pose -------------------

@configclass
class ActionsCfg:
    right_arm_joint_pos = mdp.JointPositionActionCfg(joint_names=list(RIGHT_ARM_AND_HAND), scale=1.0,
                                                     use_default_offset=False, preserve_order=True)
    object_pose = mdp.ObjectPoseActionCfg(
        asset_name="object", ranges={"x": (-0.4, 0.3), "y": (-0.4, 0.4), "z": (-0.4, 0.5),
                                     "roll": (-math.pi, math.pi), "pitch": (-math.pi, math.pi),
                                     "yaw": (-math.pi, math.pi)})


# -- observations, rewards, terminations: enough to run the env and to watch the terms -----------------------------

@configclass
class PolicyObsCfg(ObsGroup):
    joint_pos = ObsTerm(func=mdp.joint_pos_rel)
    object_to_hand_pos_b = ObsTerm(func=mdp.object_to_hand_pos_b, params={"palm_cfg": PALM, "offset_m": GRASP_POINT_M})


@configclass
class ObservationsCfg:
    policy = PolicyObsCfg()


@configclass
class RewardsCfg:
    is_alive = RewTerm(func=mdp.is_alive, weight=1.0)
    palm_to_object = RewTerm(func=mdp.palm_object_distance_exp, weight=1.0,
                             params={"std_m": 0.1, "palm_cfg": PALM, "offset_m": GRASP_POINT_M})
    lifting_object = RewTerm(func=mdp.object_is_lifted, weight=0.5, params={"minimal_height_m": LIFTED_HEIGHT_M})
    joint_pos_limits = RewTerm(func=mdp.joint_pos_limits, weight=-10.0,
                               params={"asset_cfg": SceneEntityCfg("robot", joint_names=RIGHT_ARM_AND_HAND)})


@configclass
class TerminationsCfg:
    time_out = DoneTerm(func=mdp.time_out, time_out=True)


def pick_place_debug_env_cfg() -> ManagerBasedRLEnvCfg:
    """One env, 200 Hz physics, 50 Hz control, an hour per episode."""
    return ManagerBasedRLEnvCfg(
        num_envs=1, decimation=4, episode_length_s=3600.0,
        scene=debug_scene_cfg(), sim=pick_place_sim_cfg(),
        actions=ActionsCfg(), observations=ObservationsCfg(), rewards=RewardsCfg(), terminations=TerminationsCfg())
