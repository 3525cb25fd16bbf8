"""Debug-G1-v0, Debug-T1-v0, Debug-G1-Object-v0: a robot model, its symmetry and reward terms checked by hand.

AGILE's debug tasks (`debug_env_cfg.py`, `object_debug_env_cfg.py`), on the scene of many entities: two
copies of the robot hang on fixed roots side by side. In the browser GUI (`scripts/play.py --task
Debug-G1-v0`) a slider per joint sets the first robot's joint targets; the second receives them mirrored by
the joint map that symmetry augmentation trains with, so a wrong pairing or sign is visible at a glance. The
object variant adds a kinematic cube posed by sliders and reward terms to watch while moving the hand to it.
Not for training: the runner's learning rate is 0.
"""

from __future__ import annotations

import dataclasses
import math

from agile.assets.booster_t1 import t1_robot_cfg
from agile.assets.unitree_g1 import g1_robot_cfg
from agile.rl_env import ManagerBasedRLEnvCfg, mdp
from agile.rl_env.managers import DoneTerm, ObsGroup, ObsTerm, RewTerm, SceneEntityCfg
from agile.sim.scene_cfg import ArticulationCfg, BoxShapeCfg, RigidObjectCfg, SceneCfg
from agile.sim.sim_cfg import SimCfg, SolverCfg
from agile.utils.config import configclass

ROBOT_SPACING_M = 1.25
"""Between the two robots (AGILE's env spacing: its two robots were two envs)."""
HANG_HEIGHT_M = 0.2
"""How far above its standing height each robot hangs, so that its feet swing free."""
CUBE_EDGE_M = 0.06
"""AGILE's DexCube."""
CUBE_POSITION_M = (0.35, -ROBOT_SPACING_M / 2 - 0.2, 0.9)
"""In front of the first robot's right hand, in the env frame."""


# -- scene: the robot driven by the sliders at -y, its mirror image at +y (robots face +x) -------------

def hanging(robot: ArticulationCfg, y_m: float) -> ArticulationCfg:
    x_m, _, z_m = robot.init_pos_m
    return dataclasses.replace(robot, fixed_base=True, init_pos_m=(x_m, y_m, z_m + HANG_HEIGHT_M))


def debug_scene_cfg(robot: ArticulationCfg, with_cube: bool) -> SceneCfg:
    entities = {"robot": hanging(robot, -ROBOT_SPACING_M / 2), "mirrored_robot": hanging(robot, ROBOT_SPACING_M / 2)}
    if with_cube:
        entities["object"] = RigidObjectCfg(shape=BoxShapeCfg(size_m=(CUBE_EDGE_M,) * 3), body_type="kinematic",
                                            init_pos_m=CUBE_POSITION_M)
    return SceneCfg(entities=entities, env_spacing_m=3.0)


# -- actions: sliders (or any policy) set the first robot's targets; the second mirrors them ----------------

@configclass
class ActionsCfg:
    # the action is the joint target itself [rad] (scale 1, no offset): a slider reads as the joint's angle
    joint_pos = mdp.JointPositionActionCfg(asset_name="robot", joint_names=[".*"], scale=1.0, use_default_offset=False)
    mirrored_joint_pos = mdp.MirroredJointPositionActionCfg(asset_name="mirrored_robot", source_action_name="joint_pos")


@configclass
class ObjectActionsCfg(ActionsCfg):
    object_pose = mdp.ObjectPoseActionCfg(
        asset_name="object", ranges={"x": (-0.5, 0.5), "y": (-0.5, 0.5), "z": (-0.5, 0.5), "roll": (-math.pi, math.pi),
                                     "pitch": (-math.pi, math.pi), "yaw": (-math.pi, math.pi)})


# -- observations, rewards, terminations: enough for the scripts to run the env -------------------------

@configclass
class PolicyObsCfg(ObsGroup):
    projected_gravity = ObsTerm(func=mdp.projected_gravity)
    joint_pos = ObsTerm(func=mdp.joint_pos_rel)


@configclass
class ObservationsCfg:
    policy = PolicyObsCfg()


@configclass
class RewardsCfg:
    is_alive = RewTerm(func=mdp.is_alive, weight=1.0)


@configclass
class ObjectRewardsCfg(RewardsCfg):
    # terms to watch in the live plot while moving the right hand to the cube and the cube up
    right_hand_to_object = RewTerm(func=mdp.object_body_distance_exp, weight=1.0,
                                   params={"std_m": 0.1,
                                           "body_cfg": SceneEntityCfg("robot", body_names="right_wrist_yaw_link")})
    lifting_object = RewTerm(func=mdp.object_is_lifted, weight=0.5,
                             params={"minimal_height_m": CUBE_POSITION_M[2] + 0.05})
    joint_pos_limits = RewTerm(func=mdp.joint_pos_limits, weight=-1.0)


@configclass
class TerminationsCfg:
    time_out = DoneTerm(func=mdp.time_out, time_out=True)


def debug_env_cfg(robot: ArticulationCfg, with_cube: bool = False) -> ManagerBasedRLEnvCfg:
    """One env (AGILE: two, as its second robot was a second env), 200 Hz physics, 50 Hz control, an hour
    per episode."""
    return ManagerBasedRLEnvCfg(
        num_envs=1, decimation=4, episode_length_s=3600.0,
        scene=debug_scene_cfg(robot, with_cube),
        sim=SimCfg(physics_dt_s=0.005, solver=SolverCfg(njmax=200, nconmax=40)),
        actions=ObjectActionsCfg() if with_cube else ActionsCfg(),
        observations=ObservationsCfg(),
        rewards=ObjectRewardsCfg() if with_cube else RewardsCfg(),
        terminations=TerminationsCfg())


def g1_debug_env_cfg() -> ManagerBasedRLEnvCfg:
    return debug_env_cfg(g1_robot_cfg())


def t1_debug_env_cfg() -> ManagerBasedRLEnvCfg:
    return debug_env_cfg(t1_robot_cfg())


def g1_object_debug_env_cfg() -> ManagerBasedRLEnvCfg:
    return debug_env_cfg(g1_robot_cfg(), with_cube=True)
