"""Velocity-G1-History-v0: Unitree G1 walks at commanded planar velocities from a 5-step observation
history, controlling its 12 leg joints plus waist roll and pitch (14).

AGILE `velocity_history_env_cfg.py`: medium-rough terrain (small boxes, random bumps up to 20 cm, waves up
to 25 cm) with the terrain curriculum, domain randomisation, pushes, and random arm motions the policy must
walk with (the waist yaw holds its default).
"""

from __future__ import annotations

import math

from agile.assets.unitree_g1 import LOWER_BODY_JOINTS, g1_robot_cfg
from agile.rl_env import ManagerBasedRLEnvCfg
from agile.rl_env.managers import RewTerm, SceneEntityCfg
from agile.sim.terrain import MEDIUM_ROUGH_TERRAIN_CFG
from agile.tasks.velocity import mdp
from agile.tasks.velocity.velocity_common import (BASE_HEIGHT_SENSOR, CONTACT_SENSOR, VelocityCriticObsCfg,
                                                   random_upper_body_action_cfg, velocity_command_cfg,
                                                   velocity_curriculum_cfg, velocity_events_cfg,
                                                   velocity_policy_obs_cfg, velocity_scene_cfg,
                                                   velocity_sim_cfg,
                                                   velocity_terminations_cfg, uniform_root_reset)
from agile.utils.config import configclass

CONTROLLED_JOINTS = [*LOWER_BODY_JOINTS, "waist_roll_joint", "waist_pitch_joint"]
CONTROLLED = SceneEntityCfg("robot", joint_names=CONTROLLED_JOINTS)
FOOT_BODIES = ["left_ankle_roll_link", "right_ankle_roll_link"]
FEET = SceneEntityCfg("robot", body_names=FOOT_BODIES, preserve_order=True)
FEET_CONTACT = SceneEntityCfg(CONTACT_SENSOR, body_names=FOOT_BODIES, preserve_order=True)
BASE_HEIGHT_TARGET_M = 0.72

# -- scene: the robot alone on the terrain, with the contact sensor and the base-height ray
SCENE = velocity_scene_cfg(g1_robot_cfg(), MEDIUM_ROUGH_TERRAIN_CFG, base_body="pelvis",
                           sensed_bodies=["pelvis", "torso_link", *FOOT_BODIES])


@configclass
class CommandsCfg:
    base_velocity = velocity_command_cfg()


@configclass
class ActionsCfg:
    joint_pos = mdp.JointPositionActionCfg(joint_names=CONTROLLED_JOINTS, scale=0.5, use_default_offset=True,
                                           clip=(-10.0, 10.0))
    random_pos = random_upper_body_action_cfg(excluded_joints=[*CONTROLLED_JOINTS, "waist_yaw_joint"])


@configclass
class ObservationsCfg:
    policy = velocity_policy_obs_cfg(CONTROLLED)
    critic = VelocityCriticObsCfg()


@configclass
class RewardsCfg:
    # -- task
    termination_penalty = RewTerm(func=mdp.is_terminated, weight=-100.0)
    track_lin_vel_xy_exp = RewTerm(func=mdp.track_lin_vel_xy_exp, weight=5.0,
                                   params={"command_name": "base_velocity", "std": 0.2})
    track_ang_vel = RewTerm(func=mdp.track_ang_vel_z_exp, weight=5.0, params={"command_name": "base_velocity", "std": 0.2})
    base_height = RewTerm(func=mdp.base_height_exp, weight=2.5,
                          params={"target_height_m": BASE_HEIGHT_TARGET_M, "std": 0.1,
                                  "sensor_name": BASE_HEIGHT_SENSOR})
    # -- base
    orientation = RewTerm(func=mdp.flat_body_orientation_exp, weight=5.0,
                          params={"std_rad": math.radians(10.0),
                                  "asset_cfg": SceneEntityCfg("robot", body_names=["pelvis", "torso_link"])})
    lin_vel_z = RewTerm(func=mdp.lin_vel_z_l2, weight=-0.25)
    ang_vel_xy = RewTerm(func=mdp.ang_vel_xy_l2, weight=-0.25)
    root_acc = RewTerm(func=mdp.body_acc_l2, weight=-1.0e-5,
                       params={"asset_cfg": SceneEntityCfg("robot", body_names="pelvis")})
    jumping = RewTerm(func=mdp.jumping, weight=-20.0, params={"sensor_cfg": FEET_CONTACT, "force_threshold_n": 10.0})
    # -- joints
    torques = RewTerm(func=mdp.joint_torques_l2, weight=-5.0e-5, params={"asset_cfg": CONTROLLED})
    ankle_torques = RewTerm(func=mdp.joint_torques_l2, weight=-1.0e-4,
                            params={"asset_cfg": SceneEntityCfg("robot", joint_names=".*_ankle_.*_joint")})
    ankle_roll_torques = RewTerm(func=mdp.joint_torques_l2, weight=-1.0e-3,
                                 params={"asset_cfg": SceneEntityCfg("robot", joint_names=".*_ankle_roll_joint")})
    # AGILE's G1 regularises only the joints the policy drives (T1's covers all joints)
    dof_vel = RewTerm(func=mdp.joint_vel_l2, weight=-1.0e-4, params={"asset_cfg": CONTROLLED})
    dof_pos_limits = RewTerm(func=mdp.joint_pos_limits, weight=-0.5, params={"asset_cfg": CONTROLLED})
    dof_vel_limits = RewTerm(func=mdp.joint_vel_limits, weight=-0.5,
                             params={"asset_cfg": CONTROLLED, "soft_ratio": 0.9})
    torque_limits = RewTerm(func=mdp.applied_torque_limits, weight=-0.005, params={"asset_cfg": CONTROLLED})
    # -- actions
    action_rate = RewTerm(func=mdp.action_rate_l2, weight=-0.25)
    action_rate_rate = RewTerm(func=mdp.action_rate_rate_l2, weight=-0.025)
    # -- feet
    feet_slip = RewTerm(func=mdp.feet_slip, weight=-0.05, params={"sensor_cfg": FEET_CONTACT, "asset_cfg": FEET})
    feet_roll = RewTerm(func=mdp.feet_roll_l2, weight=-0.05, params={"asset_cfg": FEET})
    feet_yaw_diff = RewTerm(func=mdp.feet_yaw_diff_l2, weight=-0.1, params={"asset_cfg": FEET})
    feet_yaw_mean = RewTerm(func=mdp.feet_yaw_mean_vs_base, weight=-2.0,
                            params={"feet_asset_cfg": FEET,
                                    "base_body_cfg": SceneEntityCfg("robot", body_names="pelvis")})
    feet_distance = RewTerm(func=mdp.feet_distance_from_ref, weight=-0.1,
                            params={"asset_cfg": FEET, "ref_distance_m": 0.2})


@configclass
class G1VelocityHistoryEnvCfg(ManagerBasedRLEnvCfg):
    num_envs = 4096
    decimation = 4  # 50 Hz policy
    episode_length_s = 30.0
    scene = SCENE
    sim = velocity_sim_cfg(max_contacts_per_world=256)  # standing about 55, flailing up to 125
    commands = CommandsCfg()
    actions = ActionsCfg()
    observations = ObservationsCfg()
    rewards = RewardsCfg()
    terminations = velocity_terminations_cfg(BASE_HEIGHT_TARGET_M, trunk_bodies=["torso_link", "pelvis"])
    events = velocity_events_cfg(base_body="pelvis", base_mass_add_kg=(-1.0, 5.0),
                                 base_com_range_m={"x": (-0.15, 0.25), "y": (-0.05, 0.05), "z": (-0.15, 0.15)},
                                 extremity_bodies=["left_wrist_yaw_link", "right_wrist_yaw_link", *FOOT_BODIES],
                                 reset_base=uniform_root_reset(xy_range_m=2.5))
    curriculum = velocity_curriculum_cfg(action_rate_final=-1.0, action_rate_rate_final=-0.5)
