"""Velocity-Go1-v0: Unitree Go1 walks at commanded planar velocities on rough terrain, controlling its 12 joints;
Velocity-Flat-Go1-v0: the same on flat ground.

The velocity family's blocks with a quadruped's bodies: Isaac Lab's rough terrain (stairs, boxes, slopes, noise) with
the terrain curriculum, the velocity tasks' domain randomisation, pushes and resets; rewards after Isaac Lab's and
mjlab's Go1 velocity tasks (tracking, base motion, joint effort, a foot air-time bonus, thigh and trunk contacts).
"""

from __future__ import annotations

import dataclasses
import math

from agile.assets.unitree_go1 import (ACTION_SCALE, BASE_BODY, FOOT_BODIES, LEG_JOINTS, THIGH_BODIES,
                                      go1_robot_cfg)
from agile.rl_env import ManagerBasedRLEnvCfg
from agile.rl_env.managers import RewTerm, SceneEntityCfg
from agile.sim.terrain import ROUGH_TERRAINS_CFG
from agile.tasks.velocity import mdp
from agile.tasks.velocity.velocity_common import (BASE_HEIGHT_SENSOR, CONTACT_SENSOR, VelocityCriticObsCfg,
                                                  uniform_root_reset, velocity_command_cfg, velocity_curriculum_cfg,
                                                  velocity_events_cfg, velocity_policy_obs_cfg, velocity_scene_cfg,
                                                  velocity_sim_cfg, velocity_terminations_cfg)
from agile.utils.config import configclass

LEGS = SceneEntityCfg("robot", joint_names=LEG_JOINTS)
FEET = SceneEntityCfg("robot", body_names=FOOT_BODIES, preserve_order=True)
FEET_CONTACT = SceneEntityCfg(CONTACT_SENSOR, body_names=FOOT_BODIES, preserve_order=True)
BASE_HEIGHT_TARGET_M = 0.28
"""The trunk's height standing in the default crouch (`agile robot check`: 0.28 m)."""

# Isaac Lab's rough terrain as its Go1 task scales it for a robot of 0.28 m: boxes of at most 10 cm, rough ground of
# at most 6 cm (in 1 cm steps); the stairs and slopes stay
GO1_ROUGH_TERRAINS_CFG = dataclasses.replace(ROUGH_TERRAINS_CFG, sub_terrains={
    **ROUGH_TERRAINS_CFG.sub_terrains,
    "boxes": dataclasses.replace(ROUGH_TERRAINS_CFG.sub_terrains["boxes"], grid_height_range_m=(0.025, 0.1)),
    "random_rough": dataclasses.replace(ROUGH_TERRAINS_CFG.sub_terrains["random_rough"], noise_range_m=(0.01, 0.06),
                                        noise_step_m=0.01),
})

# -- scene: the robot alone on the terrain, with the contact sensor and the base-height ray
SCENE = velocity_scene_cfg(go1_robot_cfg(), GO1_ROUGH_TERRAINS_CFG, base_body=BASE_BODY,
                           sensed_bodies=[BASE_BODY, *THIGH_BODIES, *FOOT_BODIES])


@configclass
class CommandsCfg:
    base_velocity = velocity_command_cfg()


@configclass
class ActionsCfg:
    joint_pos = mdp.JointPositionActionCfg(joint_names=[LEG_JOINTS], scale=dict(ACTION_SCALE),
                                           use_default_offset=True)


@configclass
class ObservationsCfg:
    policy = velocity_policy_obs_cfg(LEGS)
    critic = VelocityCriticObsCfg()


@configclass
class RewardsCfg:
    # -- task
    termination_penalty = RewTerm(func=mdp.is_terminated, weight=-100.0)
    track_lin_vel_xy_exp = RewTerm(func=mdp.track_lin_vel_xy_exp, weight=2.0,
                                   params={"command_name": "base_velocity", "std": 0.5})
    track_ang_vel = RewTerm(func=mdp.track_ang_vel_z_exp, weight=1.0,
                            params={"command_name": "base_velocity", "std": 0.5})
    # -- base
    lin_vel_z = RewTerm(func=mdp.lin_vel_z_l2, weight=-2.0)
    ang_vel_xy = RewTerm(func=mdp.ang_vel_xy_l2, weight=-0.05)
    orientation = RewTerm(func=mdp.flat_orientation_l2, weight=-1.0)
    # -- joints
    torques = RewTerm(func=mdp.joint_torques_l2, weight=-2.0e-4, params={"asset_cfg": LEGS})
    dof_acc = RewTerm(func=mdp.joint_acc_l2, weight=-2.5e-7, params={"asset_cfg": LEGS})
    dof_pos_limits = RewTerm(func=mdp.joint_pos_limits, weight=-1.0)
    # -- actions (ramped by the curriculum)
    action_rate = RewTerm(func=mdp.action_rate_l2, weight=-0.01)
    action_rate_rate = RewTerm(func=mdp.action_rate_rate_l2, weight=-0.001)
    # -- feet and contacts
    feet_air_time = RewTerm(func=mdp.feet_air_time, weight=0.25,
                            params={"command_name": "base_velocity", "threshold_s": 0.3, "sensor_cfg": FEET_CONTACT})
    feet_slip = RewTerm(func=mdp.feet_slip, weight=-0.1, params={"sensor_cfg": FEET_CONTACT, "asset_cfg": FEET})
    thigh_contact = RewTerm(func=mdp.undesired_contacts, weight=-1.0,
                            params={"sensor_cfg": SceneEntityCfg(CONTACT_SENSOR, body_names=THIGH_BODIES),
                                    "force_threshold_n": 1.0})


@configclass
class RoughRewardsCfg(RewardsCfg):
    # the trunk's height above the terrain under it. Flat ground's height termination keeps the trunk up there (0.247 m
    # walking 0.5 m/s); without it on rough terrain the policy learnt to walk crouched (trunk at 0.136 m at iteration
    # 2,800, 2026-12-02). Soft (std 0.1 m), as the ray under the trunk reads a step's edge as the ground.
    base_height = RewTerm(func=mdp.base_height_exp, weight=1.0,
                          params={"target_height_m": BASE_HEIGHT_TARGET_M, "std": 0.1, "sensor_name": BASE_HEIGHT_SENSOR})


# any trunk contact ends the episode (Isaac Lab's Go1 `base_contact`), as does a tilt past 60° or (on flat ground) the
# trunk 15 cm below its standing height
FLAT_TERMINATIONS = velocity_terminations_cfg(BASE_HEIGHT_TARGET_M, trunk_bodies=[BASE_BODY], max_tilt_deg=60.0,
                                              contact_min_height_m=math.inf, height_margin_m=0.15)
# On rough terrain the base-height ray under the trunk lands on the next step or box: a trunk 15 cm "low" there is a
# Go1 climbing, not falling (with the height termination, 22% of the episodes ended so at iteration 1,900 and the
# mean terrain level stalled at 0.7; H200, 4,096 envs, 2026-12-02). Trunk contact and tilt end them, as in Isaac Lab's
# and mjlab's rough Go1 tasks.
ROUGH_TERMINATIONS = dataclasses.replace(FLAT_TERMINATIONS, illegal_base_height=None)


@configclass
class Go1VelocityEnvCfg(ManagerBasedRLEnvCfg):
    num_envs = 4096
    decimation = 4  # 50 Hz policy
    episode_length_s = 20.0
    scene = SCENE
    sim = velocity_sim_cfg(max_contacts_per_world=256)
    commands = CommandsCfg()
    actions = ActionsCfg()
    observations = ObservationsCfg()
    rewards = RoughRewardsCfg()
    terminations = ROUGH_TERMINATIONS
    events = velocity_events_cfg(base_body=BASE_BODY, base_mass_add_kg=(-1.0, 2.0),
                                 base_com_range_m={"x": (-0.05, 0.05), "y": (-0.03, 0.03), "z": (-0.03, 0.03)},
                                 extremity_bodies=FOOT_BODIES, base_wrench_n_nm=(5.0, 1.0),
                                 extremity_wrench_n_nm=(2.0, 0.1), reset_base=uniform_root_reset(xy_range_m=2.5))
    curriculum = velocity_curriculum_cfg(action_rate_final=-0.05, action_rate_rate_final=-0.005)


def go1_flat_velocity_env_cfg() -> Go1VelocityEnvCfg:
    """Velocity-Flat-Go1-v0: the rough task on flat ground, without the terrain curriculum, with the height
    termination in place of the height reward."""
    cfg = Go1VelocityEnvCfg()
    return dataclasses.replace(cfg, scene=dataclasses.replace(cfg.scene, terrain=None), rewards=RewardsCfg(),
                               terminations=FLAT_TERMINATIONS,
                               curriculum=dataclasses.replace(cfg.curriculum, terrain_levels=None))
